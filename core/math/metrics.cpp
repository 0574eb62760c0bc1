#include "core/math/metrics.h"

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

// The integer sample OpenImageIO stores for v: roundf(v * peak) in float, clamped. NaN gives 0.
// Without libm and without branches, so that the metrics' loops vectorize (roundf is a call per
// sample on baseline x86-64; PSNR and SSIM took a tenth of a video encode): p = v * peak is
// clamped to [0, peak] (NaN to 0), and its truncation t plus one where the exact fraction p - t
// reaches 1/2 is roundf's half-away-from-zero result.
struct Quantizer {
    float scale;
    int32_t peak;

    int32_t operator()(float v) const {
        float p = v * scale;
        p = p > 0.0f ? p : 0.0f;
        p = p < scale ? p : scale;
        const auto t = static_cast<int32_t>(p);
        return t + (p - static_cast<float>(t) >= 0.5f ? 1 : 0);
    }
};

Quantizer quantizer(const QualityOptions& options) {
    const int32_t peak = (int32_t{1} << options.bit_depth) - 1;
    return {static_cast<float>(peak), peak};
}

std::string describe(const Image& image) {
    return str(image.width, "x", image.height, " with ", image.channels(), " channel(s)");
}

void check_pair(const char* metric, const Image& reference, const Image& test,
                const QualityOptions& options) {
    if (options.bit_depth < 1 || options.bit_depth > 16) {
        throw Error(str(metric, ": bit_depth ", options.bit_depth, " is outside 1..16"));
    }
    if (reference.width != test.width || reference.height != test.height ||
        reference.channels() != test.channels()) {
        throw Error(str(metric, ": reference is ", describe(reference), " but test is ",
                        describe(test), "; both must be the same size"));
    }
    if (reference.width <= 0 || reference.height <= 0 || reference.channels() <= 0) {
        throw Error(str(metric, ": images are empty (", describe(reference), ")"));
    }
    const size_t n = static_cast<size_t>(reference.width) * reference.height;
    for (const Image* image : {&reference, &test}) {
        for (int c = 0; c < image->channels(); ++c) {
            if (image->planes[c].size() != n) {
                throw Error(str(metric, ": ", image == &reference ? "reference" : "test", " plane ",
                                c, " holds ", image->planes[c].size(), " values, not ",
                                reference.width, "x", reference.height));
            }
        }
    }
}

// Cannot overflow: at most 65535^2 < 2^32 per sample and far fewer than 2^32 samples.
// Exact in 64 bits: at most 2^26 samples (the image limit), each square below 2^32.
uint64_t sum_squared_error(const std::vector<float>& a, const std::vector<float>& b, Quantizer q) {
    uint64_t sum = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        const int64_t d = q(a[i]) - q(b[i]);
        sum += static_cast<uint64_t>(d * d);
    }
    return sum;
}

double psnr_db(double mse, int32_t peak) {
    if (mse == 0.0) return std::numeric_limits<double>::infinity();
    return 10.0 * std::log10(static_cast<double>(peak) * peak / mse);
}

// Sums over one 4x4 block (or, added up, over one 8x8 window). Exact in int64 for 16-bit
// samples: a window's ss is at most 128 * 65535^2 < 2^39, and 64 ss < 2^45.
struct BlockSums {
    int64_t s1 = 0, s2 = 0, ss = 0, s12 = 0;

    BlockSums operator+(const BlockSums& o) const {
        return {s1 + o.s1, s2 + o.s2, ss + o.ss, s12 + o.s12};
    }
};

struct SsimConstants {
    int64_t c1, c2;
};

// Rounded as x264 and FFmpeg round them: 416 and 235963 for 8 bits.
SsimConstants ssim_constants(int32_t peak) {
    const double p = peak;
    return {static_cast<int64_t>(.01 * .01 * p * p * 64 + .5),
            static_cast<int64_t>(.03 * .03 * p * p * 64 * 63 + .5)};
}

