// Full-reference quality metrics, PSNR and SSIM, computed the way FFmpeg's `psnr` and `ssim`
// filters compute them, so that a number reported here is the number `ffmpeg -lavfi` prints.
//
// Both compare integer samples. Each value v becomes q = round(v * peak) clamped to [0, peak],
// with peak = 2^bit_depth - 1 and the product taken in float, rounding halves up: the conversion
// OpenImageIO applies when write_image() stores an integer file. A metric of two Images therefore
// equals FFmpeg's on the 8-bit (or 16-bit) files written from them.
//
// FFmpeg reads RGB PNGs as rgb24 and both filters negotiate gbrp, a lossless repacking, so RGB is
// compared channel by channel with no YUV conversion; grey PNGs stay gray8. Channel results here
// are in the Image's channel order (R, G, B for RGB), as FFmpeg labels them (r:/g:/b:, R:/G:/B:).
// Every channel counts here; for RGBA, FFmpeg's psnr keeps alpha (gbrap) but its ssim drops it
// (gbrp), so pass the RGB planes alone to match its SSIM.
#pragma once

#include <vector>

#include "core/math/image.h"

namespace tesswave {

struct QualityOptions {
    int bit_depth = 8;  // 1..16; samples are quantized to 2^bit_depth levels before comparing
};

// PSNR = 10 log10(peak^2 / MSE) dB. MSE is in quantized units (0..peak^2). Where the MSE is 0
// (identical after quantization) the PSNR is +infinity; FFmpeg prints "inf".
struct Psnr {
    double all = 0;                   // from mse_all: FFmpeg's "average:"
    std::vector<double> per_channel;  // FFmpeg's r:/g:/b: (y: for grey)
    double mse_all = 0;  // mean of the channels' MSEs (FFmpeg weights by plane size; all equal)
};

// Throws Error if sizes or channel counts differ, an image is empty or bit_depth is outside 1..16.
Psnr psnr(const Image& reference, const Image& test, const QualityOptions& options = {});

// SSIM in x264's block form (Wang et al. 2004 with 8x8 box windows instead of a Gaussian). Sums
// are taken over 4x4 blocks; each window is 2x2 blocks, so windows are 8x8 at a stride of 4. With
// s1 = sum a, s2 = sum b, ss = sum (a^2 + b^2), s12 = sum ab over a window's 64 samples:
//
//   SSIM_w = (2 s1 s2 + C1) (2 (64 s12 - s1 s2) + C2)
//            / ((s1^2 + s2^2 + C1) (64 ss - s1^2 - s2^2 + C2))
//   C1 = round(0.01^2 peak^2 64),  C2 = round(0.03^2 peak^2 64 63)
//
// A channel's SSIM is the mean over the (floor(w/4) - 1) x (floor(h/4) - 1) windows: samples in
// the last w mod 4 columns and h mod 4 rows are never looked at. `all` is the mean over channels
// (FFmpeg weights by plane size; all equal). Identical images give exactly 1.
struct Ssim {
    double all = 0;                   // FFmpeg's "All:"
    std::vector<double> per_channel;  // FFmpeg's R:/G:/B: (Y: for grey)
};

// Throws Error as psnr() does, and also for images smaller than 8x8 (no window fits).
Ssim ssim(const Image& reference, const Image& test, const QualityOptions& options = {});

}  // namespace tesswave
