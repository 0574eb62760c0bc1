// Four bilinear taps at once with AVX2, for the kernels that read an image at many places
// (sampling a quad's rows, the morph's residual warp): the taps' pixel indices and fractions, and
// the reads, the same operations in the same order as bilinear_tap and bilinear_at (sampling.h).
// Include only from x86-64 code; the functions are compiled for AVX2 and inlined into callers
// that are ([[gnu::target("avx2")]]), which check the CPU first.
#pragma once

#include <immintrin.h>

namespace tesswave::detail {

// Four taps on an image at least 2x2 pixels, so that a tap's right and lower pixels are the next
// ones (x1 = x0 + 1, y1 = y0 + 1): the upper-left pixels' indices (row y0 and row y0 + 1, as
// int32: the caller checks the pixel count) and the fractions.
struct Taps4 {
    __m128i i00, i10;
    __m128 tx, ty;
};

// bilinear_at for the four taps: each 64-bit gather reads a pixel and its right neighbour as one
// pair, and the pairs are split into the left and the right pixels.
[[gnu::target("avx2"), gnu::always_inline]] inline __m128 bilinear4(const float* plane,
                                                                    const Taps4& t) {
    const __m256i split = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    const auto* pairs = reinterpret_cast<const long long*>(plane);
    const __m256 row0 = _mm256_permutevar8x32_ps(
        _mm256_castsi256_ps(_mm256_i32gather_epi64(pairs, t.i00, 4)), split);
    const __m256 row1 = _mm256_permutevar8x32_ps(
        _mm256_castsi256_ps(_mm256_i32gather_epi64(pairs, t.i10, 4)), split);
    const __m128 p00 = _mm256_castps256_ps128(row0), p01 = _mm256_extractf128_ps(row0, 1);
    const __m128 p10 = _mm256_castps256_ps128(row1), p11 = _mm256_extractf128_ps(row1, 1);
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
