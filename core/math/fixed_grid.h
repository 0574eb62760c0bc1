// Separable fixed-grid wavelets on a pixel lattice, the baseline for the mesh transform (DESIGN.md
// 2.4, 6): lifting along rows then columns, Mallat layout, JPEG 2000 conventions.
//
// 1D, per level (even samples become low-pass s, odd samples high-pass d; whole-sample symmetric
// extension x[-1] = x[1], x[n] = x[n-2]; a length-1 signal is left unchanged):
//   CDF 5/3 float:   d += -1/2 (x_l + x_r);   s += 1/4 (d_l + d_r)
//   CDF 9/7 float:   d += alpha (x_l + x_r);  s += beta (d_l + d_r);  d += gamma (s_l + s_r);
//                    s += delta (d_l + d_r);  s /= K;  d *= K, with (JPEG 2000 Part 1, Annex F)
//     alpha = -1.586134342059924, beta = -0.052980118572961, gamma = 0.882911075530934,
//     delta = 0.443506852043971, K = 1.230174104914001.
//     With this K both filters share one normalization: low-pass DC gain 1 and high-pass gain 2 at
//     Nyquist (the signal +1,-1,+1,.. gives s = 0 and d = -2).
//   Integer 5/3 (JPEG 2000 reversible): d = x_odd - floor((x_l + x_r) / 2);
//                                       s = x_even + floor((d_l + d_r + 2) / 4).
// 2D, per level: every row of the current LL region, then every column; lows then go first, so the
// LL band is the top-left ceil(w/2) x ceil(h/2) and the next level transforms it. A level is only
// done while both sides of the region are at least 2, so fewer than `levels` may happen and every
// band of every level is non-empty.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace tesswave {

enum class GridWavelet { cdf53, cdf97 };

struct GridTransformOptions {
    GridWavelet wavelet = GridWavelet::cdf53;
    int levels = 5;
};

// In place on one plane of width x height samples, row-major with stride width. Throw Error when a
// side is < 1, the span size is not width * height, or levels < 0.
void grid_forward(std::span<float> plane, int width, int height,
                  const GridTransformOptions& options);
void grid_inverse(std::span<float> plane, int width, int height,
                  const GridTransformOptions& options);

// Reversible integer 5/3, bit-exact inverse. No overflow for |x| < 2^16 and up to 10 levels (each
// level grows the LL range by at most 1.5^2, a high band by at most 4).
void grid_forward_int53(std::span<int32_t> plane, int width, int height, int levels);
void grid_inverse_int53(std::span<int32_t> plane, int width, int height, int levels);
// The same in int64 (identical results where int32 does not overflow): decoders of untrusted
// streams use it when the coefficients could overflow int32 on the way back.
void grid_inverse_int53(std::span<int64_t> plane, int width, int height, int levels);

// One band of the Mallat layout. Level 1 is the finest; HL is high-pass along x (top right), LH
// high-pass along y (bottom left).
struct GridBand {
    int level;
    int type;  // 0 = LL, 1 = HL, 2 = LH, 3 = HH
    int x0, y0, width, height;
};

// The bands after `levels` levels, coarse to fine: the LL band (level = levels done, 0 if none),
// then HL, LH, HH of each level from the coarsest down to level 1. They tile the plane exactly.
std::vector<GridBand> grid_bands(int width, int height, int levels);

}  // namespace tesswave
