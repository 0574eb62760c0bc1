// Dead-zone quantization and reconstruction of the bit-plane coder's coefficients (bitplane.h
// declares them).
#include <bit>
#include <cmath>
#include <cstdint>

#include "core/codec/bitplane.h"
#include "core/math/error.h"

namespace tesswave {
namespace {

// Where a significant coefficient is put inside the interval its known bits leave open, as a
// fraction of the interval: below the middle, since magnitudes fall off inside it (0.375 is
// the usual JPEG 2000 choice; measured +0.05 dB over 0.5 on Kodak).
constexpr float kRecon = 0.375f;

// One coefficient of quantize: sign floor(|x| / step), the magnitude computed as |x| times
// 1 / step and truncated (the floor, as it is not negative). Branch-free so that the rows of a
// grid's bands vectorize; `bad` is set when the magnitude reaches 1e9 (or x is NaN).
inline int32_t quantize_one(float x, float inv, int& bad) {
    const float a = std::abs(x) * inv;
    const bool ok = a < 1e9f;
    bad |= !ok;
    const auto m = static_cast<int32_t>(ok ? a : 0.0f);
    const int32_t negative = -static_cast<int32_t>(x < 0);  // 0 or -1
    return (m ^ negative) - negative;
}

}  // namespace

void quantize(const CodingLayout& layout, std::span<const float> x,
              std::span<const float> band_steps, std::span<int32_t> out) {
    int bad = 0;
    for (size_t b = 0; b < layout.bands.size(); ++b) {
        const float inv = 1.0f / band_steps[b];
        for_band(
            layout, b,
            [&](size_t first, int width) {
                const float* __restrict in = x.data() + first;
                int32_t* __restrict to = out.data() + first;
                int row_bad = 0;  // local, so that the loop's bound cannot change under it
                for (int i = 0; i < width; ++i) to[i] = quantize_one(in[i], inv, row_bad);
                bad |= row_bad;
            },
            [&](int32_t id) { out[id] = quantize_one(x[id], inv, bad); });
    }
    if (bad) throw Error("quantizer step too small for these values");
}

namespace {

// One coefficient of dequantize: 0 for 0, else the magnitude plus kRecon of the quantizer's
// interval at the plane it was known to (none for an exact coefficient known to the last), with
// v's sign: the bits of (v < 0 ? -m : m) * step. In integer and bit operations without branches,
// so that the rows of a grid's bands vectorize on any x86-64; `known` of a coefficient never coded
// (kNone) is only read for v = 0, where the result is 0 anyway.
template <bool kExact>
inline float dequantize_one(int32_t v, uint8_t known, float step) {
    // 2^known exactly, from the exponent bits.
    const float scale = std::bit_cast<float>((static_cast<uint32_t>(known & 31) + 127u) << 23);
    uint32_t half = std::bit_cast<uint32_t>(kRecon * scale);
    if constexpr (kExact) half &= 0u - static_cast<uint32_t>(known != 0);
    const int32_t negative = v >> 31;  // 0 or -1
    const float m = static_cast<float>((v ^ negative) - negative) + std::bit_cast<float>(half);
    const uint32_t sign = static_cast<uint32_t>(v) & 0x80000000u;
    const uint32_t keep = 0u - static_cast<uint32_t>(v != 0);
    return std::bit_cast<float>((std::bit_cast<uint32_t>(m * step) ^ sign) & keep);
}

template <bool kExact>
void dequantize_bands(const CodingLayout& layout, const int32_t* value, const uint8_t* known,
                      std::span<const float> band_steps, float* out) {
    for (size_t b = 0; b < layout.bands.size(); ++b) {
        const float step = band_steps[b];
        for_band(
            layout, b,
            [&](size_t first, int width) {
                const int32_t* __restrict v = value + first;
                const uint8_t* __restrict kp = known + first;
                float* __restrict to = out + first;
                for (int i = 0; i < width; ++i) to[i] = dequantize_one<kExact>(v[i], kp[i], step);
            },
            [&](int32_t id) { out[id] = dequantize_one<kExact>(value[id], known[id], step); });
    }
}

}  // namespace

void dequantize(const CodingLayout& layout, const DecodedPlanes& decoded, int channel,
                std::span<const float> band_steps, bool exact, std::span<float> out) {
    const int32_t* value = decoded.value[channel].data();
    const uint8_t* known = decoded.known[channel].data();
    if (exact) {
        dequantize_bands<true>(layout, value, known, band_steps, out.data());
    } else {
        dequantize_bands<false>(layout, value, known, band_steps, out.data());
    }
}

namespace {

// One coefficient of requantize: 0 in the dead zone, else as dequantize, the magnitude (floor
// of |x| / step, a truncation since it is not negative) as an integer's float, 3/8 of a step into
// its interval, with x's sign. Branch-free so that the rows vectorize; `bad` is set when the
// magnitude reaches 1e9 (or x is NaN).
inline float requantize_one(float x, float step, float inv, int& bad) {
    const float a = std::abs(x) * inv;
    const bool ok = a < 1e9f;
    bad |= !ok;
    const auto m = static_cast<int32_t>(ok ? a : 0.0f);
    const float v = (static_cast<float>(m) + kRecon) * step;
    return m == 0 ? 0.0f : std::copysign(v, x);
}

}  // namespace

void requantize(const CodingLayout& layout, std::span<const float> x,
                std::span<const float> band_steps, std::span<float> out) {
    int bad = 0;
    for (size_t b = 0; b < layout.bands.size(); ++b) {
        const float step = band_steps[b], inv = 1.0f / step;
        for_band(
            layout, b,
            [&](size_t first, int width) {
                const float* __restrict in = x.data() + first;
                float* __restrict to = out.data() + first;
                for (int i = 0; i < width; ++i) to[i] = requantize_one(in[i], step, inv, bad);
            },
            [&](int32_t id) { out[id] = requantize_one(x[id], step, inv, bad); });
    }
    if (bad) throw Error("quantizer step too small for these values");
}

}  // namespace tesswave
