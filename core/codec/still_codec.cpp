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
#include "core/math/sampling.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

template <class T>
std::vector<std::span<const T>> const_spans(const std::vector<std::vector<T>>& planes) {
    return {planes.begin(), planes.end()};
}

void progress(const StillOptions& o, double done, const char* stage) {
    if (o.progress) o.progress(done, stage);
}

// The T0 mesh and J of the mesh path.
void choose_mesh(const Image& image, const StillOptions& o, TwiHeader& h) {
    const int W = image.width, H = image.height;
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
}

TwiHeader make_header(const Image& image, const StillOptions& o) {
    if (image.width < 1 || image.height < 1 || image.channels() < 1 || image.channels() > 4) {
        throw Error(str("cannot code a ", image.width, "x", image.height, " image with ",
                        image.channels(), " channels"));
    }
    TwiHeader h;
    h.transform = o.transform;
    h.lossless = o.lossless;
    h.channels = image.channels();
    h.bit_depth = image.format == SampleFormat::u8 ? 8 : 16;
    h.width = image.width;
    h.height = image.height;
    if (h.channels >= 3) h.colour = o.lossless ? TwiColour::ycocg_r : TwiColour::ycbcr;
    if (o.lossless && o.transform == TwiTransform::grid97) {
        throw Error("lossless coding needs the reversible 5/3 (--grid 53) or the mesh");
    }
    // What the decoder's default limits accept, and nothing more.
    const TwiLimits limits;
    const int64_t pixels = int64_t{image.width} * image.height;
    if (pixels > limits.max_pixels) {
        throw Error(str(image.width, "x", image.height, " pixels exceed the .twi limit of ",
                        limits.max_pixels));
    }
    if (o.transform == TwiTransform::mesh) {
        choose_mesh(image, o, h);
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
    const BitplaneOptions bo{.shifts = h.shifts};
    const DecodedPlanes d = decode_bitplanes(domain.layout(), h.planes, stream, bo);
    if (h.lossless) return domain.synthesize_int(integer_values(d));
    Planes x(h.channels, std::vector<float>(domain.size()));
    for (int c = 0; c < h.channels; ++c) {
        dequantize(domain.layout(), d, c, domain.band_steps(c, h.base_step), false, x[c]);
    }
    return domain.synthesize(std::move(x));
}

double image_psnr(const Image& a, const Image& b, int bit_depth) {
    return psnr(a, b, {.bit_depth = bit_depth}).all;
}

}  // namespace

double step_for_psnr(double psnr) { return std::sqrt(12.0 * std::pow(10.0, -psnr / 10)); }

StillResult compress_image(const Image& image, const StillOptions& o) {
    if (o.max_bytes < 0) throw Error(str("byte budget ", o.max_bytes, " is negative"));
    StillResult result;
    TwiHeader& h = result.header;
    h = make_header(image, o);
    progress(o, 0.0, "preparing");
    const CodingDomain domain(still_shape(h),
                              o.lossless ? std::max(o.norm_probes, 1) : o.norm_probes);
    const CodingLayout& layout = domain.layout();
    for (const CodingBand& b : layout.bands) h.band_norms.push_back(static_cast<float>(b.norm));
    progress(o, 0.3, "transforming");
    IntPlanes q;
    if (o.lossless) {
        q = domain.analyze_int(image);
        const float smallest = *std::min_element(h.band_norms.begin(), h.band_norms.end());
        for (float n : h.band_norms) {
            h.shifts.push_back(
                std::clamp(static_cast<int>(std::lround(std::log2(n / smallest))), 0, 32));
        }
    } else {
        const Planes x = domain.analyze(image);
        h.shifts.assign(layout.bands.size(), 0);
        q.assign(h.channels, std::vector<int32_t>(layout.size, 0));
        for (int c = 0; c < h.channels; ++c) {
            quantize(layout, x[c], domain.band_steps(c, h.base_step), q[c]);
        }
    }
    h.planes = count_planes(layout, const_spans(q));
    std::vector<uint8_t> head = write_twi_header(h);
    h.header_bytes = head.size();
    BitplaneOptions bo{.shifts = h.shifts};
    if (o.max_bytes > 0) {
        if (o.max_bytes <= static_cast<int64_t>(head.size())) {
            throw Error(str("a budget of ", o.max_bytes, " bytes does not hold the ", head.size(),
                            "-byte header"));
        }
        bo.max_bytes = o.max_bytes - head.size();
    }
    progress(o, 0.5, "coding");
    std::vector<uint8_t> stream = encode_bitplanes(layout, const_spans(q), h.planes, bo);
    if (stream.size() > bo.max_bytes) stream.resize(bo.max_bytes);

    if (o.target_psnr > 0 && !o.lossless) {
        // The smallest prefix reaching the target, by bisection (quality rises with the prefix).
        progress(o, 0.7, "rate search");
        const int depth = h.bit_depth;
        size_t lo = 0, hi = stream.size();
        if (image_psnr(image, reconstruct(domain, h, stream), depth) < o.target_psnr) {
            result.target_reached = false;  // the whole stream is the best this file can do
            lo = hi;
        }
        while (hi - lo > std::max<size_t>(1, hi / 500)) {
            const size_t mid = lo + (hi - lo) / 2;
            const std::span<const uint8_t> prefix(stream.data(), mid);
            if (image_psnr(image, reconstruct(domain, h, prefix), depth) >= o.target_psnr) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        stream.resize(hi);
    }
    progress(o, 0.9, "measuring");
    result.psnr = o.measure ? image_psnr(image, reconstruct(domain, h, stream), h.bit_depth)
                            : std::numeric_limits<double>::quiet_NaN();
    result.file = std::move(head);
    result.file.insert(result.file.end(), stream.begin(), stream.end());
    progress(o, 1.0, "done");
    return result;
}

Image decompress_image(std::span<const uint8_t> file, const std::string& name,
                       const StillDecodeOptions& options) {
    file = file.first(std::min(file.size(), options.max_bytes));
    const TwiHeader h = read_twi_header(file, name, options.limits);
    const CodingDomain domain(still_shape(h), 0, h.band_norms);
    return reconstruct(domain, h, file.subspan(h.header_bytes));
}

std::vector<std::vector<int32_t>> decode_lossless_samples(std::span<const uint8_t> file) {
    const TwiHeader h = read_twi_header(file, "lossless file");
    if (!h.lossless) throw Error("not a lossless file");
    const CodingDomain domain(still_shape(h), 0, h.band_norms);
    const DecodedPlanes d = decode_bitplanes(domain.layout(), h.planes,
                                             file.subspan(h.header_bytes), {.shifts = h.shifts});
    return domain.inverse_int(integer_values(d));
}

std::vector<std::vector<int32_t>> lossless_samples(const Image& image, const TwiHeader& header) {
    const CodingDomain domain(still_shape(header), 0, header.band_norms);
    return domain.samples_int(image);
}

}  // namespace tesswave
