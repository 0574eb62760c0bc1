#include "core/math/grid_mesh.h"

#include <cmath>
#include <cstdint>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {

Mesh grid_mesh(double width, double height, int cols, int rows) {
    if (!(width > 0 && height > 0 && std::isfinite(width) && std::isfinite(height))) {
        throw Error(str("grid: domain ", width, " x ", height, " must be positive"));
    }
    if (cols < 1 || rows < 1 || int64_t{cols} * rows > 10'000'000) {
        throw Error(str("grid: ", cols, "x", rows, " cells: need 1 to 10 million cells"));
    }
    Mesh mesh;
    mesh.width = width;
    mesh.height = height;
    for (int j = 0; j <= rows; ++j) {
        for (int i = 0; i <= cols; ++i) {
            // Exact border coordinates: i == cols must give exactly W, not W*(1 - ulp).
            mesh.vertices.push_back(
                {i == cols ? width : width * i / cols, j == rows ? height : height * j / rows});
        }
    }
    for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < cols; ++i) {
            const int32_t a = j * (cols + 1) + i;
            const int32_t corners[4] = {a, a + 1, a + cols + 2, a + cols + 1};
            mesh.add_face(corners);
        }
    }
    return mesh;
}

std::vector<int32_t> grid_lattice_index(const Hierarchy& hierarchy, int cols, int rows) {
    const int J = hierarchy.finest();
    const int64_t width = grid_lattice_side(cols, J), height = grid_lattice_side(rows, J);
    const int32_t n = hierarchy.num_samples(J);
    if (J > 20 || width * height != n ||
        hierarchy.num_samples(0) != int64_t{cols + 1} * (rows + 1)) {
        throw Error(str("the mesh is not a ", cols, "x", rows, " grid"));
    }
    // Refined from the grid of unit cells scaled by 2^J, every T_J sample sits on an integer
    // point: edge and face points are means of 2 and 4 positions, exact in binary.
    const double unit = std::ldexp(1.0, J);
    const Mesh grid = grid_mesh(cols * unit, rows * unit, cols, rows);
    const std::vector<Vec2> p = refine_positions(hierarchy, grid.vertices, J);
    std::vector<int32_t> index(p.size());
    std::vector<bool> taken(p.size(), false);
    for (size_t i = 0; i < p.size(); ++i) {
        // In range first (NaN fails), then whole: the casts are exact only for integers.
        const bool inside = p[i].x >= 0 && p[i].y >= 0 && p[i].x < static_cast<double>(width) &&
                            p[i].y < static_cast<double>(height);
        const int64_t x = inside ? static_cast<int64_t>(p[i].x) : 0;
        const int64_t y = inside ? static_cast<int64_t>(p[i].y) : 0;
        const int64_t k = y * width + x;
        if (!inside || static_cast<double>(x) != p[i].x || static_cast<double>(y) != p[i].y ||
            taken[k]) {
            throw Error(str("the mesh is not a ", cols, "x", rows, " grid"));
        }
        taken[k] = true;
        index[i] = static_cast<int32_t>(k);
    }
    return index;
}

}  // namespace tesswave
