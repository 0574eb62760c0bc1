#include "core/codec/coding_domain.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <mutex>

#include "core/math/colour.h"
#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/lifting.h"
#include "core/math/parallel.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

template <class T>
std::vector<std::span<T>> spans(std::vector<std::vector<T>>& planes) {
    return {planes.begin(), planes.end()};
}

float max_value(SampleFormat format) { return format == SampleFormat::u16 ? 65535.0f : 255.0f; }

}  // namespace

GridWavelet wavelet_of(TwiTransform transform) {
    return transform == TwiTransform::grid97 ? GridWavelet::cdf97 : GridWavelet::cdf53;
}

DomainShape still_shape(const TwiHeader& h) {
    return {.transform = h.transform,
            .width = h.width,
            .height = h.height,
            .channels = h.channels,
            .format = h.bit_depth == 16 ? SampleFormat::u16 : SampleFormat::u8,
            .colour = h.colour,
            .levels = h.levels,
            .mesh = h.mesh,
            .placement = h.placement,
            .channel_factors = h.channel_factors,
            .mesh_wavelet = h.mesh_wavelet,
            .grid_cols = h.grid_cols,
            .grid_rows = h.grid_rows};
}

CodingDomain::CodingDomain(DomainShape shape, int probes, std::span<const float> norms,
                           BandNorms weigh)
    : shape_(std::move(shape)) {
    const DomainShape& s = shape_;
    if (s.transform != TwiTransform::mesh) {
        layout_ = grid_layout(s.width, s.height, s.levels, wavelet_of(s.transform), probes > 0);
    } else {
        hierarchy_ = build_hierarchy(s.mesh, {.levels = s.levels, .finest_topology = false});
        if (s.mesh_wavelet == MeshWavelet::lattice97) {
            if (s.grid_cols < 1 || s.grid_rows < 1 ||
                s.mesh.face_corners !=
                    grid_mesh(s.mesh.width, s.mesh.height, s.grid_cols, s.grid_rows).face_corners) {
                throw Error("the lattice 9/7 needs a grid mesh");
            }
            lattice_ = grid_lattice_index(*hierarchy_, s.grid_cols, s.grid_rows);
            lattice_width_ = static_cast<int>(grid_lattice_side(s.grid_cols, s.levels));
            lattice_height_ = static_cast<int>(grid_lattice_side(s.grid_rows, s.levels));
            layout_ = grid_layout(lattice_width_, lattice_height_, s.levels, GridWavelet::cdf97,
                                  probes > 0);
            // Norms in pixel units, as mesh_layout's: a sample stands for area / |V_J| pixels.
            const double scale = std::sqrt(s.mesh.width * s.mesh.height / lattice_.size());
            if (probes > 0) {
                for (CodingBand& b : layout_.bands) b.norm *= scale;
            }
        } else {
            layout_ = mesh_layout(*hierarchy_, s.mesh.width * s.mesh.height, probes);
        }
        if (s.canvas && s.placement != MeshPlacement::area) {
            throw Error("a canvas mesh is placed by area");
        }
        if (s.placement == MeshPlacement::centres) {
            // Sample (x, y) is pixel (x, y); past the last column or row it repeats the edge pixel.
            const std::vector<Vec2> p = refine_positions(*hierarchy_, s.mesh.vertices, s.levels);
            pixel_of_sample_.resize(p.size());
            for (size_t i = 0; i < p.size(); ++i) {
                const double x = std::round(p[i].x), y = std::round(p[i].y);
                if (std::abs(p[i].x - x) > 1e-6 || std::abs(p[i].y - y) > 1e-6) {
                    throw Error(str("mesh sample ", i, " is not on a pixel centre"));
                }
                const int64_t px = std::min<int64_t>(static_cast<int64_t>(x), s.width - 1);
                const int64_t py = std::min<int64_t>(static_cast<int64_t>(y), s.height - 1);
                pixel_of_sample_[i] = static_cast<int32_t>(py * s.width + px);
                if (x < s.width && y < s.height)
                    written_samples_.push_back(static_cast<int32_t>(i));
            }
        } else if (!s.canvas) {
            rest_plan_ = plan_render(*hierarchy_, s.mesh.vertices, s.mesh.width, s.mesh.height,
                                     s.width, s.height);
        }
        if (probes > 0 && weigh == BandNorms::rendered && rest_plan_) {
            weigh_norms_by_rendering(*rest_plan_);
        }
    }
    if (probes == 0 && !norms.empty()) {
        if (norms.size() != layout_.bands.size()) {
            throw Error(str(norms.size(), " band norms for a coding layout of ",
                            layout_.bands.size(), " bands"));
        }
        for (size_t b = 0; b < norms.size(); ++b) layout_.bands[b].norm = norms[b];
    }
}

