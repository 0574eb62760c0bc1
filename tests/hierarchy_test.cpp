#include "core/math/hierarchy.h"

#include <gtest/gtest.h>

#include "core/math/error.h"
#include "core/math/lifting.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/voronoi.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

int64_t boundary_edges(const LevelTopology& t) {
    int64_t b = 0;
    for (auto f : t.edge_f) b += f[1] == -1;
    return b;
}

TEST(Hierarchy, paper_mesh_has_the_papers_counts) {
    const Mesh mesh = samples::paper_t0(249, 251);
    testing::expect_valid(mesh);
    const auto counts = level_counts(mesh, 7);
    EXPECT_EQ(counts[0].vertices, 20);
    EXPECT_EQ(counts[0].faces, 14);
    EXPECT_EQ(counts[0].edges, 33);
    EXPECT_EQ(counts[0].boundary_edges, 13);
    EXPECT_EQ(static_cast<int64_t>(mesh.face_corners.size()), 53);  // q
    EXPECT_EQ(counts[7].vertices, 217921);
}

TEST(Hierarchy, counts_match_euler_formula_and_explicit_refinement) {
    const Mesh mesh = samples::paper_t0(249, 251);
    const int64_t q = 53, B = 13;
    const auto counts = level_counts(mesh, 7);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 7});
    ASSERT_EQ(h.finest(), 7);
    for (int j = 0; j <= 7; ++j) {
        const LevelTopology& t = h.levels[j];
        if (j >= 1) {
            EXPECT_EQ(counts[j].vertices,
                      1 + q * (int64_t{1} << (2 * (j - 1))) + B * (1 << (j - 1)))
                << "level " << j;
        }
        EXPECT_EQ(t.n_vertices, counts[j].vertices) << "level " << j;
        EXPECT_EQ(t.num_edges(), counts[j].edges) << "level " << j;
        EXPECT_EQ(t.num_faces(), counts[j].faces) << "level " << j;
        EXPECT_EQ(boundary_edges(t), counts[j].boundary_edges) << "level " << j;
        EXPECT_EQ(t.n_vertices - t.num_edges() + t.num_faces(), 1) << "Euler, level " << j;
    }
    EXPECT_EQ(h.num_samples(7), 217921);
}

TEST(Hierarchy, numbering_is_nested_and_centroids_are_vertex_averages) {
    const Mesh mesh = testing::deformed_grid(30, 20, 3, 2, 0.2, 7);
    testing::expect_valid(mesh);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    for (int j = 0; j < 3; ++j) {
        const auto coarse = refine_positions(h, mesh.vertices, j);
        const auto fine = refine_positions(h, mesh.vertices, j + 1);
        for (size_t i = 0; i < coarse.size(); ++i) ASSERT_EQ(coarse[i], fine[i]);
        const LevelTopology& t = h.levels[j];
        for (int32_t k = 0; k < t.num_faces(); ++k) {
            Vec2 sum{};
            const int32_t b = t.face_offsets[k], e = t.face_offsets[k + 1];
            for (int32_t c = b; c < e; ++c) sum = sum + fine[t.face_v[c]];
            const Vec2 centroid = fine[t.n_vertices + t.num_edges() + k];
            EXPECT_NEAR(centroid.x, sum.x / (e - b), 1e-12);
            EXPECT_NEAR(centroid.y, sum.y / (e - b), 1e-12);
        }
    }
    // From T1 on, every face is a quad whose corners are (vertex, midpoint, centroid, midpoint).
    for (int j = 1; j <= 3; ++j) {
        for (int32_t k = 0; k <= h.levels[j].num_faces(); ++k) {
            EXPECT_EQ(h.levels[j].face_offsets[k], 4 * k);
        }
    }
}

TEST(Hierarchy, refined_faces_keep_the_orientation_and_tile_the_domain) {
    const Mesh mesh = samples::paper_t0(100, 80);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 2});
    const auto p = refine_positions(h, mesh.vertices, 2);
    Mesh refined;
    refined.width = 100;
    refined.height = 80;
    refined.vertices = p;
    refined.face_offsets.assign(h.levels[2].face_offsets.begin(), h.levels[2].face_offsets.end());
    refined.face_corners.assign(h.levels[2].face_v.begin(), h.levels[2].face_v.end());
    testing::expect_valid(refined);
}

