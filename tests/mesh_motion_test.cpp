// Vertex motion side information on its own: round trips on the 1/4-pixel grid, no bytes' worth
// of residuals for a uniform pan after the first step, and refusal of motion that breaks the mesh.
#include "video/mesh_motion.h"

#include <gtest/gtest.h>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"

namespace tesswave::video {
namespace {

Mesh rest_mesh() {
    Mesh m = grid_mesh(160, 120, 8, 6);
    m.vertices = round_to_motion_unit(m.vertices);
    return m;
}

// Interior vertices moved by (dx, dy); the border stays put (it slides in the encoder).
std::vector<Vec2> moved(const Mesh& m, std::span<const Vec2> from, double dx, double dy) {
    std::vector<Vec2> out(from.begin(), from.end());
    for (size_t i = 0; i < out.size(); ++i) {
        const Vec2 p = m.vertices[i];
        if (p.x > 0 && p.x < m.width && p.y > 0 && p.y < m.height)
            out[i] = {out[i].x + dx, out[i].y + dy};
    }
    return round_to_motion_unit(out);
}

TEST(MeshMotion, positions_round_to_quarter_pixels) {
    const std::vector<Vec2> p =
        round_to_motion_unit(std::vector<Vec2>{{1.13, 2.37}, {-0.1, 7.874}});
    EXPECT_DOUBLE_EQ(p[0].x, 1.25);
    EXPECT_DOUBLE_EQ(p[0].y, 2.25);
    EXPECT_DOUBLE_EQ(p[1].x, 0.0);
    EXPECT_DOUBLE_EQ(p[1].y, 7.75);
}

TEST(MeshMotion, coded_positions_decode_exactly) {
    const Mesh m = rest_mesh();
    const std::vector<Vec2> f1 = moved(m, m.vertices, 1.25, -0.5);
    const std::vector<Vec2> f2 = moved(m, f1, 1.5, -0.25);
    const auto bytes1 = encode_motion(m, f1, m.vertices, {});
    EXPECT_EQ(decode_motion(bytes1, m.vertices, {}, m, "frame 1"), f1);
    const auto bytes2 = encode_motion(m, f2, f1, m.vertices);
    EXPECT_EQ(decode_motion(bytes2, f1, m.vertices, m, "frame 2"), f2);
}

TEST(MeshMotion, a_steady_pan_costs_less_once_its_velocity_is_known) {
    const Mesh m = rest_mesh();
    const std::vector<Vec2> f1 = moved(m, m.vertices, 2.0, 1.0);
    const std::vector<Vec2> f2 = moved(m, f1, 2.0, 1.0);
    const size_t first = encode_motion(m, f1, m.vertices, {}).size();
    const size_t steady = encode_motion(m, f2, f1, m.vertices).size();
    EXPECT_LT(steady, first);
}

TEST(MeshMotion, a_truncated_stream_or_a_folding_motion_is_refused) {
    const Mesh m = rest_mesh();
    const std::vector<Vec2> f1 = moved(m, m.vertices, 1.0, 1.0);
    const auto bytes = encode_motion(m, f1, m.vertices, {});
    ASSERT_GT(bytes.size(), 2u);
    EXPECT_THROW(decode_motion(std::span(bytes).first(bytes.size() / 2), m.vertices, {}, m, "cut"),
                 Error);
    // One interior vertex pushed across its neighbours: the mesh folds.
    std::vector<Vec2> folded = m.vertices;
    folded[10] = {folded[10].x + 60, folded[10].y};
    folded = round_to_motion_unit(folded);
    const auto fold_bytes = encode_motion(m, folded, m.vertices, {});
    EXPECT_THROW(decode_motion(fold_bytes, m.vertices, {}, m, "fold"), Error);
}

}  // namespace
}  // namespace tesswave::video