// How far a band's norm moves toward its rendered norm: the norm is scaled by r^kRenderedWeight,
// with r the rendered energy of the band's detail over its samples' energy in pixel units. The
// renderer's bilinear interpolation damps fine detail (9/7 on the lattice, Kodak at density 1: r
// is 0.19 for the horizontal and vertical bands of level 1 and 0.05 for the diagonal one, 0.66 /
// 0.49 at level 2, above 0.97 from level 4). Kodak 1-8 at density 1, mean PSNR at 0.25 / 0.5 / 1 /
// 2 bpp, 9/7 on the lattice: samples' norms (0) 28.29 / 30.95 / 34.29 / 38.05 dB, 0.25 28.34 /
// 31.08 / 34.53 / 38.39, rendered norms (0.5) 28.27 / 31.01 / 34.48 / 38.37; lifted wavelet: 0
// 27.73 / 30.30 / 33.63 / 37.22, 0.25 27.68 / 30.35 / 33.64 / 37.63, 0.5 27.57 / 30.25 / 33.65 /
// 37.58. The full weight lost up to 0.36 dB at 0.25 bpp (Kodak 1), 0.25 at most 0.09 (Kodak 1 at
// 1 bpp) on the lattice. The video encoder keeps the samples' norms: with 0.25, carphone (64
// frames, moving mesh, 0.02 to 0.8 bpp) lost 2.3 % in BD-rate (up to 0.21 dB), chaplin and the
// canvas groups of aerial and Big Buck Bunny moved by less than 0.05 %.
constexpr double kRenderedWeight = 0.25;

// Each band's detail is a random-sign pattern (every coefficient of the band +-1, signs from a
// fixed generator run through the bands from the finest), synthesized to the samples and rendered
// at rest. Bands are weighed from the finest level up, and coarser levels keep their norms once
// every band of a level renders within 1 % of its samples' energy (on Kodak at density 1 every
// level is weighed: level 5's diagonal band renders 1.6 % below). The cost is an inverse
// transform and a render of the whole plane per band weighed, so the bands of two levels at a
// time are measured side by side, one a thread (a level past the one that stops is measured for
// nothing); the norms are the same on any thread count.
void CodingDomain::weigh_norms_by_rendering(const RenderPlan& plan) {
    const double pixel_units = static_cast<double>(plan.width) * plan.height / size();
    const size_t bands = layout_.bands.size();
    // Band b's generator state where the sequential pass over the bands (finest first) starts it.
    std::vector<uint32_t> first_state(bands);
    uint32_t state = 0x2545F491u;
    for (size_t b = bands; b-- > 0;) {
        first_state[b] = state;
        for (int32_t k = layout_.bands[b].begin; k < layout_.bands[b].end; ++k)
            state = state * 1664525u + 1013904223u;  // a linear congruential generator
    }
    // Rendered energy over the samples' energy in pixel units; NaN for a band that renders or
    // synthesizes to nothing.
    const auto ratio = [&](size_t b) {
        const CodingBand& band = layout_.bands[b];
        Planes x(1, std::vector<float>(static_cast<size_t>(size()), 0.0f));
        std::vector<float>& plane = x[0];  // synthesis() keeps the vector, swapping its contents
        uint32_t s = first_state[b];
        for (int32_t k = band.begin; k < band.end; ++k) {
            s = s * 1664525u + 1013904223u;
            plane[layout_.order[k]] = (s >> 31) ? 1.0f : -1.0f;
        }
        synthesis(x);
        double samples = 0, pixels = 0;
        for (float v : plane) samples += double{v} * v;
        Image rendered = make_image(plan.width, plan.height, 1, SampleFormat::f32);
        render_into(plan, std::vector<std::span<const float>>{plane}, rendered);
        for (float v : rendered.planes[0]) pixels += double{v} * v;
        return samples > 0 && pixels > 0 ? pixels / (samples * pixel_units)
                                         : std::numeric_limits<double>::quiet_NaN();
    };
    size_t next = bands;  // bands [0, next) are still to be weighed, the finest last
    while (next > 0) {
        // The bands of the next two levels (finest first).
        size_t first = next;
        for (int levels = 0; first > 0 && levels < 2; ++levels) {
            const int level = layout_.bands[first - 1].level;
            while (first > 0 && layout_.bands[first - 1].level == level) --first;
        }
        std::vector<double> ratios(next - first);
        parallel_tasks(static_cast<int64_t>(ratios.size()), [&](int64_t i) {
            ratios[static_cast<size_t>(i)] = ratio(next - 1 - static_cast<size_t>(i));
        });
        // Level by level, finest first: a level whose bands all render within 1 % is weighed and
        // stops the weighing (the bands measured past it keep their norms).
        for (size_t i = 0; i < ratios.size();) {
            const int level = layout_.bands[next - 1 - i].level;
            bool damped = false;
            for (; i < ratios.size() && layout_.bands[next - 1 - i].level == level; ++i) {
                damped = damped || std::abs(ratios[i] - 1) > 0.01;
                if (!std::isnan(ratios[i]))
                    layout_.bands[next - 1 - i].norm *= std::pow(ratios[i], kRenderedWeight);
            }
            if (!damped) return;
        }
        next = first;
    }
}

