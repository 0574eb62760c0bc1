// The lifted bilinear wavelet transform on a tessellation hierarchy (DESIGN.md 2.4; the paper's
// equations 3.1-3.4). One decomposition step, level j+1 -> j, in this order:
//
//     f' = f + avg_v(f) - 2 avg_e(f)
//     e' = e - avg_v(e) + 1/2 avg_f'(e)        curve: e' = e - avg_v(e)
//     v' = v - 1/4 avg_f'(v) + avg_e'(v)       curve: v' = v + 1/2 avg_e'(v);  corners unchanged
//
// Reconstruction subtracts the same increments in reverse order. Planes hold one value per
// sample of the finest level, in place: after decomposing to level j, entries [n_j, n_{j+1}) hold
// that step's detail coefficients (nested numbering).
#pragma once

#include <cstdint>
#include <span>

#include "core/math/hierarchy.h"

namespace tesswave {

enum class LiftingKernel : uint8_t {
    fast,       // patch interiors by rows over the patch grids, the rest by tables
    reference,  // the formulas above, one plane and one point at a time
};

struct TransformOptions {
    int steps = -1;  // decomposition steps from the finest level; -1 means down to T0
    // Both kernels evaluate the same expressions in the same order, so their results are
    // identical to the bit, in floating point as well as in integers (tests pin this).
    LiftingKernel kernel = LiftingKernel::fast;
};

void forward_transform(const Hierarchy& hierarchy, std::span<const std::span<float>> planes,
                       const TransformOptions& options = {});
void inverse_transform(const Hierarchy& hierarchy, std::span<const std::span<float>> planes,
                       const TransformOptions& options = {});

// Double precision, for analysis and for pinning exact properties in tests.
void forward_transform(const Hierarchy& hierarchy, std::span<const std::span<double>> planes,
                       const TransformOptions& options = {});
void inverse_transform(const Hierarchy& hierarchy, std::span<const std::span<double>> planes,
                       const TransformOptions& options = {});

// Integer variant, bit-exact reversible. Each increment num/den (den > 0) is rounded half up:
// floor((num + floor(den/2)) / den), computed in int64. Reconstruction subtracts the identical
// rounded increment, so it is exact whatever the rounding. Results are int32: inputs within
// +-2^20 cannot overflow for J <= 8 (the low band's gain is about 2.25 per level).
void forward_transform_int(const Hierarchy& hierarchy, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options = {});
void inverse_transform_int(const Hierarchy& hierarchy, std::span<const std::span<int32_t>> planes,
                           const TransformOptions& options = {});
// The integer inverse in int64, identical to the int32 one wherever that does not overflow: for
// decoding coefficients from untrusted streams.
void inverse_transform_int(const Hierarchy& hierarchy, std::span<const std::span<int64_t>> planes,
                           const TransformOptions& options = {});

}  // namespace tesswave
