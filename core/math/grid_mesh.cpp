#include "core/math/grid_mesh.h"

#include <cmath>

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

}  // namespace tesswave
