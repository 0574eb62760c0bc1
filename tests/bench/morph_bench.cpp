// Morph speed on procedural pairs (samples::deformed_pair: B is A under a known smooth
// deformation), single thread (cv::setNumThreads(1); Ceres runs on one thread already). Every
// figure is read off the CPU column: the rates (frames_per_s) are over the thread's CPU time, and
// CPU time, unlike wall time, does not grow when other processes share the cores.
//
// 1. One 1280x720 RGB frame at t = 0.5 (`--benchmark_filter=Morph_frame|Morph_classic`).
//    - Morph_frame/<schedule>: Morph::frame(0.5) of a Morph made once, outside the loop, from a
//      53x30 grid mesh on A fitted with Ceres to the pair's 2000 points (fitted_pair), default
//      MorphOptions (J for density 2, residual on). One call holds the band blend of the
//      coefficients, the inverse transform, the render plan on the in-between mesh, rendering,
//      and the residual warp (two renders of the sample positions, two bilinear warps, blend).
//      _preview: frame(0.5, {.preview = true}), levels J - 2, no residual.
//    - Morph_classic: the classic warp and cross-dissolve of the same size, in OpenCV: two
//      cv::remap (bilinear, CV_32FC3, maps made once) and cv::addWeighted. The maps are the
//      piecewise-affine warp of the same fitted mesh (faces split into triangles) at the
//      linearly interpolated vertices, which is the classic mesh morph.
//    - Morph_classic_with_maps: the same with the maps made in the loop (rasterizing the
//      triangles of the in-between mesh and evaluating each triangle's two affine maps per
//      pixel), the counterpart of our render plan; Morph_classic_maps: the maps alone.
//    Counters: frames_per_s; x_classic, the frame's CPU time over the classic's (maps made once),
//    the latter timed in the setup (median of 21 calls, thread CPU clock; a plain ratio, which
//    Google Benchmark prints with an "s" as it does every inverted rate); PSNR against the true
//    in-between frame (samples::moved(A, 0.5)), a check that both sides do the same job.
// 2. Automatic correspondences and the fit for a 640x480 pair (`--benchmark_filter=Morph_auto`):
//    morph::automatic_pair (auto_match, then a 27x20 grid (24 px cells) fitted with Ceres), and
//    the two parts alone. Counters: matches, and the fitted vertices' RMS distance (px) from
//    where the known deformation puts them.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <span>
#include <vector>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/metrics.h"
#include "morph/auto_match.h"
#include "morph/inbetween.h"
#include "morph/morph.h"
#include "morph/pair.h"
#include "row_threads.h"
#include "samples/sample_pair.h"

