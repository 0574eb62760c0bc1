// The embedded bit-plane coder (DESIGN.md 2.6): quantized coefficients, most significant plane
// first, each plane in three passes per band and channel as in EBCOT: significance of the
// coefficients with a significant neighbour or parent, refinement of the significant ones, then
// significance of the rest (isolated coefficients four at a time in run mode, and in bands of
// 4096 coefficients or more in zero blocks of 64 and 16 before that, so that a sparse plane costs
// few decisions). Every binary decision goes through the adaptive range coder with a context from
// the band, the channel class, and how many neighbours and parents are significant. Any prefix of
// the stream decodes to the coefficients it determines; the rest stay zero, and each coefficient
// is reconstructed 3/8 into the interval its known bits leave open.
#pragma once

#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "core/codec/coding_layout.h"

namespace tesswave {

// Bit-planes per channel and band: 0 for an all-zero band, else 1 + the top bit of its largest
// magnitude (at most 31).
using PlaneCounts = std::vector<std::vector<uint8_t>>;  // [channel][band]

PlaneCounts count_planes(const CodingLayout& layout, std::span<const std::span<const int32_t>> q);

struct BitplaneOptions {
    // Per band, how many sweeps later its planes come (0 for all in lossy coding, where the steps
    // already carry the norms; lossless coding shifts coarse bands earlier by their norm).
    std::vector<int> shifts;
    size_t max_bytes = std::numeric_limits<size_t>::max();  // the encoder stops past this size
    // Encoder only, when set: the truncation points. Entry 3 t + pass is the stream's size once
    // pass `pass` (0 significance near significant, 1 refinement, 2 the rest) of sweep t is
    // coded; sweeps run from the top down, so sizes grow as t falls. Entries the encoder did not
    // reach (it stopped at max_bytes) are SIZE_MAX.
    std::vector<size_t>* pass_ends = nullptr;
    // Fresh probability models learn fast (range_coder.h); false for the streams of .twi and .twv
    // version 1, whose models adapted at their settled rates from the start.
    bool fast_start = true;
    // Zero blocks: in the third pass over a band of 4096 coefficients or more, 64 and then 16
    // isolated coefficients take one decision (none for the last smaller block of a block that
    // holds a significant one, when the others held none) before their runs of 4; false for the
    // streams of .twi versions 1 to 3 and .twv versions 1 to 5, which code runs of 4 only.
    bool blocks = true;
};

// Codes the quantized planes (sign and magnitude in an int32 per coefficient). The result may be
// a few bytes longer than max_bytes; any prefix of it decodes.
std::vector<uint8_t> encode_bitplanes(const CodingLayout& layout,
                                      std::span<const std::span<const int32_t>> q,
                                      const PlaneCounts& planes, const BitplaneOptions& options);

struct DecodedPlanes {
    std::vector<std::vector<int32_t>> value;  // signed magnitudes from the known bits
    std::vector<std::vector<uint8_t>> known;  // lowest known plane per coefficient (32: none)
    bool complete = false;                    // every plane of every band was decoded
};

// Throws Error when `planes` does not match the layout; never reads past `stream`.
DecodedPlanes decode_bitplanes(const CodingLayout& layout, const PlaneCounts& planes,
                               std::span<const uint8_t> stream, const BitplaneOptions& options);

// Dead-zone quantization of one channel: sign floor(|x| / s) per coefficient, with s the step of
// its band (computed as |x| times 1/s in float). Throws Error when a magnitude reaches 1e9 (a
// step far too small for the values).
void quantize(const CodingLayout& layout, std::span<const float> x,
              std::span<const float> band_steps, std::span<int32_t> out);

// Coefficient c of a band with step s: 0 when its known magnitude m is 0, else
// sign (m + 3/8 2^k) s with k the lowest known plane, or exactly sign m s when k = 0 and `exact`.
void dequantize(const CodingLayout& layout, const DecodedPlanes& decoded, int channel,
                std::span<const float> band_steps, bool exact, std::span<float> out);

// quantize followed by dequantize with every plane known and `exact` false, in one pass and
// without the integer planes: what a decoder reconstructs from the whole stream at these steps
// (an encoder's search for a step measures it). The same floats; throws as quantize does.
void requantize(const CodingLayout& layout, std::span<const float> x,
                std::span<const float> band_steps, std::span<float> out);

}  // namespace tesswave
