#include "core/codec/still_codec.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/codec/coding_domain.h"
#include "core/math/colour.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/metrics.h"
#include "core/math/parallel.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

void progress(const StillOptions& o, double done, const char* stage) {
    if (o.progress) o.progress(done, stage);
}

// The T0 mesh and J of the mesh path.
void choose_mesh(int W, int H, const StillOptions& o, TwiHeader& h) {
    if (o.aligned) {
        h.levels = o.levels > 0 ? o.levels : default_grid(W, H, 1.0).levels;
        h.placement = MeshPlacement::centres;
        h.grid_cols = aligned_cells(W, h.levels);
        h.grid_rows = aligned_cells(H, h.levels);
        const double cell = std::ldexp(1.0, h.levels);
        h.mesh = grid_mesh(h.grid_cols * cell, h.grid_rows * cell, h.grid_cols, h.grid_rows);
        return;
    }
    if (!(o.density > 0) || !std::isfinite(o.density)) {
        throw Error(str("density ", o.density, " must be a positive number of samples per pixel"));
    }
    if (o.mesh.num_vertices() > 0) {
        if (o.mesh.width != W || o.mesh.height != H) {
            throw Error(str("mesh domain ", o.mesh.width, "x", o.mesh.height,
                            " does not match the image's ", W, "x", H, " pixels"));
        }
        h.mesh = o.mesh;
        round_mesh_vertices(h.mesh);
        require_valid(h.mesh, "mesh (at the file's 1/256-pixel vertex precision)");
        h.levels = o.levels > 0 ? o.levels : level_for_density(h.mesh, W * H, o.density);
        return;
    }
    const DefaultGrid grid = default_grid(W, H, o.density, o.levels);
    h.levels = grid.levels;
    h.grid_cols = grid.cols;
    h.grid_rows = grid.rows;
    h.mesh = grid_mesh(W, H, h.grid_cols, h.grid_rows);
    if (!o.lossless) h.mesh_wavelet = o.mesh_wavelet;
}

// The header of an image of this size, channel count and sample format (checked against the
// limits; no pixel is read).
TwiHeader make_header(int width, int height, int channels, SampleFormat format,
                      const StillOptions& o) {
    if (width < 1 || height < 1 || channels < 1 || channels > 4) {
        throw Error(
            str("cannot code a ", width, "x", height, " image with ", channels, " channels"));
    }
    TwiHeader h;
    h.transform = o.transform;
    h.lossless = o.lossless;
    h.channels = channels;
    h.bit_depth = format == SampleFormat::u8 ? 8 : 16;
    h.width = width;
    h.height = height;
    if (h.channels >= 3) h.colour = o.lossless ? TwiColour::ycocg_r : TwiColour::ycbcr;
    if (o.lossless && o.transform == TwiTransform::grid97) {
        throw Error("lossless coding needs the reversible 5/3 (--grid 53) or the mesh");
    }
    // What the decoder's default limits accept, and nothing more.
    const TwiLimits limits;
    if (width > kMaxTwiSide || height > kMaxTwiSide) {
        throw Error(
            str(width, "x", height, ": a side is longer than the .twi limit of ", kMaxTwiSide));
    }
    const int64_t pixels = int64_t{width} * height;
    if (pixels > limits.max_pixels) {
        throw Error(
            str(width, "x", height, " pixels exceed the .twi limit of ", limits.max_pixels));
    }
    if (o.transform == TwiTransform::mesh) {
        choose_mesh(width, height, o, h);
        const int64_t samples = sample_count(h.mesh, h.levels);
        if (samples > limits.max_samples ||
            samples > limits.max_samples_per_pixel * static_cast<double>(pixels) + (1 << 20)) {
            throw Error(str("level ", h.levels, " has ", samples, " samples (limit ",
                            limits.max_samples, ", and ", limits.max_samples_per_pixel,
                            " a pixel); lower --levels or --density"));
        }
    } else {
        h.levels = o.levels > 0 ? std::min(o.levels, 20) : 5;
    }
    h.channel_factors =
        o.lossless ? std::vector<float>(h.channels, 1.0f) : ycbcr_step_factors(h.channels);
    if (o.lossless) {
        h.base_step = 1.0f;
    } else if (o.base_step > 0) {
        h.base_step = static_cast<float>(o.base_step);
    } else if (o.target_psnr > 0) {
        h.base_step = static_cast<float>(step_for_psnr(o.target_psnr + 6));
    } else {
        h.base_step = 1.0f / 1024;
    }
    return h;
}