namespace {

struct DomainCache {
    struct Entry {
        int probes;
        BandNorms weigh;
        std::vector<float> norms;
        std::shared_ptr<const CodingDomain> domain;
    };
    // At most 4 domains, of at most 2 M coefficients in all (a mesh domain takes about 150
    // bytes a coefficient); a larger domain is built and returned, not kept.
    static constexpr size_t kCapacity = 4;
    static constexpr int64_t kMaxSize = int64_t{1} << 21;
    std::mutex mutex;
    std::vector<Entry> entries;  // most recently used last
};

DomainCache& domain_cache() {
    static DomainCache* cache = new DomainCache;  // never destroyed: callers may outlive statics
    return *cache;
}

}  // namespace

std::shared_ptr<const CodingDomain> shared_domain(const DomainShape& shape, int probes,
                                                  std::span<const float> norms, BandNorms weigh) {
    DomainCache& cache = domain_cache();
    const auto same = [&](const DomainCache::Entry& e) {
        return e.probes == probes && e.weigh == weigh && std::ranges::equal(e.norms, norms) &&
               e.domain->shape() == shape;
    };
    {
        const std::lock_guard lock(cache.mutex);
        const auto hit = std::ranges::find_if(cache.entries, same);
        if (hit != cache.entries.end()) {
            std::rotate(hit, hit + 1, cache.entries.end());
            return cache.entries.back().domain;
        }
    }
    // Built outside the lock: other threads may use the cache meanwhile (two threads asking for
    // one new domain both build it; the second one found is kept).
    auto domain = std::make_shared<const CodingDomain>(shape, probes, norms, weigh);
    if (domain->size() > DomainCache::kMaxSize) return domain;
    const std::lock_guard lock(cache.mutex);
    std::erase_if(cache.entries, same);
    const auto held = [&] {
        int64_t size = domain->size();
        for (const auto& e : cache.entries) size += e.domain->size();
        return size;
    };
    while (!cache.entries.empty() &&
           (cache.entries.size() == DomainCache::kCapacity || held() > DomainCache::kMaxSize)) {
        cache.entries.erase(cache.entries.begin());
    }
    cache.entries.push_back({probes, weigh, {norms.begin(), norms.end()}, domain});
    return domain;
}

