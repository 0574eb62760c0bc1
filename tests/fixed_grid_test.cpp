#include "core/math/fixed_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/math/error.h"

namespace tesswave {
namespace {

struct Size {
    int width;
    int height;
};

const std::vector<Size> kSizes = {{1, 1}, {1, 7},  {7, 1},   {2, 2},
                                  {3, 5}, {17, 9}, {64, 48}, {101, 67}};

// Uniform in [0, 255] from raw mt19937 output, identical on every standard library.
std::vector<float> random_plane(int width, int height, uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<float> plane(static_cast<size_t>(width) * height);
    for (float& v : plane) v = static_cast<float>(rng() >> 8) * (255.0f / 16777215.0f);
    return plane;
}

// Uniform in [-32768, 32767], so that floor rounding of negative values is exercised too.
std::vector<int32_t> random_int_plane(int width, int height, uint32_t seed) {
    std::mt19937 rng(seed);
    std::vector<int32_t> plane(static_cast<size_t>(width) * height);
    for (int32_t& v : plane) v = static_cast<int32_t>(rng() >> 16) - 32768;
    return plane;
}

float max_abs_difference(const std::vector<float>& a, const std::vector<float>& b) {
    float worst = 0.0f;
    for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(a[i] - b[i]));
    return worst;
}

std::string describe(Size size, int levels) {
    return std::to_string(size.width) + "x" + std::to_string(size.height) + ", " +
           std::to_string(levels) + " levels";
}

// Float32 lifting loses about one rounding per step; the 9/7's steps pass through values ~4x the
// input (alpha = -1.59), which puts its round trip near 2e-4..4e-4 on [0, 255] (~1.5e-6 relative).
void expect_float_round_trip(GridWavelet wavelet, float tolerance) {
    uint32_t seed = 1;
    for (const Size size : kSizes) {
        for (int levels = 1; levels <= 6; ++levels) {
            const std::vector<float> original = random_plane(size.width, size.height, seed++);
            std::vector<float> plane = original;
            const GridTransformOptions options{.wavelet = wavelet, .levels = levels};
            grid_forward(plane, size.width, size.height, options);
            if (size.width >= 2 && size.height >= 2) {
                EXPECT_GT(max_abs_difference(plane, original), 1.0f) << describe(size, levels);
            }
            grid_inverse(plane, size.width, size.height, options);
            EXPECT_LT(max_abs_difference(plane, original), tolerance) << describe(size, levels);
        }
    }
}

TEST(FixedGrid, float_53_reconstructs_perfectly) {
    expect_float_round_trip(GridWavelet::cdf53, 1e-4f);
}

TEST(FixedGrid, float_97_reconstructs_perfectly) {
    expect_float_round_trip(GridWavelet::cdf97, 5e-4f);
}

TEST(FixedGrid, int53_reconstructs_bit_exactly) {
    uint32_t seed = 100;
    for (const Size size : kSizes) {
        for (int levels = 1; levels <= 6; ++levels) {
            const std::vector<int32_t> original = random_int_plane(size.width, size.height, seed++);
            std::vector<int32_t> plane = original;
            grid_forward_int53(plane, size.width, size.height, levels);
            if (size.width >= 2 && size.height >= 2) {
                EXPECT_NE(plane, original) << describe(size, levels);
            }
            grid_inverse_int53(plane, size.width, size.height, levels);
            EXPECT_EQ(plane, original) << describe(size, levels);
        }
    }
}

TEST(FixedGrid, int53_inverse_in_int64_matches_int32) {
    uint32_t seed = 300;
    for (const Size size : kSizes) {
        std::vector<int32_t> narrow = random_int_plane(size.width, size.height, seed++);
        grid_forward_int53(narrow, size.width, size.height, 4);
        // Arbitrary coefficients too, not only those of a forward transform.
        for (size_t i = 0; i < narrow.size(); i += 3)
            narrow[i] = static_cast<int32_t>(i % 1000) - 500;
        std::vector<int64_t> wide(narrow.begin(), narrow.end());
        grid_inverse_int53(narrow, size.width, size.height, 4);
        grid_inverse_int53(wide, size.width, size.height, 4);
        EXPECT_EQ(std::vector<int64_t>(narrow.begin(), narrow.end()), wide) << describe(size, 4);
    }
}

// Whole-sample symmetric extension, for the direct formulas below.
int mirror(int i, int n) {
    while (i < 0 || i >= n) i = i < 0 ? -i : 2 * (n - 1) - i;
    return i;
}

// JPEG 2000 Part 1 analysis filters in convolution form (Table F.4 for the 9/7), taps 0, 1, 2..
// from the centre; lows at even positions, highs at odd.
std::vector<double> direct_filter(const std::vector<double>& x, const std::vector<double>& low,
                                  const std::vector<double>& high) {
    const int n = static_cast<int>(x.size());
    const int nl = (n + 1) / 2;
    std::vector<double> out(n);
    for (int p = 0; p < n; ++p) {
        const std::vector<double>& taps = p % 2 == 0 ? low : high;
        double sum = taps[0] * x[p];
        for (int k = 1; k < static_cast<int>(taps.size()); ++k) {
            sum += taps[k] * (x[mirror(p - k, n)] + x[mirror(p + k, n)]);
        }
        out[p % 2 == 0 ? p / 2 : nl + p / 2] = sum;
    }
    return out;
}

// One level on an n x 2 plane whose two rows are equal: the columns are constant, so the top row
// holds the 1D transform of the row (lows, then highs).
std::vector<float> transform_row(const std::vector<double>& x, GridWavelet wavelet) {
    const int n = static_cast<int>(x.size());
    std::vector<float> plane(2 * n);
    for (int i = 0; i < n; ++i) plane[i] = plane[n + i] = static_cast<float>(x[i]);
    grid_forward(plane, n, 2, {.wavelet = wavelet, .levels = 1});
    return {plane.begin(), plane.begin() + n};
}

TEST(FixedGrid, one_level_matches_direct_jpeg2000_filters) {
    const std::vector<double> low53 = {6.0 / 8, 2.0 / 8, -1.0 / 8};
    const std::vector<double> high53 = {1.0, -0.5};
    const std::vector<double> low97 = {0.6029490182363579, 0.2668641184428723, -0.07822326652898785,
                                       -0.01686411844287495, 0.02674875741080976};
    const std::vector<double> high97 = {1.115087052456994, -0.5912717631142470,
                                        -0.05754352622849957, 0.09127176311424948};
    for (const int n : {8, 7}) {
        std::vector<double> x(n);
        for (int i = 0; i < n; ++i) x[i] = (i * 37 + 11) % 23 - 7.5;
        const std::vector<double> want53 = direct_filter(x, low53, high53);
        const std::vector<double> want97 = direct_filter(x, low97, high97);
        const std::vector<float> got53 = transform_row(x, GridWavelet::cdf53);
        const std::vector<float> got97 = transform_row(x, GridWavelet::cdf97);
        for (int i = 0; i < n; ++i) {
            EXPECT_NEAR(got53[i], want53[i], 1e-5) << "5/3, n = " << n << ", i = " << i;
            EXPECT_NEAR(got97[i], want97[i], 1e-4) << "9/7, n = " << n << ", i = " << i;
        }
    }
}

TEST(FixedGrid, int53_matches_direct_floor_formula) {
    for (const int n : {8, 7}) {
        std::vector<int32_t> x(n);
        for (int i = 0; i < n; ++i) x[i] = (i * 37 + 11) % 23 - 9;
        // d at odd p, then s at even p, each from the mirrored neighbours, floor by std::floor.
        std::vector<double> d(n, 0.0);
        for (int p = 1; p < n; p += 2) {
            d[p] = x[p] - std::floor((x[mirror(p - 1, n)] + x[mirror(p + 1, n)]) / 2.0);
        }
        const int nl = (n + 1) / 2;
        std::vector<int32_t> want(n);
        for (int p = 0; p < n; ++p) {
            want[p % 2 == 0 ? p / 2 : nl + p / 2] =
                p % 2 == 1
                    ? static_cast<int32_t>(d[p])
                    : static_cast<int32_t>(
                          x[p] + std::floor((d[mirror(p - 1, n)] + d[mirror(p + 1, n)] + 2) / 4.0));
        }
        std::vector<int32_t> plane(2 * n);
        for (int i = 0; i < n; ++i) plane[i] = plane[n + i] = x[i];
        grid_forward_int53(plane, n, 2, 1);
        EXPECT_EQ(std::vector<int32_t>(plane.begin(), plane.begin() + n), want) << "n = " << n;
        EXPECT_EQ(std::vector<int32_t>(plane.begin() + n, plane.end()), std::vector<int32_t>(n, 0));
    }
}

// Fills every sample of `band` from `value(x, y)` in band coordinates and checks the plane.
template <typename Value>
void expect_band(const std::vector<float>& plane, int width, const GridBand& band, Value value,
                 float tolerance, const std::string& what) {
    for (int y = 0; y < band.height; ++y) {
        for (int x = 0; x < band.width; ++x) {
            ASSERT_NEAR(plane[(band.y0 + y) * width + band.x0 + x], value(x, y), tolerance)
                << what << ", level " << band.level << ", type " << band.type << " at " << x << ","
                << y;
        }
    }
}

// DC gain 1 and Nyquist gain 2 along each axis, for both wavelets and at every sample: the
// symmetric extension continues constants and alternating signals exactly.
TEST(FixedGrid, both_wavelets_share_the_53_normalization) {
    for (const GridWavelet wavelet : {GridWavelet::cdf53, GridWavelet::cdf97}) {
        const std::string what = wavelet == GridWavelet::cdf53 ? "5/3" : "9/7";
        for (const Size size : {Size{10, 8}, Size{9, 7}, Size{33, 20}}) {
            const int w = size.width;
            const int h = size.height;
            std::vector<float> constant(w * h, 3.0f);
            grid_forward(constant, w, h, {.wavelet = wavelet, .levels = 4});
            for (const GridBand& band : grid_bands(w, h, 4)) {
                const float want = band.type == 0 ? 3.0f : 0.0f;
                expect_band(
                    constant, w, band, [&](int, int) { return want; }, 1e-5f, what);
            }
            // +1, -1 along x only: HL = -2, the rest 0. Along x and y: HH = 4, the rest 0.
            std::vector<float> stripes(w * h);
            std::vector<float> checkers(w * h);
            for (int y = 0; y < h; ++y) {
                for (int x = 0; x < w; ++x) {
                    stripes[y * w + x] = x % 2 == 0 ? 1.0f : -1.0f;
                    checkers[y * w + x] = (x + y) % 2 == 0 ? 1.0f : -1.0f;
                }
            }
            grid_forward(stripes, w, h, {.wavelet = wavelet, .levels = 1});
            grid_forward(checkers, w, h, {.wavelet = wavelet, .levels = 1});
            for (const GridBand& band : grid_bands(w, h, 1)) {
                const float stripe = band.type == 1 ? -2.0f : 0.0f;
                const float checker = band.type == 3 ? 4.0f : 0.0f;
                expect_band(
                    stripes, w, band, [&](int, int) { return stripe; }, 1e-5f, what);
                expect_band(
                    checkers, w, band, [&](int, int) { return checker; }, 1e-5f, what);
            }
        }
    }
}

// A ramp a + b x + c y gives zero details and LL = the ramp at the even pixels of each level, away
// from the borders. Filter reach is 4 samples per level, so 5 band samples from each end cover
// the borders' influence for the 3 levels checked here.
TEST(FixedGrid, ramps_give_zero_details_away_from_the_borders) {
    const int w = 128;
    const int h = 101;
    const int levels = 3;
    const int margin = 5;
    auto ramp = [](double x, double y) { return static_cast<float>(10.0 + 0.75 * x - 1.25 * y); };
    for (const GridWavelet wavelet : {GridWavelet::cdf53, GridWavelet::cdf97}) {
        std::vector<float> plane(w * h);
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) plane[y * w + x] = ramp(x, y);
        }
        grid_forward(plane, w, h, {.wavelet = wavelet, .levels = levels});
        int checked = 0;
        for (const GridBand& band : grid_bands(w, h, levels)) {
            const double step = std::ldexp(1.0, band.level);
            for (int y = margin; y < band.height - margin; ++y) {
                for (int x = margin; x < band.width - margin; ++x) {
                    const float want = band.type == 0 ? ramp(step * x, step * y) : 0.0f;
                    ASSERT_NEAR(plane[(band.y0 + y) * w + band.x0 + x], want, 1e-3f)
                        << (wavelet == GridWavelet::cdf53 ? "5/3" : "9/7") << ", level "
                        << band.level << ", type " << band.type << " at " << x << "," << y;
                    ++checked;
                }
            }
        }
        EXPECT_GT(checked, w * h / 2);
    }
}