// The decoded coefficients as the integers the integer inverse takes.
IntPlanes integer_values(const DecodedPlanes& d) {
    IntPlanes out = d.value;
    for (size_t c = 0; c < out.size(); ++c) {
        for (size_t i = 0; i < out[c].size(); ++i) {
            const int32_t v = out[c][i];
            const int k = d.known[c][i];
            if (v == 0 || k == 0) continue;
            const int32_t half = int32_t{1} << (k - 1);
            out[c][i] = v < 0 ? v - half : v + half;
        }
    }
    return out;
}

Image reconstruct(const CodingDomain& domain, const TwiHeader& h, std::span<const uint8_t> stream) {
    const BitplaneOptions bo = twi_stream_options(h);
    DecodedPlanes d = decode_bitplanes(domain.layout(), h.planes, stream, bo);
    if (h.lossless) return domain.synthesize_int(integer_values(d));
    Planes x(h.channels);
    parallel_tasks(h.channels, [&](int64_t c) {  // a channel a thread
        x[c].resize(domain.size());
        dequantize(domain.layout(), d, static_cast<int>(c), domain.band_steps(c, h.base_step),
                   false, x[c]);
    });
    d = {};  // freed before the synthesis needs its planes
    return domain.synthesize(std::move(x));
}

double image_psnr(const Image& a, const Image& b, int bit_depth) {
    return psnr(a, b, {.bit_depth = bit_depth}).all;
}

}  // namespace

void check_still_size(int width, int height, int channels, const StillOptions& options) {
    make_header(width, height, channels, SampleFormat::u8, options);
}

double step_for_psnr(double psnr) { return std::sqrt(12.0 * std::pow(10.0, -psnr / 10)); }

