// Four bilinear taps at once with AVX2, for the kernels that read an image at many places
// (sampling a quad's rows, the morph's residual warp): the taps' pixel indices and fractions, and
// the reads, the same operations in the same order as bilinear_tap and bilinear_at (sampling.h).
// Include only from x86-64 code; the functions are compiled for AVX2 and inlined into callers
// that are ([[gnu::target("avx2")]]), which check the CPU first.
#pragma once

#include <immintrin.h>

#include <cstdint>

namespace tesswave::detail {

// Four taps on an image at least 2x2 pixels, so that a tap's right and lower pixels are the next
// ones (x1 = x0 + 1, y1 = y0 + 1): the upper-left pixels' indices (row y0 and row y0 + 1, as
// int32: the caller checks the pixel count) and the fractions.
struct Taps4 {
    __m128i i00, i10;
    __m128 tx, ty;
};

// bilinear_at for the four taps. Each pixel and its right neighbour are read as one 64-bit load,
// and the pairs are split into the left and the right pixels. Scalar loads, not gathers: on the
// Zen 3 this project measures on, the two gathers a row took made sampling 15 % slower, and no
// faster where the pixels were in the cache.
[[gnu::target("avx2"), gnu::always_inline]] inline __m128 bilinear4(const float* plane,
                                                                    const Taps4& t) {
    alignas(16) int32_t i00[4], i10[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(i00), t.i00);
    _mm_store_si128(reinterpret_cast<__m128i*>(i10), t.i10);
    const auto pair = [plane](int32_t i) {
        return _mm_castpd_ps(_mm_load_sd(reinterpret_cast<const double*>(plane + i)));
    };
    // Pairs 0 and 1, 2 and 3 side by side, then the left pixels of all four and the right ones.
    const __m128 top01 = _mm_movelh_ps(pair(i00[0]), pair(i00[1]));
    const __m128 top23 = _mm_movelh_ps(pair(i00[2]), pair(i00[3]));
    const __m128 bottom01 = _mm_movelh_ps(pair(i10[0]), pair(i10[1]));
    const __m128 bottom23 = _mm_movelh_ps(pair(i10[2]), pair(i10[3]));
    const __m128 p00 = _mm_shuffle_ps(top01, top23, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 p01 = _mm_shuffle_ps(top01, top23, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 p10 = _mm_shuffle_ps(bottom01, bottom23, _MM_SHUFFLE(2, 0, 2, 0));
    const __m128 p11 = _mm_shuffle_ps(bottom01, bottom23, _MM_SHUFFLE(3, 1, 3, 1));
    const __m128 top = _mm_add_ps(p00, _mm_mul_ps(_mm_sub_ps(p01, p00), t.tx));
    const __m128 bottom = _mm_add_ps(p10, _mm_mul_ps(_mm_sub_ps(p11, p10), t.tx));
    return _mm_add_ps(top, _mm_mul_ps(_mm_sub_ps(bottom, top), t.ty));
}

// The taps' indices from their upper-left pixels (x0, y0) on an image `width` pixels wide.
[[gnu::target("avx2"), gnu::always_inline]] inline Taps4 taps4(__m128i x0, __m128i y0, int width,
                                                               __m128 tx, __m128 ty) {
    const __m128i w = _mm_set1_epi32(width);
    const __m128i i00 = _mm_add_epi32(_mm_mullo_epi32(y0, w), x0);
    return {i00, _mm_add_epi32(i00, w), tx, ty};
}

}  // namespace tesswave::detail
