// Delaunay triangulation of a point set over the domain [0,W]x[0,H] (a triangle T0, DESIGN.md
// 2.1), e.g. for face-landmark files.
#pragma once

#include <span>

#include "core/math/geometry.h"
#include "core/math/mesh.h"

namespace tesswave {

struct TriangulateOptions {
    int border_points_per_side = 0;  // evenly spaced extra points inside each domain side
};

// Triangulates the given points plus the four domain corners plus, on each side, the points
// (k / (n + 1)) of the way along it for k = 1..n, n = border_points_per_side. A corner equal to a
// given point, and a border point within 4e-9 of the domain diagonal of one, is skipped. Vertex i
// of the result is points[i]; the extras follow. Triangles are counterclockwise in (x, y) and
// satisfy the empty-circle property (no vertex strictly inside any triangle's circumcircle),
// decided with exact predicates (Bowyer-Watson, Shewchuk-style expansion arithmetic), so
// co-circular and collinear points are handled without overlapping or zero-area triangles; where
// four or more points are co-circular the choice among the Delaunay triangulations depends only on
// the input. Points may lie on the domain border. Throws Error, naming the point, for a non-finite
// point, a point outside the domain or two points at the same position; also for points so close
// together (or so nearly collinear) that the result fails validate().
Mesh triangulate_points(double width, double height, std::span<const Vec2> points,
                        const TriangulateOptions& options = {});

}  // namespace tesswave