TEST(FixedGrid, bands_tile_the_plane_exactly_once) {
    for (const Size size : {Size{1, 1}, Size{1, 7}, Size{7, 1}, Size{2, 2}, Size{3, 5}, Size{17, 9},
                            Size{64, 48}, Size{101, 67}, Size{316, 316}}) {
        for (int levels = 0; levels <= 8; ++levels) {
            const std::vector<GridBand> bands = grid_bands(size.width, size.height, levels);
            ASSERT_FALSE(bands.empty());
            EXPECT_EQ(bands[0].type, 0);
            EXPECT_EQ(bands.size(), 1 + 3 * static_cast<size_t>(bands[0].level));
            EXPECT_LE(bands[0].level, levels);
            std::vector<int> covered(static_cast<size_t>(size.width) * size.height, 0);
            for (const GridBand& band : bands) {
                EXPECT_GT(band.width, 0);
                EXPECT_GT(band.height, 0);
                ASSERT_GE(band.x0, 0);
                ASSERT_GE(band.y0, 0);
                ASSERT_LE(band.x0 + band.width, size.width);
                ASSERT_LE(band.y0 + band.height, size.height);
                for (int y = band.y0; y < band.y0 + band.height; ++y) {
                    for (int x = band.x0; x < band.x0 + band.width; ++x) {
                        ++covered[y * size.width + x];
                    }
                }
            }
            EXPECT_TRUE(std::all_of(covered.begin(), covered.end(), [](int c) { return c == 1; }))
                << describe(size, levels);
        }
    }
}

