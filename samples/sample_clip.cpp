#include "sample_clip.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "core/math/error.h"
#include "core/math/strings.h"
#include "value_noise.h"

namespace tesswave::samples {
namespace {

constexpr int kMaxSize = 16384;
constexpr double kObjectPeriod = 96;  // frames per turn of the object's ellipse

using Rgb = std::array<double, 3>;

using detail::hash01;
using detail::value_noise;

Rgb mix(Rgb a, Rgb b, double t) {
    return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t};
}

// Coverage of a sample by a shape at signed distance d (in pixels): a one-pixel ramp.
double coverage(double d) { return std::clamp(0.5 - d, 0.0, 1.0); }

// The slowly varying part of the scene at world point (x, y): colour waves and clouds. It is
// smooth at the pixel scale, so one sample per pixel suffices.
Rgb smooth_layer(double x, double y, uint64_t seed) {
    const double cloud =
        (value_noise(x / 40, y / 40, seed) + 0.5 * value_noise(x / 17, y / 17, seed + 1)) / 1.5;
    const double light = 0.85 + 0.6 * (cloud - 0.5);
    return {light * (0.45 + 0.14 * std::sin(0.019 * x + 0.8 * std::sin(0.011 * y))),
            light * (0.47 + 0.12 * std::sin(0.015 * y + 0.6 * std::sin(0.009 * x) + 1.3)),
            light * (0.42 + 0.14 * std::sin(0.012 * (x - y) + 2.1))};
}

// Disks on a jittered 36-pixel grid, one per cell at most, each inside its cell.
Rgb with_disk(Rgb c, double x, double y, double px, uint64_t seed) {
    constexpr double kCell = 36;
    const int64_t i = static_cast<int64_t>(std::floor(x / kCell));
    const int64_t j = static_cast<int64_t>(std::floor(y / kCell));
    if (hash01(i, j, seed) > 0.7) return c;
    const double r = 5 + 7 * hash01(i, j, seed + 1);
    const double span = kCell - 2 * (r + 1);
    const double cx = i * kCell + r + 1 + span * hash01(i, j, seed + 2);
    const double cy = j * kCell + r + 1 + span * hash01(i, j, seed + 3);
    const double cover = coverage((std::hypot(x - cx, y - cy) - r) / px);
    if (cover == 0) return c;
    const double tone = hash01(i, j, seed + 4);
    const Rgb colour = {0.15 + 0.8 * tone, 0.2 + 0.6 * hash01(i, j, seed + 5), 0.9 - 0.7 * tone};
    return mix(c, colour, cover);
}

// Straight bars (rotated rectangles) on a 60-pixel grid offset from the disks' grid.
Rgb with_bar(Rgb c, double x, double y, double px, uint64_t seed) {
    constexpr double kCell = 60, kOffset = 17;
    const int64_t i = static_cast<int64_t>(std::floor((x - kOffset) / kCell));
    const int64_t j = static_cast<int64_t>(std::floor((y - kOffset) / kCell));
    if (hash01(i, j, seed) > 0.6) return c;
    const double cx = kOffset + (i + 0.5) * kCell + 12 * (hash01(i, j, seed + 1) - 0.5);
    const double cy = kOffset + (j + 0.5) * kCell + 12 * (hash01(i, j, seed + 2) - 0.5);
    const double half_length = 8 + 10 * hash01(i, j, seed + 3);
    const double half_width = 2 + 2 * hash01(i, j, seed + 4);
    const double angle = M_PI * hash01(i, j, seed + 5);
    const double ux = std::cos(angle), uy = std::sin(angle);
    const double along = (x - cx) * ux + (y - cy) * uy, across = (y - cy) * ux - (x - cx) * uy;
    const double d = std::max(std::abs(along) - half_length, std::abs(across) - half_width);
    const double cover = coverage(d / px);
    if (cover == 0) return c;
    const double v = hash01(i, j, seed + 6) < 0.5 ? 0.08 : 0.92;
    return mix(c, Rgb{v, v, 0.9 * v}, cover);
}

// Fine texture: value noise on 3- and 5.3-pixel lattices, as a brightness modulation.
double fine_texture(double x, double y, uint64_t seed) {
    return 1 + 0.4 * (value_noise(x / 3, y / 3, seed) - 0.5) +
           0.3 * (value_noise(x / 5.3, y / 5.3, seed + 1) - 0.5);
}

// The object's colour at offset (dx, dy) from its centre: rings, noise and shading.
Rgb object_colour(double dx, double dy, double radius, uint64_t seed) {
    const double r = std::hypot(dx, dy);
    const double rings = 0.5 + 0.5 * std::sin(0.9 * r);
    const double n = value_noise(dx / 2.5 + 1000, dy / 2.5 + 1000, seed);
    const double shade = 1 - 0.35 * (r / radius) * (r / radius);
    return {shade * (0.7 + 0.25 * rings), shade * (0.3 + 0.35 * n), shade * (0.15 + 0.2 * rings)};
}

void check(const SampleClipOptions& o) {
    if (o.width < 1 || o.height < 1 || o.width > kMaxSize || o.height > kMaxSize) {
        throw Error(str("sample clip: size ", o.width, "x", o.height, " outside 1..", kMaxSize));
    }
    if (!(o.zoom > -1) || !std::isfinite(o.zoom) || !std::isfinite(o.pan.x) ||
        !std::isfinite(o.pan.y)) {
        throw Error(str("sample clip: zoom ", o.zoom, " must be finite and > -1, pan finite"));
    }
}

Vec2 centre(const SampleClipOptions& o) { return {0.5 * o.width, 0.5 * o.height}; }

// M_t^-1: the frame-0 position of the background point seen at q in frame t.
Vec2 unmove(const SampleClipOptions& o, int t, Vec2 q) {
    const Vec2 c = centre(o);
    return c + std::pow(1 + o.zoom, -t) * (q - c - t * o.pan);
}

}  // namespace

