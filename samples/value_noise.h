// Value noise shared by the procedural samples: a hash of lattice points, smoothly interpolated,
// texture without tables (deterministic for a seed).
#pragma once

#include <cmath>
#include <cstdint>

namespace tesswave::samples::detail {

// A hash of (x, y, seed) mapped to [0, 1).
inline double hash01(int64_t x, int64_t y, uint64_t seed) {
    uint64_t h = seed * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(x) * 0xBF58476D1CE4E5B9ull ^
                 static_cast<uint64_t>(y) * 0x94D049BB133111EBull;
    h ^= h >> 31;
    h *= 0xD6E8FEB86659FD93ull;
    h ^= h >> 32;
    return (h >> 11) * 0x1.0p-53;
}

// Hashed values on the integer lattice, interpolated with smoothstep weights (C1).
inline double value_noise(double x, double y, uint64_t seed) {
    const double fx = std::floor(x), fy = std::floor(y);
    const double tx = x - fx, ty = y - fy;
    const double sx = tx * tx * (3 - 2 * tx), sy = ty * ty * (3 - 2 * ty);
    const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
    const double a = hash01(ix, iy, seed), b = hash01(ix + 1, iy, seed);
    const double c = hash01(ix, iy + 1, seed), d = hash01(ix + 1, iy + 1, seed);
    const double top = a + (b - a) * sx, bottom = c + (d - c) * sx;
    return top + (bottom - top) * sy;
}

}  // namespace tesswave::samples::detail
