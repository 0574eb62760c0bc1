// The geometry between two meshes of one topology (DESIGN.md 3): vertex interpolation, with
// detection and repair of faces that fold or turn non-convex part-way.
#pragma once

#include <span>
#include <vector>

#include "core/math/mesh.h"

namespace tesswave::morph {

// The faces of `mesh` (its topology) with vertex positions `vertices` that are not strictly
// convex: a corner whose turn is below `min_sine` times the product of its edge lengths.
std::vector<int> folded_faces(const Mesh& mesh, std::span<const Vec2> vertices,
                              double min_sine = 1e-3);

struct GeometryReport {
    int folded = 0;      // faces that folded under plain interpolation
    int iterations = 0;  // repair sweeps it took
};

// (1 - s) a + s b, then, while any face is folded, a sweep that moves each free vertex of the
// folded faces halfway to the mean of its neighbours (border vertices along their side, corners
// fixed). Throws Error when 500 sweeps leave a face folded: a folded mesh is never returned.
// `a` and `b` are on one domain [0,W]x[0,H] (mesh.width, mesh.height).
std::vector<Vec2> interpolate_geometry(const Mesh& mesh, std::span<const Vec2> a,
                                       std::span<const Vec2> b, double s,
                                       GeometryReport* report = nullptr);

}  // namespace tesswave::morph
