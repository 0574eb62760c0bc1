// Colour transforms of the still and video codecs: the reversible YCoCg-R for lossless coding and
// the irreversible YCbCr of JPEG 2000 (ITU-R BT.601 weights) for lossy coding. Both act on the
// first three planes and leave a fourth (alpha) as it is; grey images pass through.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

namespace tesswave {

// YCoCg-R, in place on integer planes R, G, B -> Y, Co, Cg (exactly invertible):
//   Co = R - B;  t = B + (Co >> 1);  Cg = G - t;  Y = t + (Cg >> 1).
void ycocg_r_forward(std::span<int32_t> r, std::span<int32_t> g, std::span<int32_t> b);
void ycocg_r_inverse(std::span<int32_t> y, std::span<int32_t> co, std::span<int32_t> cg);

// YCbCr, in place on float planes R, G, B -> Y, Cb, Cr.
void ycbcr_forward(std::span<float> r, std::span<float> g, std::span<float> b);
void ycbcr_inverse(std::span<float> y, std::span<float> cb, std::span<float> cr);

// Quantizer step factors per channel for `channels` planes after the lossy transform: an error e
// in channel c becomes an RGB error of length e |column c of the inverse|, so equal image error
// per channel needs steps proportional to 1 / |column c| (normalized to Y's); chroma is then
// made 1.2x coarser (an RD choice measured in colour.cpp). 1 for grey and alpha.
std::vector<float> ycbcr_step_factors(int channels);

}  // namespace tesswave
