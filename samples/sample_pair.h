// A morph pair with a known answer: image B is image A moved by a smooth deformation
// F(x) = x + d(x), so the true in-between frame at any t is known (A moved by x + t d(x)), and
// point files can be written from F. The samples generator writes it; tests and the demo use it.
#pragma once

#include <cstdint>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/image.h"

namespace tesswave::samples {

struct Deformation {
    double width = 0, height = 0;
    double amplitude = 6;             // pixels; zero on the border, so the border maps to itself
    Vec2 displacement(Vec2 x) const;  // d(x)
    // The point at time t of the material at x: x + t d(x).
    Vec2 at(Vec2 x, double t) const { return x + t * displacement(x); }
    // Its inverse: the x with x + t d(x) = y (fixed-point iterations; |grad d| < 1).
    Vec2 source(Vec2 y, double t) const;
};

struct SamplePair {
    Image a, b;
    Deformation deformation;
    std::vector<Vec2> points_a, points_b;  // correspondences: points_b[i] = F(points_a[i])
};

// A = scene_image(width, height, seed) with a fine texture, B = A moved by the deformation;
// `points` correspondences on a jittered grid inside the image.
SamplePair deformed_pair(int width, int height, int points = 200, uint64_t seed = 1);

// A moved to time t (the true in-between frame; t = 0 is A, t = 1 is B).
Image moved(const Image& a, const Deformation& d, double t);

}  // namespace tesswave::samples
