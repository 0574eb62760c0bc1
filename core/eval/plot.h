// Line plots for rate-distortion curves (PSNR against bits per pixel, one series per method),
// drawn with OpenCV into an RGB Image for write_image.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "core/math/image.h"

namespace tesswave {

// Points are joined in the order given; non-finite points (and x <= 0 on a log axis) are skipped.
struct PlotSeries {
    std::string name{};
    std::vector<double> x{}, y{};
};

struct PlotOptions {
    std::string title{}, x_label{}, y_label{};  // ASCII (OpenCV's Hershey font)
    int width = 960, height = 640;              // pixels, each in [160, 8192]
    bool log_x = false;  // ticks at powers of two (0.25, 0.5, 1, 2) or 1-2-5 decades
};

// An RGB raster (3 planes, floats in [0,1]): white background, grid, ticks, labels and a legend,
// each series in its own colour (Okabe-Ito) and marker. Throws Error when a series' x and y
// differ in length, the size is out of range or the values' spread overflows a double.
Image draw_line_plot(const std::vector<PlotSeries>& series, const PlotOptions& options);

// The RGB colour in [0,1] of series `index` (the palette repeats after 8).
std::array<float, 3> plot_series_colour(size_t index);

}  // namespace tesswave
