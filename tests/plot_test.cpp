#include "core/eval/plot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/math/error.h"

namespace tesswave {
namespace {

bool is_colour(const Image& im, int x, int y, const std::array<float, 3>& c) {
    for (int k = 0; k < 3; ++k) {
        if (std::abs(im.at(k, x, y) - c[k]) > 0.03f) return false;
    }
    return true;
}

// Pixels of colour `c` counted per row (`rows`) or per column.
std::vector<int> histogram(const Image& im, const std::array<float, 3>& c, bool rows) {
    std::vector<int> h(rows ? im.height : im.width, 0);
    for (int y = 0; y < im.height; ++y) {
        for (int x = 0; x < im.width; ++x) h[rows ? y : x] += is_colour(im, x, y, c);
    }
    return h;
}

int argmax(const std::vector<int>& v) {
    return static_cast<int>(std::max_element(v.begin(), v.end()) - v.begin());
}

void expect_rgb_plot(const Image& im, int width, int height) {
    ASSERT_EQ(im.width, width);
    ASSERT_EQ(im.height, height);
    ASSERT_EQ(im.channels(), 3);
    for (const auto& plane : im.planes) {
        ASSERT_EQ(plane.size(), static_cast<size_t>(width) * height);
        for (float v : plane) ASSERT_TRUE(v >= 0 && v <= 1);
    }
}

TEST(Plot, has_requested_size_and_three_channels) {
    const std::vector<PlotSeries> series = {{"a", {0.25, 0.5, 1, 2}, {28, 31, 35, 39}}};
    for (auto [w, h] : {std::pair{960, 640}, {401, 299}, {160, 160}, {1600, 400}}) {
        for (bool log_x : {false, true}) {
            const Image im = draw_line_plot(series, {.title = "t",
                                                     .x_label = "bpp",
                                                     .y_label = "PSNR (dB)",
                                                     .width = w,
                                                     .height = h,
                                                     .log_x = log_x});
            expect_rgb_plot(im, w, h);
        }
    }
}

// Four lines along the sides of a square: each colour's densest row or column is on its side.
TEST(Plot, series_colours_appear_where_their_data_maps) {
    const std::vector<PlotSeries> series = {{"bottom", {0, 1, 2, 3, 4}, {0, 0, 0, 0, 0}},
                                            {"top", {0, 1, 2, 3, 4}, {4, 4, 4, 4, 4}},
                                            {"left", {0, 0, 0, 0, 0}, {0, 1, 2, 3, 4}},
                                            {"right", {4, 4, 4, 4, 4}, {0, 1, 2, 3, 4}}};
    for (bool log_x : {false, true}) {
        SCOPED_TRACE(log_x);
        std::vector<PlotSeries> s = series;
        if (log_x) {  // the same picture with x = 2^x
            for (auto& one : s) {
                for (double& x : one.x) x = std::exp2(x);
            }
        }
        const Image im = draw_line_plot(s, {.log_x = log_x});
        const int w = im.width, h = im.height;
        const int bottom = argmax(histogram(im, plot_series_colour(0), true));
        const int top = argmax(histogram(im, plot_series_colour(1), true));
        const int left = argmax(histogram(im, plot_series_colour(2), false));
        const int right = argmax(histogram(im, plot_series_colour(3), false));
        EXPECT_GT(bottom, h / 2);
        EXPECT_LT(top, h / 2);
        EXPECT_LT(left, w / 2);
        EXPECT_GT(right, w / 2);
        // The lines span most of the plot, so they dominate their row or column.
        EXPECT_GT(histogram(im, plot_series_colour(0), true)[bottom], w / 2);
        EXPECT_GT(histogram(im, plot_series_colour(2), false)[left], h / 2);
    }
}

TEST(Plot, series_get_distinct_colours) {
    for (size_t i = 0; i < 8; ++i) {
        for (size_t j = 0; j < i; ++j) EXPECT_NE(plot_series_colour(i), plot_series_colour(j));
    }
}

TEST(Plot, edge_cases_draw_without_throwing) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<std::vector<PlotSeries>> cases = {
        {},
        {{"empty", {}, {}}},
        {{"one point", {1}, {30}}},
        {{"all equal", {1, 1, 1}, {30, 30, 30}}},
        {{"zeros", {0, 0}, {0, 0}}},
        {{"non-finite", {nan, 0.5, inf, 1, 2}, {30, nan, 31, -inf, 33}}},
        {{"only non-finite", {nan, inf}, {1, 2}}},
        {{"non-positive x", {-1, 0, 0.5, 1}, {20, 25, 30, 35}}},
        {{"tiny", {1e-300, 2e-300}, {1e-300, 3e-300}}},
        {{"huge", {1e300, 2e300}, {-1e300, 1e300}}},
        {{"wide", {1e-6, 1e6}, {0, 1}}},
        {{"narrow", {0.30, 0.31, 0.32}, {30.001, 30.002, 30.003}}},
        {{"a", {1, 2}, {3, 4}}, {"b", {}, {}}, {"c", {2}, {nan}}},
    };
    for (const auto& series : cases) {
        SCOPED_TRACE(series.empty() ? "no series" : series[0].name);
        for (bool log_x : {false, true}) {
            const Image im = draw_line_plot(series, {.title = "RD", .log_x = log_x});
            expect_rgb_plot(im, 960, 640);
        }
    }
    // Many series with long names: the palette and the markers wrap around.
    std::vector<PlotSeries> many;
    for (int k = 0; k < 20; ++k) {
        many.push_back({"a rather long method name " + std::to_string(k),
                        {1, 2, 3},
                        {k + 0.0, k + 1.0, k + 3.0}});
    }
    expect_rgb_plot(draw_line_plot(many, {.width = 320, .height = 200}), 320, 200);
}

// A lone point or a flat line still shows: more of its colour than its legend entry alone has.
TEST(Plot, single_points_and_flat_series_are_visible) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    auto count = [](const Image& im) {
        const auto h = histogram(im, plot_series_colour(0), true);
        return std::accumulate(h.begin(), h.end(), 0);
    };
    for (bool log_x : {false, true}) {
        const int legend_only = count(draw_line_plot({{"s", {nan}, {nan}}}, {.log_x = log_x}));
        EXPECT_GT(count(draw_line_plot({{"s", {0.5}, {30}}}, {.log_x = log_x})), legend_only + 20);
        EXPECT_GT(count(draw_line_plot({{"s", {0.5, 1, 2}, {30, 30, 30}}}, {.log_x = log_x})),
                  legend_only + 200);
    }
}

TEST(Plot, rejects_mismatched_sizes_and_absurd_images) {
    EXPECT_THROW(draw_line_plot({{"a", {1, 2, 3}, {1, 2}}}, {}), Error);
    EXPECT_THROW(draw_line_plot({{"a", {1}, {1}}}, {.width = 10}), Error);
    EXPECT_THROW(draw_line_plot({{"a", {1}, {1}}}, {.height = 100'000}), Error);
    // Values whose spread does not fit a double are an error, not a crash.
    EXPECT_THROW(draw_line_plot({{"a", {-1.7e308, 1.7e308}, {0, 1}}}, {}), Error);
}

}  // namespace
}  // namespace tesswave