void clear_domain_cache() {
    DomainCache& cache = domain_cache();
    const std::lock_guard lock(cache.mutex);
    cache.entries.clear();
}

float CodingDomain::step(int channel, int band, float base_step) const {
    return base_step * shape_.channel_factors[channel] /
           static_cast<float>(layout_.bands[band].norm);
}

std::vector<float> CodingDomain::band_steps(int channel, float base_step) const {
    std::vector<float> steps(layout_.bands.size());
    for (size_t b = 0; b < steps.size(); ++b)
        steps[b] = step(channel, static_cast<int>(b), base_step);
    return steps;
}

Planes CodingDomain::zeros() const {
    return Planes(shape_.channels, std::vector<float>(size(), 0.0f));
}

GridTransformOptions CodingDomain::grid_options() const {
    return {.wavelet = wavelet_of(shape_.transform), .levels = shape_.levels};
}

bool CodingDomain::at_rest(std::span<const Vec2> vertices) const {
    return std::ranges::equal(vertices, shape_.mesh.vertices);
}

// Whether the rest plan is the one a projection would make: the mesh's domain is the image's
// pixel rectangle (project.h), not a rectangle scaled onto it.
bool CodingDomain::rest_plan_is_pixels() const {
    return rest_plan_ && shape_.mesh.width == shape_.width && shape_.mesh.height == shape_.height;
}

void CodingDomain::check_image(const Image& image) const {
    if (image.width != shape_.width || image.height != shape_.height ||
        image.channels() != shape_.channels) {
        throw Error(str("image is ", image.width, "x", image.height, " with ", image.channels(),
                        " channels; the coding domain is ", shape_.width, "x", shape_.height,
                        " with ", shape_.channels));
    }
}

void CodingDomain::sample_into(const Image& image, std::span<const Vec2> vertices, Planes& out,
                               Sampling sampling, const ProjectOptions& projection) const {
    check_image(image);
    out.resize(shape_.channels);
    if (!hierarchy_) {
        for (int c = 0; c < shape_.channels; ++c) out[c] = image.planes[c];
        return;
    }
    for (auto& plane : out) plane.resize(size());
    if (pixel_of_sample_.empty()) {
        if (shape_.canvas && vertices.empty()) throw Error("a canvas needs vertex positions");
        const std::span<const Vec2> at =
            vertices.empty() ? std::span<const Vec2>(shape_.mesh.vertices) : vertices;
        if (sampling == Sampling::fit) {
            ProjectOptions po = projection;
            if (at_rest(at) && rest_plan_is_pixels()) po.plan = &*rest_plan_;
            out = project_image(image, *hierarchy_, at, po).planes;
        } else {
            sample_image_into(image, *hierarchy_, at, spans(out));
        }
        return;
    }
    for (int c = 0; c < shape_.channels; ++c) {
        for (size_t i = 0; i < pixel_of_sample_.size(); ++i)
            out[c][i] = image.planes[c][pixel_of_sample_[i]];
    }
}

std::optional<RenderPlan> CodingDomain::plan_for(std::span<const Vec2> vertices) const {
    if (!hierarchy_ || !pixel_of_sample_.empty()) return std::nullopt;
    // At rest (a still image, a static video group, a tracked mesh that has not moved) the plan
    // made with the domain serves: the same plan plan_render would make again.
    if (shape_.canvas) {
        if (vertices.empty()) throw Error("a canvas needs vertex positions");
        return plan_render(*hierarchy_, vertices, shape_.width, shape_.height, shape_.width,
                           shape_.height);
    }
    if (vertices.empty() || at_rest(vertices)) return std::nullopt;
    return plan_render(*hierarchy_, vertices, shape_.mesh.width, shape_.mesh.height, shape_.width,
                       shape_.height);
}

