#include "sample_pair.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/math/sampling.h"
#include "sample_images.h"

namespace tesswave::samples {

Vec2 Deformation::displacement(Vec2 x) const {
    // Two smooth waves under a window that vanishes on the border.
    const double u = x.x / width, v = x.y / height;
    const double window = std::sin(M_PI * u) * std::sin(M_PI * v);
    return {amplitude * window * std::sin(2 * M_PI * v + 0.5),
            amplitude * window * std::cos(2 * M_PI * u - 0.3)};
}

Vec2 Deformation::source(Vec2 y, double t) const {
    Vec2 x = y;
    for (int i = 0; i < 30; ++i) x = y - t * displacement(x);
    return x;
}

Image moved(const Image& a, const Deformation& d, double t) {
    std::vector<Vec2> positions;
    positions.reserve(static_cast<size_t>(a.width) * a.height);
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) positions.push_back(d.source({x + 0.5, y + 0.5}, t));
    }
    Image out = make_image(a.width, a.height, a.channels(), a.format);
    out.planes = sample_bilinear(a, positions);
    return out;
}

SamplePair deformed_pair(int width, int height, int points, uint64_t seed) {
    SamplePair p;
    p.a = scene_image(width, height, seed);
    // A fine texture so that every region can be matched.
    std::mt19937_64 rng(seed * 7919 + 1);
    for (auto& plane : p.a.planes) {
        for (float& v : plane) {
            v = std::clamp(v + 0.06f * static_cast<float>((rng() >> 11) * 0x1.0p-53 - 0.5), 0.0f,
                           1.0f);
        }
    }
    p.deformation = {static_cast<double>(width), static_cast<double>(height)};
    p.b = moved(p.a, p.deformation, 1.0);
    const int cols = std::max(1, static_cast<int>(std::sqrt(points * double(width) / height)));
    const int rows = std::max(1, points / cols);
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c) {
            const double jx = (rng() >> 11) * 0x1.0p-53, jy = (rng() >> 11) * 0x1.0p-53;
            const Vec2 x{(c + 0.25 + 0.5 * jx) * width / cols,
                         (r + 0.25 + 0.5 * jy) * height / rows};
            p.points_a.push_back(x);
            p.points_b.push_back(p.deformation.at(x, 1.0));
        }
    }
    return p;
}

}  // namespace tesswave::samples
