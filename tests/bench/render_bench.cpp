// Sampling and rendering a 1280x720 RGB image at density 2 beside OpenCV's cv::remap (bilinear)
// on the same image size. Items are image pixels, so every figure is per frame of 1280x720. One
// thread, except the rows of remap and of sampling with a "threads" argument (wall time).
#include <benchmark/benchmark.h>

#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/math/grid_mesh.h"
#include "core/math/project.h"
#include "core/math/render.h"
#include "core/math/sampling.h"
#include "core/math/voronoi.h"
#include "row_threads.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"

namespace tesswave {
namespace {

constexpr int kWidth = 1280, kHeight = 720;

// A Voronoi mesh whose level 6 is as close as the site count allows to 2 samples per pixel.
Mesh density_two_mesh() {
    Mesh best;
    double best_gap = INFINITY;
    for (int sites = 200; sites <= 400; sites += 4) {
        Mesh mesh =
            voronoi_mesh(kWidth, kHeight, {.sites = sites, .seed = 1, .lloyd_iterations = 2});
        const double per_pixel = level_counts(mesh, 6)[6].vertices / double(kWidth * kHeight);
        if (std::abs(per_pixel - 2.0) < best_gap) best = mesh, best_gap = std::abs(per_pixel - 2.0);
    }
    return best;
}

struct Setup {
    Setup() { cv::setNumThreads(1); }  // single thread, like every other figure here
    Image image = samples::scene_image(kWidth, kHeight);
    Mesh mesh = density_two_mesh();
    Hierarchy h = build_hierarchy(mesh, {.levels = 6});
    std::vector<Vec2> positions = refine_positions(h, mesh.vertices, 6);
    std::vector<std::vector<float>> samples = sample_image(image, h, mesh.vertices);
    RenderPlan plan = plan_render(h, mesh.vertices, kWidth, kHeight, kWidth, kHeight);
};

const Setup& setup() {
    static const Setup s;
    return s;
}

void finish(benchmark::State& state) {
    state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
    state.counters["samples_per_pixel"] =
        static_cast<double>(setup().samples[0].size()) / (kWidth * kHeight);
}

// Rendering with a plan made once (the plan is to the mesh what cv::remap's maps are to a warp).
void BM_render_apply(benchmark::State& state) {
    const Setup& s = setup();
    const std::vector<std::span<const float>> planes(s.samples.begin(), s.samples.end());
    Image out = make_image(kWidth, kHeight, 3, SampleFormat::f32);  // reused, as remap's dst
    for (auto _ : state) {
        render_into(s.plan, planes, out);
        benchmark::DoNotOptimize(out.planes[0].data());
    }
    finish(state);
}

// Making the plan: rasterizing the T1 quads and inverting the bilinear map at every pixel.
// state.range(0): threads.
void BM_render_plan(benchmark::State& state) {
    const Setup& s = setup();
    const RowThreads row(state.range(0));
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            plan_render(s.h, s.mesh.vertices, kWidth, kHeight, kWidth, kHeight));
    }
    finish(state);
}

// Sampling at precomputed positions (the positions are to the mesh what maps are to remap).
void BM_sample_apply(benchmark::State& state) {
    const Setup& s = setup();
    for (auto _ : state) benchmark::DoNotOptimize(sample_bilinear(s.image, s.positions));
    finish(state);
}

// Sampling including the refinement of the positions and the prefilter decision.
void BM_sample_full(benchmark::State& state) {
    const Setup& s = setup();
    const RowThreads row(state.range(0));
    auto out = s.samples;  // reused, as remap's dst
    const std::vector<std::span<float>> spans(out.begin(), out.end());
    for (auto _ : state) {
        sample_image_into(s.image, s.h, s.mesh.vertices, spans);
        benchmark::DoNotOptimize(out[0].data());
    }
    finish(state);
}

// Density 1, the still codec's default grid until 2026-12-07 (not aligned with the pixels): point
// sampling against the projection (project.h) with its default options, on the same mesh.
struct DensityOne {
    DefaultGrid g = default_grid(kWidth, kHeight, 1.0);
    Mesh mesh = grid_mesh(kWidth, kHeight, g.cols, g.rows);
    Hierarchy h = build_hierarchy(mesh, {.levels = g.levels});
};

const DensityOne& density_one() {
    static const DensityOne d;
    return d;
}

void BM_sample_full_density1(benchmark::State& state) {
    const DensityOne& d = density_one();
    const Image& image = setup().image;  // made before the timing, as every setup here
    const RowThreads row(state.range(0));
    for (auto _ : state) benchmark::DoNotOptimize(sample_image(image, d.h, d.mesh.vertices));
    state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
}

// Rendering at density 1 (as many samples as pixels, as remap reads), the plan made once.
void BM_render_apply_density1(benchmark::State& state) {
    const DensityOne& d = density_one();
    static const std::vector<std::vector<float>> samples =
        sample_image(setup().image, d.h, d.mesh.vertices);
    static const RenderPlan plan =
        plan_render(d.h, d.mesh.vertices, kWidth, kHeight, kWidth, kHeight);
    const std::vector<std::span<const float>> planes(samples.begin(), samples.end());
    Image out = make_image(kWidth, kHeight, 3, SampleFormat::f32);
    for (auto _ : state) {
        render_into(plan, planes, out);
        benchmark::DoNotOptimize(out.planes[0].data());
    }
    state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
    state.counters["samples_per_pixel"] =
        static_cast<double>(samples[0].size()) / (kWidth * kHeight);
}

void BM_project_density1(benchmark::State& state) {
    const DensityOne& d = density_one();
    const Image& image = setup().image;
    int iterations = 0;
    for (auto _ : state) {
        const Projection p = project_image(image, d.h, d.mesh.vertices);
        iterations = p.iterations;
        benchmark::DoNotOptimize(p.planes[0].data());
    }
    state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
    state.counters["cg_iterations"] = iterations;
}

// The peer: cv::remap, bilinear, 3-channel float, with a smooth warp map made once.
void BM_cv_remap(benchmark::State& state) {
    const Setup& s = setup();
    cv::Mat src(kHeight, kWidth, CV_32FC3), dst;
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            for (int c = 0; c < 3; ++c) src.at<cv::Vec3f>(y, x)[c] = s.image.at(c, x, y);
        }
    }
    cv::Mat map_x(kHeight, kWidth, CV_32FC1), map_y(kHeight, kWidth, CV_32FC1);
    for (int y = 0; y < kHeight; ++y) {
        for (int x = 0; x < kWidth; ++x) {
            map_x.at<float>(y, x) = static_cast<float>(x + 3 * std::sin(y / 40.0));
            map_y.at<float>(y, x) = static_cast<float>(y + 3 * std::cos(x / 50.0));
        }
    }
    cv::setNumThreads(static_cast<int>(state.range(0)));
    for (auto _ : state) {
        cv::remap(src, dst, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        benchmark::DoNotOptimize(dst.data);
    }
    cv::setNumThreads(1);
    state.SetItemsProcessed(state.iterations() * int64_t{kWidth} * kHeight);
}

}  // namespace

BENCHMARK(BM_cv_remap)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_render_apply)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_render_apply_density1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_render_plan)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_sample_apply)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_sample_full)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_sample_full_density1)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_project_density1)->Unit(benchmark::kMillisecond);

}  // namespace tesswave