TEST(Hierarchy, features_get_one_sample_per_side) {
    const Mesh mesh = samples::paper_t0_with_features(100, 80);
    testing::expect_valid(mesh);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
    // Vertices 5 (border), 6 and 7 (on the curve) have two sides; 8 ends the curve: one sample.
    ASSERT_EQ(h.num_samples(0), 23);
    EXPECT_EQ(h.source_vertex[20], 5);
    EXPECT_EQ(h.source_vertex[21], 6);
    EXPECT_EQ(h.source_vertex[22], 7);
    const auto& kind = h.levels[0].kind;
    EXPECT_EQ(kind[5], PointKind::corner);  // a feature meets the border
    EXPECT_EQ(kind[6], PointKind::curve);
    EXPECT_EQ(kind[21], PointKind::curve);
    EXPECT_EQ(kind[8], PointKind::corner);  // end of the feature curve
    EXPECT_EQ(kind[0], PointKind::corner);  // domain corner
    EXPECT_EQ(kind[2], PointKind::curve);   // border vertex on a straight side
    EXPECT_EQ(kind[1], PointKind::interior);
    // Each feature edge is cut into two boundary edges: 13 + 2 * 3 in the cut mesh.
    EXPECT_EQ(boundary_edges(h.levels[0]), 19);
    EXPECT_EQ(sample_count(mesh, 3), h.num_samples(3));
    // The geometric count (no duplicates) is unchanged by features.
    EXPECT_EQ(level_counts(mesh, 3)[3].vertices,
              level_counts(samples::paper_t0(100, 80), 3)[3].vertices);
}

TEST(Hierarchy, refuses_huge_levels_before_allocating) {
    const Mesh mesh = samples::paper_t0(100, 80);
    try {
        build_hierarchy(mesh, {.levels = 14});
        FAIL() << "level 14 must be refused";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("needs 3556876289 samples"), std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("MiB"), std::string::npos) << e.what();
    }
    EXPECT_THROW(build_hierarchy(mesh, {.levels = -1}), Error);
}

TEST(Hierarchy, rejects_invalid_meshes) {
    Mesh mesh = samples::paper_t0(100, 80);
    mesh.vertices[6] = {60, 60};  // folds faces around vertex 6
    EXPECT_THROW(build_hierarchy(mesh, {.levels = 2}), Error);
}

// Without finest_topology, T_J keeps what sampling, rendering and the transform read, and they
// give the same values to the bit as on the full hierarchy; T_J's edges, faces and stars are gone.
TEST(Hierarchy, a_light_finest_level_serves_sampling_rendering_and_the_transform_alike) {
    const Mesh mesh = voronoi_mesh(96, 64, {.sites = 12, .seed = 3});
    const Hierarchy full = build_hierarchy(mesh, {.levels = 4});
    const Hierarchy light = build_hierarchy(mesh, {.levels = 4, .finest_topology = false});
    ASSERT_EQ(light.finest(), 4);
    EXPECT_FALSE(light.levels[4].topology);
    EXPECT_EQ(light.levels[4].num_edges(), 0);
    EXPECT_TRUE(light.levels[4].star_e.empty());
    EXPECT_GT(full.levels[4].num_edges(), 0);
    for (int j = 0; j < 4; ++j) EXPECT_TRUE(light.levels[j].topology) << j;
    EXPECT_EQ(light.levels[4].n_vertices, full.levels[4].n_vertices);
    EXPECT_EQ(light.levels[4].patch_grid, full.levels[4].patch_grid);

    const Image image = samples::scene_image(96, 64, 3);
    auto run = [&](const Hierarchy& h) {
        std::vector<std::vector<float>> x = sample_image(image, h, mesh.vertices);
        std::vector<std::span<float>> s(x.begin(), x.end());
        forward_transform(h, s);
        inverse_transform(h, s);
        const std::vector<std::span<const float>> in(x.begin(), x.end());
        const Image back = render(plan_render(h, mesh.vertices, 96, 64, 96, 64), in);
        return std::make_pair(x, back.planes);
    };
    EXPECT_EQ(run(light), run(full));
}

}  // namespace
}  // namespace tesswave
