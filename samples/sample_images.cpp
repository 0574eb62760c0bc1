#include "sample_images.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "value_noise.h"

namespace tesswave::samples {
namespace {

using detail::hash01;
using detail::value_noise;

double fractal(double x, double y, uint64_t seed, int octaves) {
    double sum = 0, amp = 0.5, norm = 0;
    for (int o = 0; o < octaves; ++o) {
        sum += amp * value_noise(x, y, seed + o);
        norm += amp;
        x *= 2.03;
        y *= 2.03;
        amp *= 0.5;
    }
    return sum / norm;
}

using Rgb = std::array<double, 3>;

Rgb mix(Rgb a, Rgb b, double t) {
    return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t};
}

// Coverage of a pixel-centre sample by a shape edge at signed distance d (pixels): a one-pixel
// ramp, so edges are sharp but not aliased.
double coverage(double d) { return std::clamp(0.5 - d, 0.0, 1.0); }

Rgb shade(double u, double v, double px, uint64_t seed) {
    // Sky and sun.
    Rgb c = mix({0.36, 0.55, 0.85}, {0.93, 0.83, 0.68}, std::pow(v / 0.55, 1.5));
    const double sun = std::hypot(u - 0.78, v - 0.18) - 0.07;
    c = mix(c, {1.0, 0.93, 0.6}, coverage(sun / px));
    c = mix(c, {1.0, 0.96, 0.85}, 0.35 * std::exp(-std::max(sun, 0.0) * 18));
    // Two hills with soft shading.
    const double hill1 = 0.55 + 0.08 * std::sin(u * 5.1 + 0.3) + 0.03 * fractal(u * 6, 0, seed, 3);
    const double hill2 = 0.66 + 0.06 * std::sin(u * 3.3 + 2.0);
    if (v > hill1 - px) {
        const double shadow = 0.75 + 0.25 * std::cos(u * 5.1 + 0.3);
        c = mix(c, Rgb{0.25 * shadow, 0.45 * shadow, 0.3 * shadow}, coverage((hill1 - v) / px));
    }
    if (v > hill2 - px) {
        // Textured field: fractal noise and furrows.
        const double n = fractal(u * 40, v * 40, seed + 7, 4);
        const double furrow = 0.5 + 0.5 * std::sin((u * 60 + v * 25) * 3.14159);
        Rgb field = {0.45 + 0.25 * n, 0.5 + 0.2 * n - 0.08 * furrow, 0.18 + 0.1 * n};
        c = mix(c, field, coverage((hill2 - v) / px));
    }
    // A block with a roof: hard straight edges.
    const double bx0 = 0.18, bx1 = 0.38, by0 = 0.5, by1 = 0.74;
    const double box = std::max({bx0 - u, u - bx1, by0 - v, v - by1});
    c = mix(c, {0.78, 0.32, 0.22}, coverage(box / px));
    // Roof: the triangle with apex (0.28, 0.40) over the block, by its edge distances.
    const double roof = std::max(v - by0, (std::abs(u - 0.28) - (v - 0.40) * 1.2) / 1.562);
    c = mix(c, {0.3, 0.22, 0.2}, coverage(roof / px));
    // Windows with glyph-like marks (text-like detail).
    for (int row = 0; row < 3; ++row) {
        for (int k = 0; k < 7; ++k) {
            const double gx = 0.205 + k * 0.024, gy = 0.56 + row * 0.05;
            const double on = hash01(k, row, seed + 3);
            const double glyph =
                std::max(std::abs(u - gx) - 0.006 - 0.004 * on, std::abs(v - gy) - 0.012);
            c = mix(c, {0.95, 0.9, 0.7}, coverage(glyph / px));
        }
    }
    return c;
}

}  // namespace

Image scene_image(int width, int height, uint64_t seed) {
    Image image = make_image(width, height, 3);
    const double scale = std::max(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            const Rgb c = shade((x + 0.5) / scale, (y + 0.5) / scale, 1.0 / scale, seed);
            for (int ch = 0; ch < 3; ++ch) {
                image.at(ch, x, y) = static_cast<float>(std::clamp(c[ch], 0.0, 1.0));
            }
        }
    }
    return image;
}

Image noise_image(int width, int height) {
    Image image = make_image(width, height, 3);
    uint32_t state = 12345;
    for (auto& plane : image.planes) {
        for (float& v : plane) {
            state = state * 1664525u + 1013904223u;
            v = static_cast<float>(state >> 8) / static_cast<float>(1u << 24);
        }
    }
    return image;
}

}  // namespace tesswave::samples
