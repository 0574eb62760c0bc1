// Mesh transform throughput (forward + inverse, 3 channels, all levels) on a Voronoi and a regular
// grid mesh at about 1e5, 1e6 and 1e7 samples; compare with BM_grid53_roundtrip at the same counts.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>

#include "core/math/grid_mesh.h"
#include "core/math/lifting.h"
#include "core/math/parallel.h"
#include "core/math/voronoi.h"
#include "row_threads.h"

namespace tesswave {
namespace {

// Every figure here is single-threaded, as its peers are, unless a benchmark sets threads itself
// (BM_Morph_frame's second row) and puts it back.
const bool kOneThread = (set_thread_count(1), true);

constexpr int kLevels = 6;  // each T0 face corner spans a 32x32 patch of T_6 quads

void run_roundtrip(benchmark::State& state, const Mesh& mesh,
                   LiftingKernel kernel = LiftingKernel::fast) {
    const Hierarchy h = build_hierarchy(mesh, {.levels = kLevels});
    const size_t n = h.num_samples(kLevels);
    std::vector<std::vector<float>> planes(3, std::vector<float>(n));
    std::mt19937 rng(1);
    for (auto& p : planes) {
        for (float& v : p) v = static_cast<float>(rng() % 256);
    }
    std::vector<std::span<float>> spans(planes.begin(), planes.end());
    for (auto _ : state) {
        forward_transform(h, spans, {.kernel = kernel});
        inverse_transform(h, spans, {.kernel = kernel});
        benchmark::DoNotOptimize(planes[0].data());
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(n));
    state.counters["samples"] = static_cast<double>(n);
}

// Sites so that the Voronoi mesh has about `samples` samples at level 6 (q ~ 6 corners a site).
void BM_mesh_roundtrip_voronoi(benchmark::State& state) {
    const int sites = static_cast<int>(state.range(0) / (6.0 * 1024));
    run_roundtrip(state,
                  voronoi_mesh(4000, 3000, {.sites = sites, .seed = 1, .lloyd_iterations = 1}));
}

// The same on two threads (wall time): the patches and the skeleton's points shared.
void BM_mesh_roundtrip_voronoi_two_threads(benchmark::State& state) {
    const RowThreads row(2);
    BM_mesh_roundtrip_voronoi(state);
}

// Cells so that the grid mesh has about `samples` samples at level 6 (4096 per cell).
void BM_mesh_roundtrip_grid(benchmark::State& state) {
    const int cells = static_cast<int>(std::lround(std::sqrt(state.range(0) / 4096.0)));
    run_roundtrip(state, grid_mesh(4000, 4000, cells, cells));
}

// The plain reference kernel on the Voronoi mesh, for the fast/reference ratio.
void BM_mesh_roundtrip_voronoi_reference(benchmark::State& state) {
    const int sites = static_cast<int>(state.range(0) / (6.0 * 1024));
    run_roundtrip(state,
                  voronoi_mesh(4000, 3000, {.sites = sites, .seed = 1, .lloyd_iterations = 1}),
                  LiftingKernel::reference);
}

}  // namespace

BENCHMARK(BM_mesh_roundtrip_voronoi_reference)
    ->Arg(100'000)
    ->Arg(1'000'000)
    ->Arg(10'000'000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_mesh_roundtrip_voronoi)
    ->Arg(100'000)
    ->Arg(1'000'000)
    ->Arg(10'000'000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_mesh_roundtrip_voronoi_two_threads)
    ->Arg(1'000'000)
    ->Arg(10'000'000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_mesh_roundtrip_grid)
    ->Arg(100'000)
    ->Arg(1'000'000)
    ->Arg(10'000'000)
    ->Unit(benchmark::kMillisecond);

}  // namespace tesswave