void CodingDomain::to_image(const Planes& samples, std::span<const Vec2> vertices, Image& out,
                            const RenderPlan* plan) const {
    out = make_image(shape_.width, shape_.height, shape_.channels, shape_.format);
    if (!hierarchy_) {
        out.planes = samples;
        return;
    }
    if (pixel_of_sample_.empty()) {
        const std::vector<std::span<const float>> in(samples.begin(), samples.end());
        if (plan) {
            render_into(*plan, in, out);
            return;
        }
        const std::optional<RenderPlan> own = plan_for(vertices);
        render_into(own ? *own : *rest_plan_, in, out);
        return;
    }
    for (int c = 0; c < out.channels(); ++c) {
        for (int32_t i : written_samples_) out.planes[c][pixel_of_sample_[i]] = samples[c][i];
    }
}

// The 9/7 on the lattice: each plane's samples put in lattice order and transformed there (the
// coefficients stay in the lattice's Mallat layout), or back.
void CodingDomain::lattice_transform(Planes& x, bool forward) const {
    const GridTransformOptions options{.wavelet = GridWavelet::cdf97, .levels = shape_.levels};
    // A plane a thread.
    parallel_tasks(static_cast<int64_t>(x.size()), [&](int64_t c) {
        std::vector<float>& plane = x[static_cast<size_t>(c)];
        std::vector<float> lattice(lattice_.size());
        if (forward) {
            for (size_t i = 0; i < lattice_.size(); ++i) lattice[lattice_[i]] = plane[i];
            grid_forward(lattice, lattice_width_, lattice_height_, options);
        } else {
            grid_inverse(plane, lattice_width_, lattice_height_, options);
            for (size_t i = 0; i < lattice_.size(); ++i) lattice[i] = plane[lattice_[i]];
        }
        plane.swap(lattice);
    });
}

void CodingDomain::transform(Planes& x) const {
    if (shape_.colour == TwiColour::ycbcr) ycbcr_forward(x[0], x[1], x[2]);
    if (!lattice_.empty()) {
        lattice_transform(x, true);
    } else if (hierarchy_) {
        forward_transform(*hierarchy_, spans(x));
    } else {
        parallel_tasks(static_cast<int64_t>(x.size()), [&](int64_t c) {  // a plane a thread
            grid_forward(x[static_cast<size_t>(c)], shape_.width, shape_.height, grid_options());
        });
    }
}

void CodingDomain::analyze(const Image& image, std::span<const Vec2> vertices, Planes& out,
                           Sampling sampling, const ProjectOptions& projection) const {
    sample_into(image, vertices, out, sampling, projection);
    transform(out);
}

void CodingDomain::analyze_fits(const Image& image, std::span<const double> smoothness,
                                const ProjectOptions& projection,
                                const std::function<void(size_t, Planes&)>& take) const {
    check_image(image);
    if (!hierarchy_ || !pixel_of_sample_.empty()) {  // nothing to project
        for (size_t k = 0; k < smoothness.size(); ++k) {
            Planes x;
            analyze(image, {}, x);
            take(k, x);
        }
        return;
    }
    ProjectOptions po = projection;
    if (rest_plan_is_pixels()) po.plan = &*rest_plan_;
    project_image_each(image, *hierarchy_, shape_.mesh.vertices, smoothness, po,
                       [&](size_t k, const Projection& p) {
                           Planes x = p.planes;
                           transform(x);
                           take(k, x);
                       });
}

Planes CodingDomain::analyze(const Image& image, Sampling sampling,
                             const ProjectOptions& projection) const {
    Planes x;
    analyze(image, {}, x, sampling, projection);
    return x;
}

void CodingDomain::synthesis(Planes& x) const {
    if (!lattice_.empty()) {
        lattice_transform(x, false);
    } else if (hierarchy_) {
        inverse_transform(*hierarchy_, spans(x));
    } else {
        parallel_tasks(static_cast<int64_t>(x.size()), [&](int64_t c) {
            grid_inverse(x[static_cast<size_t>(c)], shape_.width, shape_.height, grid_options());
        });
    }
}

void CodingDomain::inverse(Planes& x) const {
    synthesis(x);
    if (shape_.colour == TwiColour::ycbcr) ycbcr_inverse(x[0], x[1], x[2]);
}

void CodingDomain::synthesize(Planes x, std::span<const Vec2> vertices, Image& out,
                              const RenderPlan* plan) const {
    inverse(x);
    if (!hierarchy_) {  // a fixed grid: the samples are the pixels, handed over as they are
        out.width = shape_.width;
        out.height = shape_.height;
        out.format = shape_.format;
        out.planes = std::move(x);
        return;
    }
    to_image(x, vertices, out, plan);
}