namespace {

// One coded candidate: a header (its bit-plane counts depend on the samples) and a stream.
struct Coded {
    TwiHeader header;
    std::vector<uint8_t> head, stream;
    std::vector<uint8_t> full;  // the stream before the rate control cut it
    double psnr = 0;            // of the kept prefix (NaN when not measured)
    bool target_reached = true;
    size_t bytes() const { return head.size() + stream.size(); }
};

// Codes quantized coefficients `q` (freed once coded, before any reconstruction), then applies
// the rate control of `o`.
Coded code(const CodingDomain& domain, const TwiHeader& base, IntPlanes q, const Image& image,
           const StillOptions& o, bool measure) {
    Coded c;
    TwiHeader& h = c.header;
    h = base;
    h.planes = count_planes(domain.layout(), const_spans(q));
    c.head = write_twi_header(h);
    h.header_bytes = c.head.size();
    BitplaneOptions bo = twi_stream_options(h);
    if (o.max_bytes > 0) {
        if (o.max_bytes <= static_cast<int64_t>(c.head.size())) {
            throw Error(str("a budget of ", o.max_bytes, " bytes does not hold the ", c.head.size(),
                            "-byte header"));
        }
        bo.max_bytes = o.max_bytes - c.head.size();
    }
    c.stream = encode_bitplanes(domain.layout(), const_spans(q), h.planes, bo);
    q = {};
    if (c.stream.size() > bo.max_bytes) c.stream.resize(bo.max_bytes);
    c.full = c.stream;
    const int depth = h.bit_depth;
    if (o.target_psnr > 0 && !o.lossless) {
        // The smallest prefix reaching the target, by bisection (quality rises with the prefix).
        size_t lo = 0, hi = c.stream.size();
        c.psnr = image_psnr(image, reconstruct(domain, h, c.stream), depth);
        if (c.psnr < o.target_psnr) {
            c.target_reached = false;  // the whole stream is the best this file can do
            lo = hi;
        }
        while (hi - lo > std::max<size_t>(1, hi / 500)) {
            const size_t mid = lo + (hi - lo) / 2;
            const std::span<const uint8_t> prefix(c.stream.data(), mid);
            if (image_psnr(image, reconstruct(domain, h, prefix), depth) >= o.target_psnr) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        c.stream.resize(hi);
    }
    c.psnr = measure ? image_psnr(image, reconstruct(domain, h, c.stream), depth)
                     : std::numeric_limits<double>::quiet_NaN();
    return c;
}

// The projections the encoder tries beside point sampling: none (the closest render, for the
// highest qualities) and smoothness weights that keep the finest bands cheap, each tried for
// targets of at least its size (bits per pixel) or PSNR, and with no target. On Kodak 1, 3 and 8
// at density 1, the best of 0.001 to 0.03 was 0.01 or 0.03 at 0.5 bpp and 0.001 to 0.01 at 2 bpp;
// a penalty on the finest detail alone (d = sample less the mean of its coarser neighbours) was
// 0.3 to 2 dB behind smoothness at 1 and 2 bpp and was dropped. They are solved smoothest first,
// each from the one before (analyze_fits): on Kodak 1 that took 66 iterations in all where four
// solves from the point samples took 72, and left the unsmoothed one closer to its solution.
// - 0.001: with band norms weighed by rendering, Kodak 1-8 at 2 bpp chose it over 0.003 on all
//   eight (+0.04 to +0.37 dB, mean +0.20); at 1 bpp 0.003 won on all eight. 0.0003 in its place
//   was 0.04 to 0.23 dB behind it at 2 bpp. With --psnr it is tried from 33 dB, the lowest PSNR
//   of the eight at 2 bpp (Kodak 8: 33.10 dB).
// - 0 (the costliest solve: it runs to the iteration limit): it never won below 3 bpp or 40 dB
//   (Kodak 1-8 at 0.25, 1 and 2 bpp, Kodak 1, 3 and 7 at 3 bpp); it won on Kodak 1 from 4 bpp
//   (38.98 dB) and on Kodak 3 and 7 from 6 bpp.
struct FitChoice {
    double smoothness, from_bpp, from_psnr;
};
constexpr FitChoice kFits[] = {
    {0.03, 0, 0}, {0.01, 0, 0}, {0.003, 0, 0}, {0.001, 1.5, 33}, {0.0, 3, 40}};

bool worth_trying(const FitChoice& fit, const StillOptions& o, int64_t pixels) {
    if (o.max_bytes > 0) return o.max_bytes * 8.0 >= fit.from_bpp * static_cast<double>(pixels);
    if (o.target_psnr > 0) return o.target_psnr >= fit.from_psnr;
    return true;
}

// The index of the candidate with the lower error at the target size: at the budget, the
// smallest file that reaches the target PSNR, or, with the whole stream kept, the best PSNR when
// every candidate is cut to the shortest one's size.
size_t pick(const std::vector<Coded>& c, const CodingDomain& domain, const Image& image,
            const StillOptions& o) {
    size_t best = 0;
    if (o.target_psnr > 0) {
        for (size_t k = 1; k < c.size(); ++k) {
            const bool better = c[k].target_reached == c[best].target_reached
                                    ? (c[k].target_reached ? c[k].bytes() < c[best].bytes()
                                                           : c[k].psnr > c[best].psnr)
                                    : c[k].target_reached;
            if (better) best = k;
        }
        return best;
    }
    if (o.max_bytes > 0) {
        for (size_t k = 1; k < c.size(); ++k) best = c[k].psnr > c[best].psnr ? k : best;
        return best;
    }
    size_t shortest = c[0].bytes();
    for (const Coded& k : c) shortest = std::min(shortest, k.bytes());
    // Each candidate's reconstruction on a thread of its own.
    std::vector<double> psnr(c.size());
    parallel_tasks(static_cast<int64_t>(c.size()), [&](int64_t i) {
        const Coded& k = c[static_cast<size_t>(i)];
        const size_t keep = std::min(k.stream.size(), shortest - k.head.size());
        psnr[static_cast<size_t>(i)] = image_psnr(
            image, reconstruct(domain, k.header, {k.stream.data(), keep}), k.header.bit_depth);
    });
    double best_psnr = -INFINITY;
    for (size_t k = 0; k < c.size(); ++k) {
        if (psnr[k] > best_psnr) best = k, best_psnr = psnr[k];
    }
    return best;
}

}  // namespace

namespace {

// The decoder's default limits weigh a header against the file's size (a small file may only
// claim a small image). A file below that floor keeps more of its stream, or, when the whole
// stream is shorter (a large flat image), gets zeros after it, which the decoder never reads:
// a complete stream stops at its last bit-plane.
void meet_size_floor(Coded& c, const CodingDomain& domain, const Image& image,
                     const StillOptions& o) {
    const TwiHeader& h = c.header;
    const int64_t samples = h.transform == TwiTransform::mesh ? sample_count(h.mesh, h.levels) : 0;
    const int64_t needed = twi_bytes_needed(int64_t{h.width} * h.height, samples);
    if (static_cast<int64_t>(c.bytes()) >= needed) return;
    if (o.max_bytes > 0 && o.max_bytes < needed) {
        throw Error(str("a ", h.width, "x", h.height, " file needs at least ", needed,
                        " bytes to be decodable within the default limits; the budget is ",
                        o.max_bytes));
    }
    const size_t want = static_cast<size_t>(needed) - c.head.size();
    c.stream.assign(c.full.begin(),
                    c.full.begin() + static_cast<std::ptrdiff_t>(std::min(want, c.full.size())));
    c.stream.resize(want, 0);  // zeros only past a complete stream
    if (!std::isnan(c.psnr))
        c.psnr = image_psnr(image, reconstruct(domain, h, c.stream), h.bit_depth);
}

// A file the decoder's default limits would refuse is never written.
void require_decodable(const StillResult& r) {
    const TwiHeader& h = r.header;
    const int64_t samples = h.transform == TwiTransform::mesh ? sample_count(h.mesh, h.levels) : 0;
    const int64_t needed = twi_bytes_needed(int64_t{h.width} * h.height, samples);
    if (static_cast<int64_t>(r.file.size()) < needed) {
        throw Error(str("the file would be ", r.file.size(), " bytes; one of ", h.width, "x",
                        h.height, " pixels", samples > 0 ? str(" and ", samples, " samples") : "",
                        " needs at least ", needed,
                        " to be decodable within the default limits (raise the rate or lower "
                        "the density)"));
    }
}

}  // namespace

StillResult compress_image(const Image& image, const StillOptions& o) {
    if (o.max_bytes < 0) throw Error(str("byte budget ", o.max_bytes, " is negative"));
    StillResult result;
    TwiHeader h = make_header(image.width, image.height, image.channels(), image.format, o);
    progress(o, 0.0, "preparing");
    const auto shared = o.lossless
                            ? shared_domain(still_shape(h), std::max(o.norm_probes, 1))
                            : shared_domain(still_shape(h), o.norm_probes, {}, BandNorms::rendered);
    const CodingDomain& domain = *shared;
    const CodingLayout& layout = domain.layout();
    for (const CodingBand& b : layout.bands) h.band_norms.push_back(static_cast<float>(b.norm));
    if (o.lossless) {
        progress(o, 0.3, "transforming");
        IntPlanes q = domain.analyze_int(image);
        const float smallest = *std::min_element(h.band_norms.begin(), h.band_norms.end());
        for (float n : h.band_norms) {
            h.shifts.push_back(
                std::clamp(static_cast<int>(std::lround(std::log2(n / smallest))), 0, 32));
        }
        progress(o, 0.5, "coding");
        Coded c = code(domain, h, std::move(q), image, o, o.measure);
        meet_size_floor(c, domain, image, o);
        result.header = c.header;
        result.psnr = c.psnr;
        result.file = std::move(c.head);
        result.file.insert(result.file.end(), c.stream.begin(), c.stream.end());
        require_decodable(result);
        progress(o, 1.0, "done");
        return result;
    }
    h.shifts.assign(layout.bands.size(), 0);
    // Point sampling, then the projections when they can differ from it (mesh samples that are
    // not the pixels themselves).
    struct Choice {
        Sampling sampling;
        double smoothness;
    };
    std::vector<Choice> choices = {{Sampling::point, 0}};
    if (o.sampling == Sampling::fit && o.transform == TwiTransform::mesh && !o.aligned) {
        for (const FitChoice& fit : kFits) {
            if (worth_trying(fit, o, int64_t{image.width} * image.height))
                choices.push_back({Sampling::fit, fit.smoothness});
        }
    }
    std::vector<Coded> coded(choices.size());
    const auto part = [&](size_t k) {
        return progress_range(o.progress, 0.05 + 0.85 * k / choices.size(),
                              0.05 + 0.85 * (k + 1) / choices.size());
    };
    // The candidates are coded side by side, as many at once as there are threads: each one's
    // coding and measurements (the serial bit-plane coder, reconstructions) run on one thread,
    // while the projections between batches share the threads. A batch's coefficients are
    // quantized and freed as it is coded, so at most a batch of them is held at once.
    struct Waiting {
        size_t k;
        Planes x;
    };
    std::vector<Waiting> batch;
    const size_t batch_size = static_cast<size_t>(std::max(1, thread_count()));
    const auto code_one = [&](Waiting& w) {
        IntPlanes q(h.channels);
        parallel_tasks(h.channels, [&](int64_t c) {  // a channel a thread, when not nested
            q[c].resize(layout.size);
            quantize(layout, w.x[c], domain.band_steps(c, h.base_step), q[c]);
        });
        w.x = {};
        coded[w.k] = code(domain, h, std::move(q), image, o, o.measure || choices.size() > 1);
    };
    const auto code_batch = [&] {
        for (const Waiting& w : batch) report(part(w.k), 0.4, "coding");
        // A lone candidate (a fixed grid's, or the last) keeps the threads for its own parts.
        if (batch.size() == 1) {
            code_one(batch[0]);
        } else {
            parallel_tasks(static_cast<int64_t>(batch.size()),
                           [&](int64_t i) { code_one(batch[static_cast<size_t>(i)]); });
        }
        batch.clear();
    };
    // Takes the coefficients `x` (analyze_fits lets its callback do so).
    const auto code_choice = [&](size_t k, Planes& x) {
        batch.push_back({k, std::move(x)});
        if (batch.size() == batch_size || k + 1 == choices.size()) code_batch();
    };
    report(part(0), 0.0, "sampling");
    Planes point = domain.analyze(image, Sampling::point);
    code_choice(0, point);
    // The projections, one after the other from one assembly (analyze_fits).
    std::vector<double> smoothness;
    for (size_t k = 1; k < choices.size(); ++k) smoothness.push_back(choices[k].smoothness);
    if (!smoothness.empty()) report(part(1), 0.0, "projecting");
    domain.analyze_fits(image, smoothness, {}, [&](size_t k, Planes& x) {
        code_choice(k + 1, x);
        if (k + 2 < choices.size()) report(part(k + 2), 0.0, "projecting");
    });
    progress(o, 0.9, "choosing");
    const size_t best = choices.size() > 1 ? pick(coded, domain, image, o) : 0;
    Coded& c = coded[best];
    meet_size_floor(c, domain, image, o);
    result.header = c.header;
    result.psnr = o.measure ? c.psnr : std::numeric_limits<double>::quiet_NaN();
    result.target_reached = c.target_reached;
    result.sampling =
        choices[best].sampling == Sampling::point ? "point" : str("fit ", choices[best].smoothness);
    result.file = std::move(c.head);
    result.file.insert(result.file.end(), c.stream.begin(), c.stream.end());
    require_decodable(result);
    progress(o, 1.0, "done");
    return result;
}

Image decompress_image(std::span<const uint8_t> file, const std::string& name,
                       const StillDecodeOptions& options) {
    // The header is weighed against the whole file; a prefix decodes the first max_bytes.
    const TwiHeader h = read_twi_header(file, name, options.limits);
    if (options.max_bytes < h.header_bytes) {
        throw Error(str(name, ": ", options.max_bytes,
                        options.max_bytes == 1 ? " byte does" : " bytes do", " not hold the ",
                        h.header_bytes, "-byte header"));
    }
    const auto shared = shared_domain(still_shape(h), 0, h.band_norms);
    const CodingDomain& domain = *shared;
    file = file.first(std::min(file.size(), options.max_bytes));
    return reconstruct(domain, h, file.subspan(h.header_bytes));
}

std::vector<std::vector<int32_t>> decode_lossless_samples(std::span<const uint8_t> file) {
    const TwiHeader h = read_twi_header(file, "lossless file");
    if (!h.lossless) throw Error("not a lossless file");
    const auto shared = shared_domain(still_shape(h), 0, h.band_norms);
    const CodingDomain& domain = *shared;
    const DecodedPlanes d = decode_bitplanes(domain.layout(), h.planes,
                                             file.subspan(h.header_bytes), twi_stream_options(h));
    return domain.inverse_int(integer_values(d));
}

std::vector<std::vector<int32_t>> lossless_samples(const Image& image, const TwiHeader& header) {
    return shared_domain(still_shape(header), 0, header.band_norms)->samples_int(image);
}

}  // namespace tesswave
