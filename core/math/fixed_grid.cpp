// Fixed-grid separable lifting (CDF 5/3, CDF 9/7, reversible 5/3) on one plane, Mallat layout.
#include "core/math/fixed_grid.h"

#include <algorithm>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "core/math/error.h"

namespace tesswave {
namespace {

// JPEG 2000 Part 1, Annex F (irreversible 9/7). K makes the low-pass DC gain 1 and the high-pass
// Nyquist gain 2, the 5/3's normalization; both hold to ~1e-15 with these rounded constants.
constexpr float kAlpha = -1.586134342059924f;
constexpr float kBeta = -0.052980118572961f;
constexpr float kGamma = 0.882911075530934f;
constexpr float kDelta = 0.443506852043971f;
constexpr float kK = 1.230174104914001f;
constexpr float kInvK = static_cast<float>(1.0 / 1.230174104914001);

// A signal of length n held as two halves: nl = ceil(n/2) lows (the even samples) then
// nh = floor(n/2) highs (the odd samples). For a row pass an element of a half is one sample
// (Samples); for a column pass it is a whole image row of `count` samples (Lines), so that the loop
// over columns is the innermost one and vectorizes.
template <typename T>
struct Samples {
    T* low;
    T* high;

    template <typename Op>
    void high_step(int t, int a, int b, Op op) const {
        high[t] = op(high[t], low[a], low[b]);
    }
    template <typename Op>
    void low_step(int t, int a, int b, Op op) const {
        low[t] = op(low[t], high[a], high[b]);
    }
    void scale(int nl, int nh, T low_scale, T high_scale) const {
        for (int i = 0; i < nl; ++i) low[i] *= low_scale;
        for (int i = 0; i < nh; ++i) high[i] *= high_scale;
    }
};

template <typename T>
struct Lines {
    T* low;
    T* high;
    std::ptrdiff_t stride;
    int count;