Image CodingDomain::synthesize(Planes coefficients) const {
    Image out;
    synthesize(std::move(coefficients), {}, out);
    return out;
}

IntPlanes CodingDomain::samples_int(const Image& image) const {
    if (!lattice_.empty()) throw Error("lossless coding takes the lifted mesh wavelet");
    Planes s;
    sample_into(image, {}, s);
    const float top = max_value(shape_.format);
    IntPlanes out(s.size(), std::vector<int32_t>(size()));
    for (size_t c = 0; c < s.size(); ++c) {
        for (int32_t i = 0; i < size(); ++i) {
            const float v = std::clamp(s[c][i], 0.0f, 1.0f) * top;
            out[c][i] = static_cast<int32_t>(std::lround(v));
        }
    }
    return out;
}

IntPlanes CodingDomain::analyze_int(const Image& image) const {
    IntPlanes x = samples_int(image);
    if (shape_.colour == TwiColour::ycocg_r) ycocg_r_forward(x[0], x[1], x[2]);
    if (hierarchy_) {
        forward_transform_int(*hierarchy_, spans(x));
    } else {
        for (auto& plane : x) grid_forward_int53(plane, shape_.width, shape_.height, shape_.levels);
    }
    return x;
}

IntPlanes CodingDomain::inverse_int(IntPlanes x) const {
    if (!lattice_.empty()) throw Error("lossless coding takes the lifted mesh wavelet");
    // The integer inverse grows values by less than 16x a level (at most 6.25x for the grid 5/3,
    // 10.75x for the mesh), so int32 is safe while largest * 16^levels < 2^30. Coefficients from
    // a damaged stream can exceed that: they take the int64 inverse, or are refused past 2^62.
    uint32_t largest = 0;
    for (const auto& plane : x) {
        for (int32_t v : plane)
            largest = std::max(largest, static_cast<uint32_t>(v < 0 ? -int64_t{v} : v));
    }
    const int levels = hierarchy_ ? hierarchy_->finest() : shape_.levels;
    const int bits = std::bit_width(largest) + 4 * levels;
    const int W = shape_.width, H = shape_.height;
    if (bits <= 30) {
        if (hierarchy_) {
            inverse_transform_int(*hierarchy_, spans(x));
        } else {
            for (auto& plane : x) grid_inverse_int53(plane, W, H, shape_.levels);
        }
    } else if (bits <= 62) {
        std::vector<std::vector<int64_t>> wide(x.size());
        for (size_t c = 0; c < x.size(); ++c) wide[c].assign(x[c].begin(), x[c].end());
        if (hierarchy_) {
            inverse_transform_int(*hierarchy_, spans(wide));
        } else {
            for (auto& plane : wide) grid_inverse_int53(plane, W, H, shape_.levels);
        }
        constexpr int64_t kLimit = int64_t{1} << 30;  // no sample of a valid file comes near it
        for (size_t c = 0; c < x.size(); ++c) {
            for (size_t i = 0; i < x[c].size(); ++i) {
                x[c][i] = static_cast<int32_t>(std::clamp(wide[c][i], -kLimit, kLimit));
            }
        }
    } else {
        throw Error("lossless coefficients out of range (a corrupted stream)");
    }
    if (shape_.colour == TwiColour::ycocg_r) ycocg_r_inverse(x[0], x[1], x[2]);
    return x;
}

Image CodingDomain::synthesize_int(IntPlanes coefficients) const {
    const IntPlanes x = inverse_int(std::move(coefficients));
    const float scale = 1.0f / max_value(shape_.format);
    Planes s(x.size(), std::vector<float>(size()));
    for (size_t c = 0; c < x.size(); ++c) {
        for (int32_t i = 0; i < size(); ++i) s[c][i] = static_cast<float>(x[c][i]) * scale;
    }
    Image out;
    to_image(s, {}, out);
    return out;
}

}  // namespace tesswave
