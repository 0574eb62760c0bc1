// Fixed-grid wavelet round trips (forward + inverse, 3 channels, 5 levels) on square images of
// 1e5, 1e6 and 1e7 samples; items are samples per channel set, as in the mesh benchmarks.
#include <benchmark/benchmark.h>

#include <cstdint>
#include <random>
#include <vector>

#include "core/math/fixed_grid.h"

namespace tesswave {
namespace {

constexpr int kChannels = 3;
constexpr int kLevels = 5;

template <typename T>
std::vector<std::vector<T>> random_planes(int side) {
    std::mt19937 rng(42);
    std::vector<std::vector<T>> planes(kChannels, std::vector<T>(static_cast<size_t>(side) * side));
    for (auto& plane : planes) {
        for (T& v : plane) v = static_cast<T>(rng() >> 24);  // 8-bit samples
    }
    return planes;
}

void float_round_trip(benchmark::State& state, GridWavelet wavelet) {
    const int side = static_cast<int>(state.range(0));
    std::vector<std::vector<float>> planes = random_planes<float>(side);
    const GridTransformOptions options{.wavelet = wavelet, .levels = kLevels};
    for (auto _ : state) {
        for (auto& plane : planes) {
            grid_forward(plane, side, side, options);
            grid_inverse(plane, side, side, options);
            benchmark::DoNotOptimize(plane.data());
        }
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(side) * side);
}

void BM_grid53_roundtrip(benchmark::State& state) { float_round_trip(state, GridWavelet::cdf53); }
void BM_grid97_roundtrip(benchmark::State& state) { float_round_trip(state, GridWavelet::cdf97); }

void BM_grid53_int_roundtrip(benchmark::State& state) {
    const int side = static_cast<int>(state.range(0));
    std::vector<std::vector<int32_t>> planes = random_planes<int32_t>(side);
    for (auto _ : state) {
        for (auto& plane : planes) {
            grid_forward_int53(plane, side, side, kLevels);
            grid_inverse_int53(plane, side, side, kLevels);
            benchmark::DoNotOptimize(plane.data());
        }
        benchmark::ClobberMemory();
    }
    state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(side) * side);
}

BENCHMARK(BM_grid53_roundtrip)->Arg(316)->Arg(1000)->Arg(3162)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_grid97_roundtrip)->Arg(316)->Arg(1000)->Arg(3162)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_grid53_int_roundtrip)->Arg(316)->Arg(1000)->Arg(3162)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace tesswave
