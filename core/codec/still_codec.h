// The still-image codec (.twi, DESIGN.md 2.6): an image on a tessellation (or on the pixel
// lattice, for comparisons), colour transform, wavelet transform, per-band quantization with
// steps from the basis-function norms, and the embedded bit-plane coder. Any prefix of a file
// after its header decodes to a coarser image.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include "core/codec/twi_format.h"
#include "core/math/image.h"
#include "core/math/mesh.h"
#include "core/math/progress.h"
#include "core/math/project.h"

namespace tesswave {

// The default samples per pixel of the still codec's grid mesh (StillOptions::density).
inline constexpr double kStillDensity = 1.25;

struct StillOptions {
    TwiTransform transform = TwiTransform::mesh;
    bool lossless = false;  // integer lifting and YCoCg-R; every bit-plane coded
    // Rate control (lossy): at most max_bytes in all (0: no limit), or the smallest prefix whose
    // decoded image reaches target_psnr dB (0: none; a target the whole stream misses keeps the
    // whole stream and clears StillResult::target_reached). Without either the whole stream is
    // kept.
    int64_t max_bytes = 0;
    double target_psnr = 0;
    // Quantizer step for a band of unit norm, in units of the full pixel range; 0 picks one
    // (fine enough for any budget, or about 6 dB beyond target_psnr).
    double base_step = 0;
    // Mesh path. `mesh` covers the image's pixel rectangle; without one, a grid mesh is made.
    // `aligned` makes a grid mesh whose level-J vertices are the pixel centres (odd sizes only),
    // so that sampling and rendering are exact.
    Mesh mesh = {};
    bool aligned = false;
    // The transform of a default grid mesh's samples (lossy; other meshes, aligned grids and
    // lossless coding take the lifted wavelet). Kodak 1 / 5 at 0.5, 1, 2 bpp: +0.53 / +0.46 /
    // +0.67 dB and +0.72 / +0.95 / +0.94 dB for the 9/7 on the lattice.
    MeshWavelet mesh_wavelet = MeshWavelet::lattice97;
    // How the image goes on the mesh. With fit the encoder codes point samples and projections
    // (project.h) of a few smoothness weights and keeps the file with the lower error at the
    // target size, so that fit is never worse than point.
    Sampling sampling = Sampling::fit;
    int levels = 0;  // J (mesh) or decomposition levels (grid); 0: chosen
    // Samples per pixel when J is chosen. 1.25 rather than 1: at exactly one sample a pixel the
    // default grid's samples sit on the pixel corners, every pixel is the mean of four samples,
    // and a fit must sharpen hard (costly finest bands). A grid about 0.9 pixel apart blurs less:
    // Kodak 1-8 with the projection, mean PSNR at 0.25 / 0.5 / 1 / 2 bpp 28.34 / 31.08 / 34.53 /
    // 38.59 dB at 1, 28.36 / 31.15 / 34.80 / 39.50 at 1.25 (1.5: 28.38 / 31.11 / 34.69 / 39.28).
    double density = kStillDensity;
    int norm_probes = 1;     // impulses per band for the band norms
    bool measure = true;     // decode the result once and report its PSNR
    Progress progress = {};  // optional
};

struct StillResult {
    std::vector<uint8_t> file;
    TwiHeader header;
    double psnr = 0;             // of the decoded file against the input (NaN when not measured)
    bool target_reached = true;  // false: target_psnr was out of reach, the whole stream is kept
    std::string sampling = "point";  // what the file codes: "point", or "fit" and its smoothness
};

// The quantizer step (StillOptions::base_step) whose quantization error alone is about `psnr` dB:
// sqrt(12 * 10^(-psnr / 10)) of the full range (uniform error over a step: step^2 / 12).
double step_for_psnr(double psnr);

// Throws Error for images or options the codec cannot take (with the reason).
StillResult compress_image(const Image& image, const StillOptions& options);

// Throws the Error compress_image would throw for an image of this size and channel count (sides,
// pixels, mesh samples, channels), so that a file's declared size can be refused before its pixels
// are read (ImageLimits::check_size).
void check_still_size(int width, int height, int channels, const StillOptions& options);

struct StillDecodeOptions {
    size_t max_bytes = SIZE_MAX;  // decode only this prefix of the file
    TwiLimits limits = {};
};

// Decodes a file or any prefix of it that holds the whole header; `name` prefixes messages.
Image decompress_image(std::span<const uint8_t> file, const std::string& name,
                       const StillDecodeOptions& options = {});

// The mesh samples a lossless file holds, decoded (tests: the round trip of the samples is exact).
std::vector<std::vector<int32_t>> decode_lossless_samples(std::span<const uint8_t> file);
// The same samples taken from an image by the encoder's sampling.
std::vector<std::vector<int32_t>> lossless_samples(const Image& image, const TwiHeader& header);

}  // namespace tesswave
