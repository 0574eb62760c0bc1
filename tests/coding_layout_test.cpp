#include "core/codec/coding_layout.h"

#include <gtest/gtest.h>

#include <map>
#include <set>

#include "core/math/grid_mesh.h"
#include "core/math/voronoi.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

// What the bit-plane coder relies on: `order` visits every coefficient once, band after band;
// neighbours are symmetric and primary on both sides (significance counts are pushed from the
// coefficient that turns significant to its own neighbour list); children are the reverse of
// parents.
void expect_consistent(const CodingLayout& l) {
    ASSERT_EQ(static_cast<int32_t>(l.order.size()), l.size);
    std::vector<int32_t> position(l.size, -1);
    for (size_t k = 0; k < l.order.size(); ++k) {
        ASSERT_EQ(position[l.order[k]], -1) << "coefficient " << l.order[k] << " twice";
        position[l.order[k]] = static_cast<int32_t>(k);
    }
    int32_t next = 0;
    for (const CodingBand& b : l.bands) {
        EXPECT_EQ(b.begin, next);
        EXPECT_GT(b.end, b.begin);
        EXPECT_GT(b.norm, 0.0);
        next = b.end;
    }
    EXPECT_EQ(next, l.size);
    std::map<std::pair<int32_t, int32_t>, bool> edges;  // (from, to) -> primary
    std::multiset<std::pair<int32_t, int32_t>> parent_links, child_links;
    for (size_t k = 0; k < l.order.size(); ++k) {
        const int32_t id = l.order[k];
        const int32_t begin = l.nb_offsets[k];
        ASSERT_LE(l.nb_primary[k], l.nb_offsets[k + 1] - begin);
        for (int32_t i = begin; i < l.nb_offsets[k + 1]; ++i) {
            EXPECT_NE(l.nb[i], id);
            EXPECT_TRUE(edges.emplace(std::pair{id, l.nb[i]}, i < begin + l.nb_primary[k]).second)
                << "neighbour listed twice";
        }
        for (int32_t i = l.pa_offsets[k]; i < l.pa_offsets[k + 1]; ++i) {
            parent_links.insert({l.pa[i], id});
        }
    }
    for (const auto& [e, primary] : edges) {
        const auto back = edges.find({e.second, e.first});
        ASSERT_NE(back, edges.end()) << e.first << " -> " << e.second << " has no way back";
        EXPECT_EQ(back->second, primary) << e.first << " <-> " << e.second;
    }
    for (int32_t p = 0; p < l.size; ++p) {
        for (int32_t i = l.ch_offsets[p]; i < l.ch_offsets[p + 1]; ++i)
            child_links.insert({p, l.ch[i]});
    }
    EXPECT_EQ(parent_links, child_links);
}

TEST(CodingLayout, mesh_layouts_are_consistent) {
    const Mesh meshes[] = {grid_mesh(40, 30, 3, 2), samples::paper_t0(60, 50),
                           samples::paper_t0_with_features(60, 50),
                           voronoi_mesh(50, 40, {.sites = 12, .seed = 3, .lloyd_iterations = 1}),
                           testing::deformed_grid(30, 30, 3, 3, 0.2, 5)};
    for (const Mesh& mesh : meshes) {
        const Hierarchy h = build_hierarchy(mesh, {.levels = 3});
        const CodingLayout l = mesh_layout(h, mesh.width * mesh.height, 1);
        EXPECT_EQ(l.bands.size(), 7u);
        expect_consistent(l);
    }
}

TEST(CodingLayout, grid_layouts_are_consistent) {
    for (auto [w, h] : {std::pair{32, 32}, std::pair{37, 23}, std::pair{1, 9}, std::pair{64, 3}}) {
        for (GridWavelet wavelet : {GridWavelet::cdf53, GridWavelet::cdf97}) {
            SCOPED_TRACE(::testing::Message() << w << "x" << h);
            expect_consistent(grid_layout(w, h, 4, wavelet, true, GridRelations::listed));
        }
    }
}

// The computed form holds the same order and bands as the listed one, and the bands' rectangles
// with their child bands: the same orientation one level finer.
TEST(CodingLayout, computed_grid_layouts_hold_the_listed_order_and_bands) {
    for (auto [w, h] : {std::pair{32, 32}, std::pair{37, 23}, std::pair{1, 9}, std::pair{64, 3}}) {
        SCOPED_TRACE(::testing::Message() << w << "x" << h);
        const CodingLayout c = grid_layout(w, h, 4, GridWavelet::cdf53);
        const CodingLayout l =
            grid_layout(w, h, 4, GridWavelet::cdf53, true, GridRelations::listed);
        EXPECT_EQ(c.order, l.order);
        ASSERT_EQ(c.bands.size(), l.bands.size());
        ASSERT_EQ(c.grid_bands.size(), c.bands.size());
        ASSERT_EQ(c.grid_child_band.size(), c.bands.size());
        EXPECT_EQ(c.grid_width, w);
        EXPECT_TRUE(c.nb.empty() && c.nb_offsets.empty() && c.ch.empty() && c.ch_offsets.empty());
        for (size_t b = 0; b < c.bands.size(); ++b) {
            EXPECT_EQ(c.bands[b].begin, l.bands[b].begin);
            EXPECT_EQ(c.bands[b].end, l.bands[b].end);
            EXPECT_EQ(c.bands[b].norm, l.bands[b].norm);
            const GridBand& g = c.grid_bands[b];
            EXPECT_EQ(c.bands[b].end - c.bands[b].begin, g.width * g.height);
            // Detail bands above level 1 have children: the band three on, one level finer.
            const int32_t child = c.grid_child_band[b];
            if (g.type == 0 || g.level == 1) {
                EXPECT_EQ(child, -1) << "band " << b;
                continue;
            }
            ASSERT_EQ(child, static_cast<int32_t>(b) + 3) << "band " << b;
            EXPECT_EQ(c.grid_bands[child].type, g.type);
            EXPECT_EQ(c.grid_bands[child].level + 1, g.level);
        }
    }
}

// The norms of the small plane grid_layout measures on equal those of the whole plane.
TEST(CodingLayout, grid_norms_match_the_full_plane) {
    const CodingLayout l = grid_layout(400, 200, 2, GridWavelet::cdf97);
    std::vector<float> x(400 * 200);
    for (size_t b = 0; b < l.bands.size(); ++b) {
        const GridBand g = grid_bands(400, 200, 2)[b];
        std::fill(x.begin(), x.end(), 0.0f);
        x[(g.y0 + g.height / 2) * 400 + g.x0 + g.width / 2] = 1.0f;
        grid_inverse(x, 400, 200, {.wavelet = GridWavelet::cdf97, .levels = 2});
        double energy = 0;
        for (float v : x) energy += double{v} * v;
        EXPECT_NEAR(l.bands[b].norm, std::sqrt(energy), 1e-5 * std::sqrt(energy)) << "band " << b;
    }
}

}  // namespace
}  // namespace tesswave
