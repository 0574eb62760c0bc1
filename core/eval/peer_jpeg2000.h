// JPEG 2000 (ISO/IEC 15444-1) through OpenJPEG, in memory: the peer codec "tesswave compare" puts
// beside the still-image codec at equal file size.
//
// The encoder writes a raw J2K codestream (SOC ... EOC, what opj_compress writes to a .j2k file),
// not a JP2 file: the JP2 boxes, 85 bytes with OpenJPEG, carry no image data. Its settings are
// opj_compress's defaults: one tile, 64x64 code-blocks, no precincts, LRCP order, one quality
// layer, and the multiple component transform on the first three components when there are three
// or more (ICT with the 9/7, RCT with the 5/3). Only the COM marker differs: it is empty (6 bytes)
// instead of "Created by OpenJPEG version 2.5.0" (39 bytes). One thread, the caller's.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/math/image.h"

namespace tesswave {

struct Jpeg2000Options {
    // 0: lossless, the reversible 5/3 and RCT. Otherwise the irreversible 9/7 and ICT, and the
    // whole codestream, every marker from SOC to EOC included, is the largest OpenJPEG's rate
    // allocator can make within target_bytes (see encode_jpeg2000()).
    int64_t target_bytes = 0;
    int levels = 5;  // wavelet decomposition levels, 0..32; fewer where the image is too small
};

// Samples are quantized to 8 bits as write_image() and psnr() do: round(v * 255) in float, halves
// away from zero, clamped to 0..255, NaN to 0. The image has 1..4 channels, stored as components
// in channel order. Levels are lowered to floor(log2(min(width, height))), the most OpenJPEG
// accepts, for small images.
//
// Lossy rate control: OpenJPEG's single quality layer keeps, in each code-block, the passes whose
// distortion-rate slope clears one threshold, bisected to fit a byte budget, so the sizes it can
// reach are steps apart: about 50 to 300 bytes on a 768x512 photograph at 0.25 to 1 bpp (0.2 to
// 1.5 % of the target), more on tiny images. The result is the highest step <= target_bytes, in
// one encode: the budget handed over (as the ratio raw bytes / budget) is target_bytes minus the
// 16 bytes OpenJPEG 2.5 leaves out of it (SOT, SOD, EOC) and half a byte for its rounding up.
// Should an OpenJPEG overshoot anyway, a search on the budget (at most 12 encodes) takes over.
//
// Throws Error for an empty image, more than 4 channels, a plane of the wrong size, a negative
// target or levels outside 0..32, and for a target below the smallest codestream of the image
// (headers plus empty packets, about 100 to 200 bytes).
std::vector<uint8_t> encode_jpeg2000(const Image& image, const Jpeg2000Options& options);

// Reads a J2K codestream or a JP2 file (told apart by their signatures), as written by
// encode_jpeg2000() or opj_compress. Unsigned components of 1..16 bits, all of the image's size
// (no subsampling), 1..4 of them, at most kJpeg2000MaxSamples samples in all; value v becomes
// v / (2^bits - 1). The format is u8 for up to 8 bits, u16 above. A codestream truncated inside
// its packets decodes to what the prefix holds, as OpenJPEG allows; anything OpenJPEG rejects, or
// a header outside the limits above, throws Error with OpenJPEG's message.
inline constexpr int64_t kJpeg2000MaxSamples = int64_t{1} << 28;
Image decode_jpeg2000(std::span<const uint8_t> bytes);

}  // namespace tesswave
