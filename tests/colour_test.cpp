// The colour transforms: YCoCg-R is exactly invertible on integers, YCbCr inverts to float
// precision and maps grey to zero chroma, and the step factors follow the inverse's columns.
#include "core/math/colour.h"

#include <gtest/gtest.h>

#include <random>

namespace tesswave {
namespace {

TEST(Colour, ycocg_r_round_trips_every_integer_exactly) {
    std::mt19937 rng(5);
    std::uniform_int_distribution<int32_t> value(-70000, 70000);
    std::vector<int32_t> r(5000), g(5000), b(5000);
    for (size_t i = 0; i < r.size(); ++i) r[i] = value(rng), g[i] = value(rng), b[i] = value(rng);
    r[0] = 255, g[0] = 0, b[0] = 255;  // extremes of 8-bit input
    const auto r0 = r, g0 = g, b0 = b;
    ycocg_r_forward(r, g, b);
    EXPECT_NE(r, r0);
    ycocg_r_inverse(r, g, b);
    EXPECT_EQ(r, r0);
    EXPECT_EQ(g, g0);
    EXPECT_EQ(b, b0);
}

TEST(Colour, ycbcr_maps_grey_to_zero_chroma_and_inverts) {
    std::vector<float> r = {0.0f, 0.5f, 1.0f, 0.2f}, g = {0.0f, 0.5f, 1.0f, 0.7f},
                       b = {0.0f, 0.5f, 1.0f, 0.9f};
    const auto r0 = r, g0 = g, b0 = b;
    ycbcr_forward(r, g, b);
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(r[i], r0[i], 1e-6) << "Y of grey is the grey level";
        EXPECT_NEAR(g[i], 0.0f, 1e-6);
        EXPECT_NEAR(b[i], 0.0f, 1e-6);
    }
    EXPECT_NEAR(r[3], 0.299f * 0.2f + 0.587f * 0.7f + 0.114f * 0.9f, 1e-5);
    ycbcr_inverse(r, g, b);
    for (int i = 0; i < 4; ++i) {
        EXPECT_NEAR(r[i], r0[i], 1e-5);
        EXPECT_NEAR(g[i], g0[i], 1e-5);
        EXPECT_NEAR(b[i], b0[i], 1e-5);
    }
}

TEST(Colour, step_factors_are_one_for_grey_and_alpha_and_coarser_for_chroma) {
    EXPECT_EQ(ycbcr_step_factors(1), std::vector<float>{1.0f});
    const std::vector<float> f = ycbcr_step_factors(4);
    ASSERT_EQ(f.size(), 4u);
    EXPECT_FLOAT_EQ(f[0], 1.0f);
    EXPECT_GT(f[1], 1.0f);
    EXPECT_GT(f[2], 1.0f);
    EXPECT_FLOAT_EQ(f[3], 1.0f);
}

}  // namespace
}  // namespace tesswave
