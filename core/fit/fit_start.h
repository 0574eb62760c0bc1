// The start of a mesh fit (mesh_fit.cpp): the frame that maps A's domain onto B's, and the
// initial vertices and per-face transforms the Ceres problem starts from. Internal to core/fit.
#pragma once

#include <span>
#include <vector>

#include "core/fit/mesh_fit.h"

namespace tesswave::fit_detail {

enum Side : int { kLeft = 1, kRight = 2, kTop = 4, kBottom = 8 };

// The frame of the fit: each vertex's border sides on A and its position r scaled to B.
struct Frame {
    double width = 0, height = 0;  // B's domain
    double sx = 1, sy = 1;         // A -> B scale
    std::vector<int> sides;
    std::vector<Vec2> reference;

    Vec2 scale(Vec2 a) const { return {a.x * sx, a.y * sy}; }
    Vec2 snap(int v, Vec2 p) const;  // onto vertex v's sides, exactly
};

Frame make_frame(const Mesh& a, double width_b, double height_b);

// The start: the previous frame's vertices if given, else the robust affine fit of the matches
// applied to r, each snapped to the border and taken if it is a valid mesh; r itself otherwise
// (always valid: a scaled valid mesh).
std::vector<Vec2> initial_vertices(const Mesh& a, const Frame& frame,
                                   std::span<const Vec2> points_a, std::span<const Vec2> points_b,
                                   const MeshFitOptions& options);

// The best S_f from r to x for every face (closed form), the start of the per-face parameters.
std::vector<double> initial_transforms(const Mesh& a, const Frame& frame,
                                       const std::vector<Vec2>& x, Rigidity rigidity);

}  // namespace tesswave::fit_detail
