// Regular grid tessellation: cols x rows equal rectangular cells over [0,W]x[0,H].
#pragma once

#include <cstdint>
#include <vector>

#include "core/math/hierarchy.h"
#include "core/math/mesh.h"

namespace tesswave {

// Vertex (i, j) has id j * (cols + 1) + i and sits at (i W / cols, j H / rows); faces are listed
// row by row with positive signed area. Throws Error for non-positive sizes or counts.
Mesh grid_mesh(double width, double height, int cols, int rows);

// The level-J samples of a cols x rows grid form a lattice: J steps of refinement split every
// cell into 2^J x 2^J, so T_J has (cols 2^J + 1) x (rows 2^J + 1) samples in a regular array
// (wherever the vertices were moved: the lattice is in the mesh's parameter domain). For a
// hierarchy built from a mesh with grid_mesh's faces, the row-major lattice index of each T_J
// sample. Throws Error when the hierarchy is not of such a grid.
// The lattice's columns or rows: cells 2^J + 1.
inline int64_t grid_lattice_side(int cells, int levels) { return (int64_t{cells} << levels) + 1; }
std::vector<int32_t> grid_lattice_index(const Hierarchy& hierarchy, int cols, int rows);

}  // namespace tesswave
