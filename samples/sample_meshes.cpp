#include "sample_meshes.h"

namespace tesswave::samples {

Mesh paper_t0(double width, double height) {
    // clang-format off
    static constexpr double kUnit[20][2] = {
        {0.00, 0.00}, {0.24, 0.15}, {0.50, 0.00}, {0.75, 0.00}, {1.00, 0.00},
        {0.00, 0.30}, {0.22, 0.36}, {0.52, 0.30}, {0.78, 0.38}, {1.00, 0.35},
        {0.00, 0.68}, {0.27, 0.64}, {0.48, 0.70}, {0.74, 0.62}, {1.00, 0.66},
        {0.00, 1.00}, {0.25, 1.00}, {0.55, 1.00}, {0.80, 1.00}, {1.00, 1.00},
    };
    static constexpr int32_t kQuads[11][4] = {
        {0, 1, 6, 5},     {1, 2, 7, 6},     {2, 3, 8, 7},     {3, 4, 9, 8},
        {5, 6, 11, 10},   {6, 7, 12, 11},   {7, 8, 13, 12},   {8, 9, 14, 13},
        {10, 11, 16, 15}, {11, 12, 17, 16}, {12, 13, 18, 17},
    };
    static constexpr int32_t kTriangles[3][3] = {{0, 2, 1}, {13, 14, 19}, {13, 19, 18}};
    // clang-format on
    Mesh mesh;
    mesh.width = width;
    mesh.height = height;
    for (auto [x, y] : kUnit) {
        mesh.vertices.push_back({x == 1.0 ? width : x * width, y == 1.0 ? height : y * height});
    }
    for (const auto& q : kQuads) mesh.add_face(q);
    for (const auto& t : kTriangles) mesh.add_face(t);
    return mesh;
}

Mesh paper_t0_with_features(double width, double height) {
    Mesh mesh = paper_t0(width, height);
    mesh.features = {{5, 6}, {6, 7}, {7, 8}};  // from the left border to vertex 8 inside
    return mesh;
}

}  // namespace tesswave::samples
