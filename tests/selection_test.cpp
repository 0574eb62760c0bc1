#include "core/math/selection.h"

#include <gtest/gtest.h>

#include <random>

#include "core/math/lifting.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::uniform;

TEST(Selection, paper_rule_keeps_exactly_the_requested_count) {
    const Hierarchy h = build_hierarchy(samples::paper_t0(100, 80), {.levels = 4});
    const int32_t n = h.num_samples(4), n0 = h.num_samples(0);
    std::mt19937_64 rng(1);
    for (double percent : {100.0, 10.0, 1.0, 0.1, 0.01}) {
        std::vector<float> r(n), g(n), b(n);
        for (int32_t i = 0; i < n; ++i) {
            // Many exact ties (quantized values) so the tie-break is exercised.
            r[i] = static_cast<float>(std::floor(uniform(rng) * 8));
            g[i] = static_cast<float>(std::floor(uniform(rng) * 8));
            b[i] = 0;
        }
        const auto base = std::vector<float>(r.begin(), r.begin() + n0);
        std::span<float> planes[] = {r, g, b};
        const int64_t want = keep_count(n - n0, percent);
        EXPECT_EQ(keep_largest(planes, n0, want), want);
        int64_t nonzero = 0;
        for (int32_t i = n0; i < n; ++i) nonzero += (r[i] != 0 || g[i] != 0);
        EXPECT_LE(nonzero, want) << percent;  // kept zeros count as kept
        EXPECT_EQ(std::vector<float>(r.begin(), r.begin() + n0), base) << "base level kept";
    }
    EXPECT_THROW(keep_count(100, 0), Error);
    EXPECT_THROW(keep_count(100, 100.5), Error);
}

TEST(Selection, keeps_the_largest_by_euclidean_length) {
    std::vector<float> a = {9, 0, 3, 0, 4}, b = {9, 1, 4, 0, 0};
    std::span<float> planes[] = {a, b};
    keep_largest(planes, 1, 2);  // lengths of 1..4: 1, 5, 0, 4 -> keep indices 2 and 4
    EXPECT_EQ(a, (std::vector<float>{9, 0, 3, 0, 4}));
    EXPECT_EQ(b, (std::vector<float>{9, 0, 4, 0, 0}));
}

// Band norms: on a regular grid, coarser bands have larger basis functions; each norm equals
// the L2 norm of the reconstructed impulse integrated over the domain.
TEST(Selection, band_norms_grow_with_scale) {
    const Mesh mesh = grid_mesh(64, 64, 2, 2);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 5});
    const auto bands = mesh_bands(h, 64.0 * 64.0);
    ASSERT_EQ(bands.size(), 10u);
    for (size_t i = 2; i < bands.size(); ++i) {
        EXPECT_LT(bands[i].norm, bands[i - 2].norm) << "level " << bands[i].level << bands[i].type;
        EXPECT_GT(bands[i].norm, 0.0);
    }
    // The finest e band: a tent of half-width one sample spacing (1 px) along one axis.
    EXPECT_NEAR(bands[8].norm, bands[6].norm / 2, bands[6].norm * 0.15);
}

}  // namespace
}  // namespace tesswave
