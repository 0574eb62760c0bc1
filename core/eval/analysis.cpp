#include "core/eval/analysis.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/math/error.h"
#include "core/math/fixed_grid.h"
#include "core/math/hierarchy.h"
#include "core/math/lifting.h"
#include "core/math/metrics.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

using Planes = std::vector<std::vector<float>>;

std::vector<std::span<float>> spans(Planes& planes) { return {planes.begin(), planes.end()}; }
std::vector<std::span<const float>> const_spans(const Planes& planes) {
    return {planes.begin(), planes.end()};
}

AnalysisRow measure(const Image& original, const Image& test, std::string method, double keep,
                    int64_t kept, int64_t total) {
    const QualityOptions q{.bit_depth = original.format == SampleFormat::u16 ? 16 : 8};
    return {std::move(method),          keep, kept, total, psnr(original, test, q).all,
            ssim(original, test, q).all};
}

// Fixed-grid wavelet of the original pixels, k % of its detail coefficients kept.
class GridExperiment {
  public:
    GridExperiment(const Image& image, GridWavelet wavelet, int levels)
        : image_(image), options_{.wavelet = wavelet, .levels = levels} {
        coefficients_ = image.planes;
        for (auto& plane : coefficients_) grid_forward(plane, image.width, image.height, options_);
        for (const GridBand& band : grid_bands(image.width, image.height, levels)) {
            if (band.type == 0) continue;  // the LL band is always kept
            for (int y = band.y0; y < band.y0 + band.height; ++y) {
                for (int x = band.x0; x < band.x0 + band.width; ++x) {
                    details_.push_back(y * image.width + x);
                }
            }
        }
    }
    int64_t details() const { return static_cast<int64_t>(details_.size()); }
    Image reconstruct(int64_t count) const {
        Planes planes = coefficients_;
        keep_largest(spans(planes), std::span<const int32_t>(details_), count);
        Image out = image_;
        for (size_t c = 0; c < planes.size(); ++c) {
            grid_inverse(planes[c], image_.width, image_.height, options_);
            out.planes[c] = std::move(planes[c]);
        }
        return out;
    }

  private:
    const Image& image_;
    GridTransformOptions options_;
    Planes coefficients_;
    std::vector<int32_t> details_;
};

}  // namespace

AnalysisResult analyze_image(const Image& image, const Mesh& mesh, const AnalysisOptions& options) {
    if (mesh.width != image.width || mesh.height != image.height) {
        throw Error(str("mesh domain ", mesh.width, "x", mesh.height,
                        " does not match the image's ", image.width, "x", image.height,
                        " pixels (scale the mesh, e.g. with --fit-mesh)"));
    }
    for (double k : options.keep) keep_count(1, k);  // validates the percentages
    auto progress = [&](double done, const char* stage) {
        if (options.progress) options.progress(done, stage);
    };
    AnalysisResult result;
    result.levels = options.levels;
    progress(0.0, "refining");
    const Hierarchy h = build_hierarchy(mesh, {.levels = options.levels, .finest_topology = false});
    const int32_t n = h.num_samples(options.levels), n0 = h.num_samples(0);
    result.samples = n;
    result.samples_per_pixel = static_cast<double>(n) / (int64_t{image.width} * image.height);
    progress(0.05, "sampling");
    const Planes point = sample_image(image, h, mesh.vertices);
    const RenderPlan plan =
        plan_render(h, mesh.vertices, mesh.width, mesh.height, image.width, image.height);
    const int64_t total = n - n0;
    Image rendered = render(plan, const_spans(point), image.format);
    result.rows.push_back(measure(image, rendered, "resample point", 100, total, total));
    ProjectOptions po = options.projection;
    const std::vector<std::span<const float>> anchor = const_spans(point);
    if (po.anchor.empty()) po.anchor = anchor;
    Projection fit = project_image(image, h, mesh.vertices, po);
    result.projection_iterations = fit.iterations;
    Image fitted = render(plan, const_spans(fit.planes), image.format);
    result.rows.push_back(measure(image, fitted, "resample fit", 100, total, total));
    const bool use_fit = options.sampling == Sampling::fit;
    Planes samples = use_fit ? std::move(fit.planes) : point;
    result.resampled = use_fit ? std::move(fitted) : std::move(rendered);

    progress(0.15, "transforming");
    Planes coefficients = samples;
    forward_transform(h, spans(coefficients));
    Planes picture = coefficients;
    for (auto& plane : picture) {
        for (int32_t i = n0; i < n; ++i) plane[i] = 0.5f + 10.0f * plane[i];
    }
    result.coefficients = render(plan, const_spans(picture), SampleFormat::u8);

    progress(0.2, "band norms");
    const std::vector<float> weights = band_weights(mesh_bands(h, mesh.width * mesh.height), n);
    for (size_t k = 0; k < options.keep.size(); ++k) {
        progress(0.25 + 0.45 * k / options.keep.size(), "mesh reconstructions");
        const int64_t count = keep_count(total, options.keep[k]);
        for (SelectionRule rule : {SelectionRule::paper, SelectionRule::l2}) {
            Planes kept = coefficients;
            keep_largest(spans(kept), n0, count,
                         rule == SelectionRule::l2 ? std::span<const float>(weights)
                                                   : std::span<const float>());
            inverse_transform(h, spans(kept));
            Image out = render(plan, const_spans(kept), image.format);
            result.rows.push_back(measure(image, out,
                                          rule == SelectionRule::paper ? "mesh paper" : "mesh l2",
                                          options.keep[k], count, total));
            if (rule == options.picture_rule) result.mesh_images.push_back(std::move(out));
        }
    }
    progress(0.7, "fixed-grid wavelets");
    const int grid_levels = std::clamp(
        static_cast<int>(std::floor(std::log2(std::min(image.width, image.height) / 8.0))), 1,
        options.grid_levels);
    // Two comparisons per fixed-grid wavelet: the same percentage of its own (fewer) detail
    // coefficients, and the same number of coefficients as the mesh kept ("=n" rows), which is
    // the like-for-like one when the mesh has more samples than the image has pixels.
    std::vector<int64_t> mesh_counts;
    for (double percent : options.keep) mesh_counts.push_back(keep_count(total, percent));
    for (auto [wavelet, name] :
         {std::pair{GridWavelet::cdf53, "grid 5/3"}, std::pair{GridWavelet::cdf97, "grid 9/7"}}) {
        const GridExperiment grid(image, wavelet, grid_levels);
        for (double percent : options.keep) {
            const int64_t count = keep_count(grid.details(), percent);
            Image out = grid.reconstruct(count);
            result.rows.push_back(measure(image, out, name, percent, count, grid.details()));
            (wavelet == GridWavelet::cdf53 ? result.grid53_images : result.grid97_images)
                .push_back(std::move(out));
        }
        for (size_t k = 0; k < options.keep.size(); ++k) {
            const int64_t count = std::min(mesh_counts[k], grid.details());
            result.rows.push_back(measure(image, grid.reconstruct(count), str(name, " =n"),
                                          100.0 * count / grid.details(), count, grid.details()));
        }
    }
    progress(1.0, "done");
    return result;
}

}  // namespace tesswave