Vec2 sample_clip_motion(const SampleClipOptions& o, int t, Vec2 p) {
    const Vec2 c = centre(o);
    return c + std::pow(1 + o.zoom, t) * (p - c) + t * o.pan;
}

Vec2 sample_clip_motion(const SampleClipOptions& o, int from, int to, Vec2 p) {
    return sample_clip_motion(o, to, unmove(o, from, p));
}

SampleClipObject sample_clip_object(const SampleClipOptions& o, int t) {
    if (!o.object) return {};
    const double angle = 0.6 + 2 * M_PI * t / kObjectPeriod;
    return {.centre = centre(o) +
                      Vec2{0.28 * o.width * std::cos(angle), 0.22 * o.height * std::sin(angle)},
            .radius = 0.16 * std::min(o.width, o.height)};
}

Image sample_clip_frame(const SampleClipOptions& o, int t) {
    check(o);
    Image image = make_image(o.width, o.height, 3);
    const uint64_t seed = o.seed;
    // World coordinates: frame-0 pixels shifted by a seeded origin, so seeds differ everywhere.
    const Vec2 origin = {1e4 * hash01(1, 2, seed), 1e4 * hash01(3, 4, seed)};
    const double px = std::pow(1 + o.zoom, -t);  // a frame pixel's size in world units
    const SampleClipObject object = sample_clip_object(o, t);
    constexpr std::array<double, 2> kSub = {-0.25, 0.25};
    for (int y = 0; y < o.height; ++y) {
        for (int x = 0; x < o.width; ++x) {
            const Vec2 q = {x + 0.5, y + 0.5};
            const Vec2 w = unmove(o, t, q) + origin;
            const Rgb base = smooth_layer(w.x, w.y, seed + 10);
            Rgb sum = {0, 0, 0};
            for (double sy : kSub) {
                for (double sx : kSub) {
                    const Vec2 qs = q + Vec2{sx, sy};
                    const Vec2 ws = w + px * Vec2{sx, sy};
                    Rgb c = with_disk(base, ws.x, ws.y, px, seed + 20);
                    c = with_bar(c, ws.x, ws.y, px, seed + 30);
                    const double f = fine_texture(ws.x, ws.y, seed + 40);
                    c = {c[0] * f, c[1] * f, c[2] * f};
                    if (object.radius > 0) {
                        const Vec2 d = qs - object.centre;
                        const double cover = coverage(norm(d) - object.radius);
                        if (cover > 0) {
                            c = mix(c, object_colour(d.x, d.y, object.radius, seed + 50), cover);
                        }
                    }
                    for (int ch = 0; ch < 3; ++ch) sum[ch] += c[ch];
                }
            }
            for (int ch = 0; ch < 3; ++ch) {
                image.at(ch, x, y) = static_cast<float>(std::clamp(0.25 * sum[ch], 0.0, 1.0));
            }
        }
    }
    return image;
}

}  // namespace tesswave::samples