// The block sums of the 4x4 blocks whose top row is y0; blocks.size() blocks from x = 0.
void block_row(const std::vector<float>& a, const std::vector<float>& b, int width, int y0,
               Quantizer q, std::vector<BlockSums>& blocks) {
    for (BlockSums& s : blocks) s = {};
    for (int y = y0; y < y0 + 4; ++y) {
        const float* row_a = a.data() + static_cast<size_t>(y) * width;
        const float* row_b = b.data() + static_cast<size_t>(y) * width;
        for (size_t k = 0; k < blocks.size(); ++k) {
            BlockSums& s = blocks[k];
            for (size_t x = 4 * k; x < 4 * k + 4; ++x) {
                const int64_t va = q(row_a[x]);
                const int64_t vb = q(row_b[x]);
                s.s1 += va;
                s.s2 += vb;
                s.ss += va * va + vb * vb;
                s.s12 += va * vb;
            }
        }
    }
}

// The variance terms are exact integers; only the final ratio is rounded (FFmpeg rounds each
// factor to float, which moves a channel's mean by ~1e-7).
double window_ssim(const BlockSums& s, SsimConstants c) {
    const int64_t vars = 64 * s.ss - s.s1 * s.s1 - s.s2 * s.s2;
    const int64_t covar = 64 * s.s12 - s.s1 * s.s2;
    const double num =
        static_cast<double>(2 * s.s1 * s.s2 + c.c1) * static_cast<double>(2 * covar + c.c2);
    const double den =
        static_cast<double>(s.s1 * s.s1 + s.s2 * s.s2 + c.c1) * static_cast<double>(vars + c.c2);
    return num / den;
}

double channel_ssim(const std::vector<float>& a, const std::vector<float>& b, int width, int height,
                    Quantizer q) {
    const int blocks_x = width / 4;
    const int blocks_y = height / 4;
    const SsimConstants c = ssim_constants(q.peak);
    std::vector<BlockSums> above(blocks_x), below(blocks_x);
    block_row(a, b, width, 0, q, above);
    double total = 0.0;
    for (int by = 1; by < blocks_y; ++by) {
        block_row(a, b, width, 4 * by, q, below);
        for (int bx = 0; bx + 1 < blocks_x; ++bx) {
            total += window_ssim(above[bx] + above[bx + 1] + below[bx] + below[bx + 1], c);
        }
        std::swap(above, below);
    }
    return total / (static_cast<double>(blocks_x - 1) * (blocks_y - 1));
}

}  // namespace

Psnr psnr(const Image& reference, const Image& test, const QualityOptions& options) {
    check_pair("psnr", reference, test, options);
    const Quantizer q = quantizer(options);
    const double samples = static_cast<double>(reference.width) * reference.height;
    Psnr out;
    for (int c = 0; c < reference.channels(); ++c) {
        const double mse = sum_squared_error(reference.planes[c], test.planes[c], q) / samples;
        out.per_channel.push_back(psnr_db(mse, q.peak));
        out.mse_all += mse;
    }
    out.mse_all /= reference.channels();
    out.all = psnr_db(out.mse_all, q.peak);
    return out;
}

Ssim ssim(const Image& reference, const Image& test, const QualityOptions& options) {
    check_pair("ssim", reference, test, options);
    if (reference.width < 8 || reference.height < 8) {
        throw Error(str("ssim: images are ", reference.width, "x", reference.height,
                        "; SSIM needs at least 8x8 pixels for one window"));
    }
    const Quantizer q = quantizer(options);
    Ssim out;
    for (int c = 0; c < reference.channels(); ++c) {
        out.per_channel.push_back(channel_ssim(reference.planes[c], test.planes[c], reference.width,
                                               reference.height, q));
        out.all += out.per_channel.back();
    }
    out.all /= reference.channels();
    return out;
}

}  // namespace tesswave