    template <typename Op>
    void high_step(int t, int a, int b, Op op) const {
        step(high + t * stride, low + a * stride, low + b * stride, op);
    }
    template <typename Op>
    void low_step(int t, int a, int b, Op op) const {
        step(low + t * stride, high + a * stride, high + b * stride, op);
    }
    template <typename Op>
    void step(T* __restrict dst, const T* __restrict l, const T* __restrict r, Op op) const {
        for (int x = 0; x < count; ++x) dst[x] = op(dst[x], l[x], r[x]);
    }
    void scale(int nl, int nh, T low_scale, T high_scale) const {
        for (int i = 0; i < nl; ++i) scale_line(low + i * stride, low_scale);
        for (int i = 0; i < nh; ++i) scale_line(high + i * stride, high_scale);
    }
    void scale_line(T* line, T s) const {
        for (int x = 0; x < count; ++x) line[x] *= s;
    }
};

// d[i] = op(d[i], s[i], s[i+1]), where s[nl] stands for s[nl-1] (x[n] = x[n-2], n even).
template <typename Halves, typename Op>
void high_pass_step(const Halves& h, int nl, int nh, Op op) {
    const int interior = std::min(nh, nl - 1);
    for (int i = 0; i < interior; ++i) h.high_step(i, i, i + 1, op);
    if (nh == nl) h.high_step(nh - 1, nh - 1, nh - 1, op);
}

// s[i] = op(s[i], d[i-1], d[i]), where d[-1] stands for d[0] (x[-1] = x[1]) and d[nh] for d[nh-1]
// (x[n] = x[n-2], n odd). With no highs (n = 1) the low sample is left alone.
template <typename Halves, typename Op>
void low_pass_step(const Halves& h, int nl, int nh, Op op) {
    if (nh == 0) return;
    h.low_step(0, 0, 0, op);
    for (int i = 1; i < nh; ++i) h.low_step(i, i - 1, i, op);
    if (nl > nh) h.low_step(nl - 1, nh - 1, nh - 1, op);
}

auto lift(float c) {
    return [c](float v, float a, float b) { return v + c * (a + b); };
}

template <typename Halves>
void forward_float(const Halves& h, int nl, int nh, GridWavelet wavelet) {
    if (nh == 0) return;
    if (wavelet == GridWavelet::cdf53) {
        high_pass_step(h, nl, nh, lift(-0.5f));
        low_pass_step(h, nl, nh, lift(0.25f));
        return;
    }
    high_pass_step(h, nl, nh, lift(kAlpha));
    low_pass_step(h, nl, nh, lift(kBeta));
    high_pass_step(h, nl, nh, lift(kGamma));
    low_pass_step(h, nl, nh, lift(kDelta));
    h.scale(nl, nh, kInvK, kK);
}

template <typename Halves>
void inverse_float(const Halves& h, int nl, int nh, GridWavelet wavelet) {
    if (nh == 0) return;
    if (wavelet == GridWavelet::cdf53) {
        low_pass_step(h, nl, nh, lift(-0.25f));
        high_pass_step(h, nl, nh, lift(0.5f));
        return;
    }
    h.scale(nl, nh, kK, kInvK);
    low_pass_step(h, nl, nh, lift(-kDelta));
    high_pass_step(h, nl, nh, lift(-kGamma));
    low_pass_step(h, nl, nh, lift(-kBeta));
    high_pass_step(h, nl, nh, lift(-kAlpha));
}

// Rounding: floor by arithmetic right shift (defined for negative values since C++20), exactly
// the JPEG 2000 rule, so the inverse subtracts the very same integers. Overflow: a sum of two
// neighbours needs one bit more than the samples; see the bound in the header.
template <typename Halves>
void forward_int53(const Halves& h, int nl, int nh) {
    high_pass_step(h, nl, nh, [](int32_t v, int32_t a, int32_t b) { return v - ((a + b) >> 1); });
    low_pass_step(h, nl, nh,
                  [](int32_t v, int32_t a, int32_t b) { return v + ((a + b + 2) >> 2); });
}

template <typename Halves>
void inverse_int53(const Halves& h, int nl, int nh) {
    // Generic in the sample type: int32 for the codec, int64 for decoding untrusted streams.
    using T = std::remove_cvref_t<decltype(*h.low)>;
    low_pass_step(h, nl, nh, [](T v, T a, T b) { return v - ((a + b + 2) >> 2); });
    high_pass_step(h, nl, nh, [](T v, T a, T b) { return v + ((a + b) >> 1); });
}

// Each row of the w x h region: split even/odd samples into `buffer`, lift, write back.
template <typename T, typename Lift>
void rows_forward(T* plane, std::ptrdiff_t stride, int w, int h, T* buffer, Lift lift_1d) {
    const int nl = (w + 1) / 2;
    const int nh = w / 2;
    for (int y = 0; y < h; ++y) {
        T* row = plane + y * stride;
        for (int i = 0; i < nl; ++i) buffer[i] = row[2 * i];
        for (int i = 0; i < nh; ++i) buffer[nl + i] = row[2 * i + 1];
        lift_1d(Samples<T>{buffer, buffer + nl}, nl, nh);
        std::copy_n(buffer, w, row);
    }
}

template <typename T, typename Lift>
void rows_inverse(T* plane, std::ptrdiff_t stride, int w, int h, T* buffer, Lift lift_1d) {
    const int nl = (w + 1) / 2;
    const int nh = w / 2;
    for (int y = 0; y < h; ++y) {
        T* row = plane + y * stride;
        std::copy_n(row, w, buffer);
        lift_1d(Samples<T>{buffer, buffer + nl}, nl, nh);
        for (int i = 0; i < nl; ++i) row[2 * i] = buffer[i];
        for (int i = 0; i < nh; ++i) row[2 * i + 1] = buffer[nl + i];
    }
}

// The columns of the w x h region, whole rows at a time: odd rows go to `buffer`, even rows move
// up to rows [0, nl), the odd rows follow them, then the lifting runs on the two halves.
template <typename T, typename Lift>
void columns_forward(T* plane, std::ptrdiff_t stride, int w, int h, T* buffer, Lift lift_1d) {
    const int nl = (h + 1) / 2;
    const int nh = h / 2;
    for (int i = 0; i < nh; ++i) std::copy_n(plane + (2 * i + 1) * stride, w, buffer + i * w);
    for (int i = 1; i < nl; ++i) std::copy_n(plane + 2 * i * stride, w, plane + i * stride);
    for (int i = 0; i < nh; ++i) std::copy_n(buffer + i * w, w, plane + (nl + i) * stride);
    lift_1d(Lines<T>{plane, plane + nl * stride, stride, w}, nl, nh);
}

// Row i moves to row 2i from the last low row up, so that no low row is overwritten unread.
template <typename T, typename Lift>
void columns_inverse(T* plane, std::ptrdiff_t stride, int w, int h, T* buffer, Lift lift_1d) {
    const int nl = (h + 1) / 2;
    const int nh = h / 2;
    lift_1d(Lines<T>{plane, plane + nl * stride, stride, w}, nl, nh);
    for (int i = 0; i < nh; ++i) std::copy_n(plane + (nl + i) * stride, w, buffer + i * w);
    for (int i = nl - 1; i >= 1; --i) std::copy_n(plane + i * stride, w, plane + 2 * i * stride);
    for (int i = 0; i < nh; ++i) std::copy_n(buffer + i * w, w, plane + (2 * i + 1) * stride);
}

void check_plane(size_t size, int width, int height, int levels, const char* function) {
    const std::string where = std::string(function) + ": ";
    if (width < 1 || height < 1) {
        throw Error(where + "plane size " + std::to_string(width) + "x" + std::to_string(height) +
                    " must be at least 1x1");
    }
    if (size != static_cast<size_t>(width) * static_cast<size_t>(height)) {
        throw Error(where + "plane has " + std::to_string(size) + " samples, expected " +
                    std::to_string(width) + "x" + std::to_string(height));
    }
    if (levels < 0) throw Error(where + "levels must be >= 0, got " + std::to_string(levels));
}

// The region sizes (w, h) that the levels transform, finest first.
std::vector<std::pair<int, int>> level_regions(int width, int height, int levels) {
    std::vector<std::pair<int, int>> regions;
    int w = width;
    int h = height;
    while (static_cast<int>(regions.size()) < levels && w >= 2 && h >= 2) {
        regions.emplace_back(w, h);
        w = (w + 1) / 2;
        h = (h + 1) / 2;
    }
    return regions;
}

// Room for one row, or for the odd rows of the largest region.
template <typename T>
std::vector<T> scratch(int width, int height) {
    return std::vector<T>(std::max<size_t>(width, static_cast<size_t>(width) * (height / 2)));
}

template <typename T, typename Lift>
void forward_2d(std::span<T> plane, int width, int height, int levels, Lift lift_1d) {
    std::vector<T> buffer = scratch<T>(width, height);
    for (const auto& [w, h] : level_regions(width, height, levels)) {
        rows_forward(plane.data(), width, w, h, buffer.data(), lift_1d);
        columns_forward(plane.data(), width, w, h, buffer.data(), lift_1d);
    }
}

template <typename T, typename Lift>
void inverse_2d(std::span<T> plane, int width, int height, int levels, Lift lift_1d) {
    std::vector<T> buffer = scratch<T>(width, height);
    const auto regions = level_regions(width, height, levels);
    for (auto it = regions.rbegin(); it != regions.rend(); ++it) {
        columns_inverse(plane.data(), width, it->first, it->second, buffer.data(), lift_1d);
        rows_inverse(plane.data(), width, it->first, it->second, buffer.data(), lift_1d);
    }
}

}  // namespace

void grid_forward(std::span<float> plane, int width, int height,
                  const GridTransformOptions& options) {
    check_plane(plane.size(), width, height, options.levels, "grid_forward");
    forward_2d(plane, width, height, options.levels,
               [&](const auto& h, int nl, int nh) { forward_float(h, nl, nh, options.wavelet); });
}

void grid_inverse(std::span<float> plane, int width, int height,
                  const GridTransformOptions& options) {
    check_plane(plane.size(), width, height, options.levels, "grid_inverse");
    inverse_2d(plane, width, height, options.levels,
               [&](const auto& h, int nl, int nh) { inverse_float(h, nl, nh, options.wavelet); });
}

void grid_forward_int53(std::span<int32_t> plane, int width, int height, int levels) {
    check_plane(plane.size(), width, height, levels, "grid_forward_int53");
    forward_2d(plane, width, height, levels,
               [](const auto& h, int nl, int nh) { forward_int53(h, nl, nh); });
}

void grid_inverse_int53(std::span<int32_t> plane, int width, int height, int levels) {
    check_plane(plane.size(), width, height, levels, "grid_inverse_int53");
    inverse_2d(plane, width, height, levels,
               [](const auto& h, int nl, int nh) { inverse_int53(h, nl, nh); });
}

void grid_inverse_int53(std::span<int64_t> plane, int width, int height, int levels) {
    check_plane(plane.size(), width, height, levels, "grid_inverse_int53");
    inverse_2d(plane, width, height, levels,
               [](const auto& h, int nl, int nh) { inverse_int53(h, nl, nh); });
}

std::vector<GridBand> grid_bands(int width, int height, int levels) {
    if (width < 1 || height < 1 || levels < 0) {
        throw Error("grid_bands: need a plane of at least 1x1 and levels >= 0, got " +
                    std::to_string(width) + "x" + std::to_string(height) + " and " +
                    std::to_string(levels));
    }
    const auto regions = level_regions(width, height, levels);
    const int done = static_cast<int>(regions.size());
    if (done == 0) return {GridBand{0, 0, 0, 0, width, height}};
    std::vector<GridBand> bands;
    const auto [cw, ch] = regions.back();
    bands.push_back({done, 0, 0, 0, (cw + 1) / 2, (ch + 1) / 2});
    for (int level = done; level >= 1; --level) {
        const auto [w, h] = regions[level - 1];
        const int lw = (w + 1) / 2;
        const int lh = (h + 1) / 2;
        bands.push_back({level, 1, lw, 0, w - lw, lh});
        bands.push_back({level, 2, 0, lh, lw, h - lh});
        bands.push_back({level, 3, lw, lh, w - lw, h - lh});
    }
    return bands;
}

}  // namespace tesswave
