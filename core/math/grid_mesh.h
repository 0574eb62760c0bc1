// Regular grid tessellation: cols x rows equal rectangular cells over [0,W]x[0,H].
#pragma once

#include "core/math/mesh.h"

namespace tesswave {

// Vertex (i, j) has id j * (cols + 1) + i and sits at (i W / cols, j H / rows); faces are listed
// row by row with positive signed area. Throws Error for non-positive sizes or counts.
Mesh grid_mesh(double width, double height, int cols, int rows);

}  // namespace tesswave