TEST(FixedGrid, levels_stop_when_a_side_reaches_one) {
    EXPECT_EQ(grid_bands(316, 316, 5)[0].width, 10);  // 316 158 79 40 20 10
    EXPECT_EQ(grid_bands(16, 2, 5)[0].level, 1);
    EXPECT_EQ(grid_bands(16, 2, 5)[0].width, 8);
    EXPECT_EQ(grid_bands(1, 7, 3).size(), 1u);
    const std::vector<float> original = random_plane(1, 7, 5);
    std::vector<float> plane = original;
    grid_forward(plane, 1, 7, {.wavelet = GridWavelet::cdf97, .levels = 3});
    EXPECT_EQ(plane, original);

    // A 16 x 2 plane takes one level whatever is asked: a second one would leave the plane as it
    // is.
    std::vector<float> one = random_plane(16, 2, 6);
    std::vector<float> five = one;
    grid_forward(one, 16, 2, {.levels = 1});
    grid_forward(five, 16, 2, {.levels = 5});
    EXPECT_EQ(one, five);
}

TEST(FixedGrid, bad_arguments_throw) {
    std::vector<float> plane(12);
    std::vector<int32_t> ints(12);
    EXPECT_THROW(grid_forward(plane, 4, 4, {}), Error);
    EXPECT_THROW(grid_inverse(plane, 0, 12, {}), Error);
    EXPECT_THROW(grid_forward(plane, 4, 3, {.levels = -1}), Error);
    EXPECT_THROW(grid_forward_int53(ints, 3, 3, 1), Error);
    EXPECT_THROW(grid_inverse_int53(ints, 4, 3, -2), Error);
    EXPECT_THROW(grid_bands(0, 3, 1), Error);
    EXPECT_THROW(grid_bands(3, 3, -1), Error);
    EXPECT_NO_THROW(grid_forward(plane, 4, 3, {.levels = 0}));
}

}  // namespace
}  // namespace tesswave
