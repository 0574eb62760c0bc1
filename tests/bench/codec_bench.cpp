// Still-image codec speed beside OpenJPEG (the JPEG 2000 peer) on a 768x512 RGB procedural scene
// quantized to 8 bits like a file's pixels, single thread: encode and decode at 0.5 and 1 bpp
// (budget bpp * W * H / 8 bytes, as `tesswave compress --bpp`) and lossless. The `pixels` counter
// is the throughput (M/s = MPixel/s), so that the ratios to the peer can be read off one run
// (`--benchmark_filter=Codec`). It is over the thread's CPU time (the CPU column): both codecs run
// on one thread, and CPU time, unlike wall time, does not grow when other processes share the
// cores.
//
// What each timing holds:
// - encode, ours: compress_image() with StillOptions::measure off (it does not decode its result
//   for a PSNR): choosing the mesh, the band norms (impulse probes), sampling or projection,
//   colour transform, analysis, quantization and the bit-plane coder, header included; the mesh
//   encoder codes point samples and projections and decodes each to keep the best.
// - decode, ours: decompress_image() in all: header, the domain (hierarchy or grid layout, and
//   for the mesh the sample-to-pixel plan), bit-plane decoding, dequantization, inverse transform,
//   colour transform and the image planes. The domain comes from the cache (shared_domain) after
//   the first call; the `_cold` rows empty the cache before every call, as a lone command is.
// - JPEG 2000: encode_jpeg2000() and decode_jpeg2000() in all, in memory, with the conversions
//   between the float planes and OpenJPEG's integer components.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "core/codec/coding_domain.h"
#include "core/codec/still_codec.h"
#include "core/eval/peer_jpeg2000.h"
#include "core/math/metrics.h"
#include "core/math/strings.h"
#include "row_threads.h"
#include "samples/sample_images.h"

namespace tesswave {
namespace {

constexpr int kWidth = 768, kHeight = 512;
constexpr double kPixels = double{kWidth} * kHeight;

enum class Coder { jpeg2000, mesh, mesh_aligned, grid53, grid97 };

const Image& scene() {
    static const Image image = [] {
        Image out = samples::scene_image(kWidth, kHeight);
        for (auto& plane : out.planes) {
            for (float& v : plane) v = std::round(v * 255.0f) / 255.0f;
        }
        return out;
    }();
    return image;
}

int64_t budget(double bpp) { return static_cast<int64_t>(std::floor(bpp * kPixels / 8)); }

// bpp 0: lossless.
StillOptions still_options(Coder coder, double bpp) {
    StillOptions o{.lossless = bpp == 0, .max_bytes = budget(bpp)};
    if (coder == Coder::grid53) o.transform = TwiTransform::grid53;
    if (coder == Coder::grid97) o.transform = TwiTransform::grid97;
    o.aligned = coder == Coder::mesh_aligned;
    return o;
}

void finish(benchmark::State& state, size_t bytes, double psnr) {
    state.counters["pixels"] = benchmark::Counter(static_cast<double>(state.iterations()) * kPixels,
                                                  benchmark::Counter::kIsRate);
    state.counters["bpp"] = static_cast<double>(bytes) * 8 / kPixels;
    state.counters["PSNR"] = psnr;
}

// `/2threads` rows run with two threads and are timed on the wall clock; the others on one.
// Cold rows empty the domain cache before each call, so that every call builds its hierarchy,
// layout and render plan, as a single command does; warm rows reuse them, as compare, a video
// group or a second call in one process does.
void forget_domains(benchmark::State& state, bool cold) {
    if (!cold) return;
    state.PauseTiming();
    clear_domain_cache();
    state.ResumeTiming();
}

void BM_Codec_encode(benchmark::State& state, Coder coder, double bpp, bool cold, int threads) {
    const RowThreads row(threads);
    const Image& image = scene();
    if (coder == Coder::jpeg2000) {
        std::vector<uint8_t> bytes;
        for (auto _ : state) {
            bytes = encode_jpeg2000(image, {.target_bytes = budget(bpp)});
            benchmark::DoNotOptimize(bytes.data());
        }
        finish(state, bytes.size(), psnr(image, decode_jpeg2000(bytes)).all);
        return;
    }
    // The encoder alone: no decode of its own result for a PSNR (StillOptions::measure); the
    // mesh encoder with projections still decodes its candidates to choose one, which is part of
    // its work. The PSNR is measured once, after the timed loop.
    StillOptions o = still_options(coder, bpp);
    o.measure = false;
    StillResult r;
    for (auto _ : state) {
        forget_domains(state, cold);
        r = compress_image(image, o);
        benchmark::DoNotOptimize(r.file.data());
    }
    finish(state, r.file.size(), psnr(image, decompress_image(r.file, "bench")).all);
}

void BM_Codec_decode(benchmark::State& state, Coder coder, double bpp, bool cold, int threads) {
    const RowThreads row(threads);
    const Image& image = scene();
    const std::vector<uint8_t> bytes = coder == Coder::jpeg2000
                                           ? encode_jpeg2000(image, {.target_bytes = budget(bpp)})
                                           : compress_image(image, still_options(coder, bpp)).file;
    Image out;
    for (auto _ : state) {
        forget_domains(state, cold);
        out = coder == Coder::jpeg2000 ? decode_jpeg2000(bytes) : decompress_image(bytes, "bench");
        benchmark::DoNotOptimize(out.planes[0].data());
    }
    finish(state, bytes.size(), psnr(image, out).all);
}

// Grouped by rate, the peer first, so each figure sits beside the one it is compared with.
[[maybe_unused]] const bool registered = [] {
    struct Entry {
        const char* name;
        Coder coder;
    };
    const Entry lossy[] = {{"jpeg2000", Coder::jpeg2000},
                           {"mesh", Coder::mesh},
                           {"mesh_aligned", Coder::mesh_aligned},
                           {"grid53", Coder::grid53},
                           {"grid97", Coder::grid97}};
    const Entry lossless[] = {{"jpeg2000", Coder::jpeg2000},
                              {"mesh_aligned", Coder::mesh_aligned},
                              {"grid53", Coder::grid53}};
    const std::pair<double, const char*> rates[] = {
        {0.5, "0.5bpp"}, {1.0, "1bpp"}, {0, "lossless"}};
    for (const auto& [bpp, rate] : rates) {
        for (const bool encode : {true, false}) {
            for (const Entry& e : bpp == 0 ? std::span<const Entry>(lossless) : lossy) {
                // Cold and two-thread rows for the two lossy paths of our codec at 0.5 bpp.
                const bool more =
                    bpp == 0.5 && (e.coder == Coder::mesh || e.coder == Coder::grid97);
                for (const bool cold : {false, true}) {
                    for (const int threads : {1, 2}) {
                        if ((cold || threads == 2) && !more) continue;
                        const std::string name = str(encode ? "BM_Codec_encode" : "BM_Codec_decode",
                                                     cold ? "_cold/" : "/", e.name, "/", rate,
                                                     threads == 2 ? "/2threads" : "");
                        auto* b = benchmark::RegisterBenchmark(
                            name.c_str(), encode ? BM_Codec_encode : BM_Codec_decode, e.coder, bpp,
                            cold, threads);
                        b->Unit(benchmark::kMillisecond);
                        // Two threads: wall time (the CPU column is the calling thread's alone).
                        if (threads == 2) b->UseRealTime();
                    }
                }
            }
        }
    }
    return true;
}();

}  // namespace
}  // namespace tesswave