namespace tesswave::morph {
namespace {

constexpr int kWidth = 1280, kHeight = 720;
constexpr int kCols = 53, kRows = 30;
constexpr int kPoints = 2000;
constexpr double kT = 0.5;
constexpr int kAutoWidth = 640, kAutoHeight = 480;

double thread_seconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

cv::Mat interleaved(const Image& image) {
    cv::Mat m(image.height, image.width, CV_32FC3);
    for (int y = 0; y < image.height; ++y) {
        auto* row = m.ptr<cv::Vec3f>(y);
        for (int x = 0; x < image.width; ++x) {
            for (int c = 0; c < 3; ++c) row[x][c] = image.at(c, x, y);
        }
    }
    return m;
}

Image planar(const cv::Mat& m) {
    Image out = make_image(m.cols, m.rows, 3, SampleFormat::f32);
    for (int y = 0; y < m.rows; ++y) {
        const auto* row = m.ptr<cv::Vec3f>(y);
        for (int x = 0; x < m.cols; ++x) {
            for (int c = 0; c < 3; ++c) out.at(c, x, y) = row[x][c];
        }
    }
    return out;
}

// The classic mesh warp's maps: for every output pixel centre q inside a triangle (p0, p1, p2) of
// the mesh at t (vertices (1 - t) a + t b, faces fanned from their first corner), the point with
// the same barycentric coordinates in A's and in B's triangle, in OpenCV's pixel indices (centre
// of pixel i at i). Each triangle's two affine maps are set up once and evaluated per pixel.
struct ClassicMaps {
    cv::Mat ax, ay, bx, by;
};

void classic_maps(const Mesh& mesh, std::span<const Vec2> va, std::span<const Vec2> vb, double t,
                  ClassicMaps& m) {
    const int W = kWidth, H = kHeight;
    for (cv::Mat* map : {&m.ax, &m.ay, &m.bx, &m.by}) map->create(H, W, CV_32FC1);
    const auto at = [&](int32_t i) { return (1 - t) * va[i] + t * vb[i]; };
    for (int f = 0; f < mesh.num_faces(); ++f) {
        const std::span<const int32_t> corners = mesh.face(f);
        for (size_t k = 1; k + 1 < corners.size(); ++k) {
            const int32_t i0 = corners[0], i1 = corners[k], i2 = corners[k + 1];
            const Vec2 p0 = at(i0), e1 = at(i1) - p0, e2 = at(i2) - p0;
            const double det = cross(e1, e2);
            if (std::abs(det) < 1e-12) continue;
            // q -> barycentric (l1, l2) = (cross(q - p0, e2), cross(e1, q - p0)) / det, and the
            // source point s0 + l1 (s1 - s0) + l2 (s2 - s0), folded into one affine map each.
            const Vec2 a0 = va[i0], a1 = va[i1] - a0, a2 = va[i2] - a0;
            const Vec2 b0 = vb[i0], b1 = vb[i1] - b0, b2 = vb[i2] - b0;
            const double l1x = e2.y / det, l1y = -e2.x / det;  // dl1/dx, dl1/dy
            const double l2x = -e1.y / det, l2y = e1.x / det;  // dl2/dx, dl2/dy
            const double eps = 1e-9;
            const double xmin = std::min({p0.x, p0.x + e1.x, p0.x + e2.x});
            const double xmax = std::max({p0.x, p0.x + e1.x, p0.x + e2.x});
            const double ymin = std::min({p0.y, p0.y + e1.y, p0.y + e2.y});
            const double ymax = std::max({p0.y, p0.y + e1.y, p0.y + e2.y});
            const int x0 = std::max(0, static_cast<int>(std::ceil(xmin - 0.5)));
            const int x1 = std::min(W - 1, static_cast<int>(std::floor(xmax - 0.5)));
            const int y0 = std::max(0, static_cast<int>(std::ceil(ymin - 0.5)));
            const int y1 = std::min(H - 1, static_cast<int>(std::floor(ymax - 0.5)));
            for (int y = y0; y <= y1; ++y) {
                float* ax = m.ax.ptr<float>(y);
                float* ay = m.ay.ptr<float>(y);
                float* bx = m.bx.ptr<float>(y);
                float* by = m.by.ptr<float>(y);
                const double dy = y + 0.5 - p0.y;
                for (int x = x0; x <= x1; ++x) {
                    const double dx = x + 0.5 - p0.x;
                    const double l1 = l1x * dx + l1y * dy, l2 = l2x * dx + l2y * dy;
                    if (l1 < -eps || l2 < -eps || l1 + l2 > 1 + eps) continue;
                    ax[x] = static_cast<float>(a0.x + l1 * a1.x + l2 * a2.x - 0.5);
                    ay[x] = static_cast<float>(a0.y + l1 * a1.y + l2 * a2.y - 0.5);
                    bx[x] = static_cast<float>(b0.x + l1 * b1.x + l2 * b2.x - 0.5);
                    by[x] = static_cast<float>(b0.y + l1 * b1.y + l2 * b2.y - 0.5);
                }
            }
        }
    }
}

// Warp both images to the in-between mesh and cross-dissolve; `out` and the warped images are
// reused from call to call, as remap's destinations are in render_bench.
struct Classic {
    cv::Mat a, b, wa, wb, out;
    void frame(const ClassicMaps& m, double t) {
        cv::remap(a, wa, m.ax, m.ay, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        cv::remap(b, wb, m.bx, m.by, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        cv::addWeighted(wa, 1 - t, wb, t, 0, out);
    }
};

// Set before any other member is made, so that OpenCV runs on one thread from the start.
bool single_thread() {
    cv::setNumThreads(1);
    return true;
}

struct FrameSetup {
    FrameSetup() { prepare(); }
    bool one_thread = single_thread();
    samples::SamplePair pair = samples::deformed_pair(kWidth, kHeight, kPoints);
    PairMeshes meshes = fitted_pair(grid_mesh(kWidth, kHeight, kCols, kRows),
                                    {pair.points_a, pair.points_b}, kWidth, kHeight);
    Image truth = samples::moved(pair.a, pair.deformation, kT);
    ClassicMaps maps;
    Classic classic;
    double classic_seconds = 0;  // one classic frame (maps made once), thread CPU time
    double classic_psnr = 0;

    void prepare() {
        // Every pixel centre must fall in some triangle: start from NaN and count what is left.
        for (cv::Mat* map : {&maps.ax, &maps.ay, &maps.bx, &maps.by}) {
            map->create(kHeight, kWidth, CV_32FC1);
            map->setTo(NAN);
        }
        classic_maps(meshes.a, meshes.a.vertices, meshes.b.vertices, kT, maps);
        for (const cv::Mat* map : {&maps.ax, &maps.ay, &maps.bx, &maps.by}) {
            if (cv::countNonZero(*map == *map) != kWidth * kHeight) {
                throw Error("morph_bench: the classic maps miss pixels");
            }
        }
        classic.a = interleaved(pair.a);
        classic.b = interleaved(pair.b);
        std::vector<double> times;
        for (int i = 0; i < 21; ++i) {
            const double start = thread_seconds();
            classic.frame(maps, kT);
            times.push_back(thread_seconds() - start);
        }
        std::nth_element(times.begin(), times.begin() + 10, times.end());
        classic_seconds = times[10];
        classic_psnr = psnr(truth, planar(classic.out)).all;
    }
};

FrameSetup& frame_setup() {
    static FrameSetup s;
    return s;
}

const Morph& prepared_morph(ScheduleKind kind) {
    const FrameSetup& s = frame_setup();
    const auto make = [&](ScheduleKind k) {
        return Morph(s.pair.a, s.pair.b, s.meshes.a, s.meshes.b, {.schedule = {.kind = k}});
    };
    if (kind == ScheduleKind::sharp) {
        static const Morph sharp = make(ScheduleKind::sharp);
        return sharp;
    }
    if (kind == ScheduleKind::aware) {
        static const Morph aware = make(ScheduleKind::aware);
        return aware;
    }
    static const Morph linear = make(ScheduleKind::linear);
    return linear;
}

void frames_counter(benchmark::State& state) {
    state.counters["frames_per_s"] =
        benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

// state.range(0): threads (parallel.h); 1 is the single-core figure.
void BM_Morph_frame(benchmark::State& state, ScheduleKind kind, bool preview) {
    const FrameSetup& s = frame_setup();
    const Morph& morph = prepared_morph(kind);
    const RowThreads row(state.range(0));
    for (auto _ : state) {
        Image frame = morph.frame(kT, {.preview = preview});
        benchmark::DoNotOptimize(frame.planes[0].data());
    }
    frames_counter(state);
    // Per-iteration CPU time / classic_seconds: (classic x iterations / CPU time), inverted.
    state.counters["x_classic"] =
        benchmark::Counter(s.classic_seconds, benchmark::Counter::kIsIterationInvariantRate |
                                                  benchmark::Counter::kInvert);
    state.counters["PSNR"] = psnr(s.truth, morph.frame(kT, {.preview = preview})).all;
    state.counters["levels"] = morph.levels();
    state.counters["samples_per_pixel"] =
        static_cast<double>(morph.samples()) / (double{kWidth} * kHeight);
}

void BM_Morph_classic(benchmark::State& state) {
    FrameSetup& s = frame_setup();
    for (auto _ : state) {
        s.classic.frame(s.maps, kT);
        benchmark::DoNotOptimize(s.classic.out.data);
    }
    frames_counter(state);
    state.counters["PSNR"] = s.classic_psnr;
}

void BM_Morph_classic_with_maps(benchmark::State& state) {
    FrameSetup& s = frame_setup();
    ClassicMaps maps;
    for (auto _ : state) {
        classic_maps(s.meshes.a, s.meshes.a.vertices, s.meshes.b.vertices, kT, maps);
        s.classic.frame(maps, kT);
        benchmark::DoNotOptimize(s.classic.out.data);
    }
    frames_counter(state);
    state.counters["PSNR"] = s.classic_psnr;
}

// The maps alone, for the split.
void BM_Morph_classic_maps(benchmark::State& state) {
    const FrameSetup& s = frame_setup();
    ClassicMaps maps;
    for (auto _ : state) {
        classic_maps(s.meshes.a, s.meshes.a.vertices, s.meshes.b.vertices, kT, maps);
        benchmark::DoNotOptimize(maps.ax.data);
    }
}

// ---- 2. Automatic correspondences and the fit, 640x480 ----

struct AutoSetup {
    bool one_thread = single_thread();
    samples::SamplePair pair = samples::deformed_pair(kAutoWidth, kAutoHeight);
    Matches matches = auto_match(pair.a, pair.b);
    // As automatic_pair: cells of 24 px.
    Mesh grid = grid_mesh(kAutoWidth, kAutoHeight, static_cast<int>(std::lround(kAutoWidth / 24.0)),
                          static_cast<int>(std::lround(kAutoHeight / 24.0)));
};

const AutoSetup& auto_setup() {
    static const AutoSetup s;
    return s;
}

// RMS distance (px) of the fitted vertices on B from where the deformation takes A's vertices.
double vertex_error(const PairMeshes& p, const samples::Deformation& d) {
    double sum = 0;
    for (int i = 0; i < p.a.num_vertices(); ++i) {
        const Vec2 e = p.b.vertices[i] - d.at(p.a.vertices[i], 1.0);
        sum += e.x * e.x + e.y * e.y;
    }
    return std::sqrt(sum / p.a.num_vertices());
}

void BM_Morph_auto_pair(benchmark::State& state) {
    const AutoSetup& s = auto_setup();
    PairMeshes pair;
    for (auto _ : state) {
        pair = automatic_pair(s.pair.a, s.pair.b, 24);
        benchmark::DoNotOptimize(pair.b.vertices.data());
    }
    state.counters["matches"] = static_cast<double>(s.matches.a.size());
    state.counters["vertex_rms_px"] = vertex_error(pair, s.pair.deformation);
}

void BM_Morph_auto_match(benchmark::State& state) {
    const AutoSetup& s = auto_setup();
    for (auto _ : state) benchmark::DoNotOptimize(auto_match(s.pair.a, s.pair.b).a.data());
    state.counters["matches"] = static_cast<double>(s.matches.a.size());
    state.counters["from_flow"] = s.matches.from_flow;
    state.counters["from_features"] = s.matches.from_features;
}

void BM_Morph_auto_fit(benchmark::State& state) {
    const AutoSetup& s = auto_setup();
    PairMeshes pair;
    for (auto _ : state) {
        pair = fitted_pair(s.grid, {s.matches.a, s.matches.b}, kAutoWidth, kAutoHeight);
        benchmark::DoNotOptimize(pair.b.vertices.data());
    }
    state.counters["matches"] = static_cast<double>(s.matches.a.size());
    state.counters["vertex_rms_px"] = vertex_error(pair, s.pair.deformation);
}

}  // namespace

BENCHMARK(BM_Morph_classic)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Morph_classic_maps)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Morph_classic_with_maps)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Morph_frame, linear, ScheduleKind::linear, false)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Morph_frame, sharp, ScheduleKind::sharp, false)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Morph_frame, aware, ScheduleKind::aware, false)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Morph_frame, linear_preview, ScheduleKind::linear, true)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Morph_frame, sharp_preview, ScheduleKind::sharp, true)
    ->Arg(1)
    ->Arg(2)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Morph_auto_match)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Morph_auto_fit)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_Morph_auto_pair)->Unit(benchmark::kMillisecond);

}  // namespace tesswave::morph
