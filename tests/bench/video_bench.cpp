// Video codec speed at 352x288 (CIF) on the procedural sample clip (pan, zoom, a moving disk),
// 0.2 bpp, single thread, beside x264 (preset medium, the reference line of compare-video) in the
// same run: frames/s of encoding and of decoding for the moving mesh, the static mesh and the
// fixed-grid 5/3 and 9/7, on one thread and on two (the second argument). The `frames` counter is
// the throughput over wall time, so that the one- and two-thread rows compare.
//
// - encode: VideoEncoder::encode() per frame, a group of 32 frames lifted along time (tracking,
//   the Ceres fit and the projection included for the moving mesh, and its second coding of the
//   group on the static mesh; the group's reconstruction included), plus finish(). The last row
//   is the moving mesh with low-delay groups (closed-loop deltas).
// - decode: VideoDecoder::read() per frame of the file the encode wrote, rendering included.
// - x264: encode_peer_video() at the same rate, encoding and decoding together (libavcodec).
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <vector>

#include "core/eval/peer_video.h"
#include "row_threads.h"
#include "samples/sample_clip.h"
#include "video/dec_video.h"
#include "video/enc_video.h"

namespace tesswave::video {
namespace {

constexpr int kWidth = 352, kHeight = 288, kFrames = 32;
constexpr double kFps = 25, kBpp = 0.2;
constexpr double kKbps = kBpp * kWidth * kHeight * kFps / 1000;

const std::vector<Image>& clip() {
    static const std::vector<Image> frames = [] {
        const samples::SampleClipOptions o{.width = kWidth,
                                           .height = kHeight,
                                           .frames = kFrames,
                                           .pan = {1.25, 0.5},
                                           .zoom = 0.002};
        std::vector<Image> out;
        for (int t = 0; t < kFrames; ++t) out.push_back(samples::sample_clip_frame(o, t));
        return out;
    }();
    return frames;
}

VideoEncodeOptions options_for(int mode) {
    switch (mode) {
        case 0:  // the encoder's default: the grid is each group's candidate too
            return {.kbps = kKbps};
        case 1:  // the static mesh alone
            return {.motion = TwvMotion::none, .kbps = kKbps, .grid_groups = false};
        case 2:
            return {.transform = TwiTransform::grid53, .kbps = kKbps};
        case 3:
            return {.transform = TwiTransform::grid97, .kbps = kKbps};
        default:
            return {.low_delay = true, .kbps = kKbps};
    }
}

const char* kNames[] = {"moving_mesh", "static_mesh", "grid53", "grid97", "moving_low_delay"};

std::string path_for(int mode) {
    return (std::filesystem::temp_directory_path() /
            (std::string("video_bench_") + kNames[mode] + ".twv"))
        .string();
}

void encode_clip(int mode) {
    VideoEncoder encoder(path_for(mode), kWidth, kHeight, kFps, options_for(mode));
    for (const Image& f : clip()) encoder.encode(f);
    encoder.finish();
}

void BM_VideoEncode(benchmark::State& state) {
    const int mode = static_cast<int>(state.range(0));
    const RowThreads row(state.range(1));
    clip();
    for (auto _ : state) encode_clip(mode);
    state.SetLabel(kNames[mode]);
    state.counters["frames"] = benchmark::Counter(static_cast<double>(state.iterations()) * kFrames,
                                                  benchmark::Counter::kIsRate);
}

void BM_VideoDecode(benchmark::State& state) {
    const int mode = static_cast<int>(state.range(0));
    const RowThreads row(state.range(1));
    encode_clip(mode);
    Image frame;
    for (auto _ : state) {
        VideoDecoder decoder(path_for(mode));
        while (decoder.read(frame)) benchmark::DoNotOptimize(frame.planes.data());
    }
    state.SetLabel(kNames[mode]);
    state.counters["frames"] = benchmark::Counter(static_cast<double>(state.iterations()) * kFrames,
                                                  benchmark::Counter::kIsRate);
}

void BM_VideoX264(benchmark::State& state) {
    clip();
    for (auto _ : state) {
        size_t next = 0;
        encode_peer_video(
            [&](Image& f) {
                if (next == clip().size()) return false;
                f = clip()[next++];
                return true;
            },
            [](int, const Image& decoded) { benchmark::DoNotOptimize(decoded.planes.data()); },
            {.codec = PeerCodec::x264, .kbps = kKbps, .fps = kFps, .gop = 32});
    }
    state.SetLabel("x264 encode+decode");
    state.counters["frames"] = benchmark::Counter(static_cast<double>(state.iterations()) * kFrames,
                                                  benchmark::Counter::kIsRate);
}

BENCHMARK(BM_VideoEncode)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_VideoDecode)
    ->ArgsProduct({{0, 1, 2, 3, 4}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_VideoX264)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace tesswave::video
