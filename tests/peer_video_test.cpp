#include "core/eval/peer_video.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/eval/compare_video.h"
#include "core/io/video_io.h"
#include "core/math/error.h"
#include "core/math/metrics.h"
#include "temp_dir.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 10;

// A colour gradient under a fine drifting grating, with a 16x16 square moving 4 px right and
// 2 px down a frame: motion, edges and texture, so that rates matter.
Image test_frame(int w, int h, int t) {
    Image image = make_image(w, h, 3);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const float u = static_cast<float>(x) / w, v = static_cast<float>(y) / h;
            const float grating =
                0.12f * std::sin(0.9f * static_cast<float>(x - 2 * t)) *
                std::sin(0.7f * static_cast<float>(y) + 0.3f * static_cast<float>(x));
            const bool inside =
                x >= 8 + 4 * t && x < 24 + 4 * t && y >= 12 + 2 * t && y < 28 + 2 * t;
            image.at(0, x, y) = inside ? 0.9f : 0.2f + 0.6f * u + grating;
            image.at(1, x, y) = inside ? 0.2f : 0.3f + 0.5f * v + grating;
            image.at(2, x, y) =
                inside ? 0.3f : 0.5f + 0.3f * std::sin(3.0f * u + 2.0f * v) + grating;
        }
    }
    return image;
}

struct PeerRun {
    PeerVideoResult result;
    std::vector<Image> decoded;
    double psnr = 0;               // mean of the frames' PSNR
    std::vector<int> read_before;  // frames read when each decoded frame arrived
};

PeerRun run(const PeerVideoOptions& options, int w = 96, int h = 64) {
    PeerRun r;
    int read = 0;
    r.result = encode_peer_video(
        [&](Image& frame) {
            if (read == kFrames) return false;
            frame = test_frame(w, h, read++);
            return true;
        },
        [&](int index, const Image& decoded) {
            EXPECT_EQ(index, static_cast<int>(r.decoded.size()));  // display order, none missing
            r.decoded.push_back(decoded);
            r.read_before.push_back(read);
        },
        options);
    for (size_t t = 0; t < r.decoded.size(); ++t) {
        r.psnr += psnr(test_frame(w, h, static_cast<int>(t)), r.decoded[t]).all / kFrames;
    }
    return r;
}

// The bytes a target rate allows for the whole clip at 25 fps.
double target_bytes(double kbps) { return kbps * 1000 / 8 * kFrames / 25; }

// What VideoWriter's .y4m (yuv420p) and VideoReader make of the clip: the colour round trip
// every peer goes through, the ceiling of its quality.
std::vector<Image> writer_reader_round_trip(int w, int h) {
    const testing::TempDir dir("peer_video");
    const fs::path path = dir.path / "clip.y4m";
    VideoWriter writer(path.string(), w, h, {.codec = VideoCodec::rawvideo});
    for (int t = 0; t < kFrames; ++t) writer.write(test_frame(w, h, t));
    writer.finish();
    std::vector<Image> frames;
    VideoReader reader(path.string());
    for (Image frame; reader.read(frame);) frames.push_back(frame);
    fs::remove(path);
    return frames;
}

TEST(PeerVideo, lossless_x264_reproduces_the_video_writer_round_trip) {
    const PeerRun lossless = run({.codec = PeerCodec::x264, .quality = 0});
    const std::vector<Image> reference = writer_reader_round_trip(96, 64);
    ASSERT_EQ(lossless.decoded.size(), reference.size());
    for (size_t t = 0; t < reference.size(); ++t) {
        EXPECT_EQ(lossless.decoded[t].planes, reference[t].planes) << "frame " << t;
    }
    EXPECT_GT(lossless.psnr, 35.5);  // 4:2:0 chroma on the square's edges costs this much
    EXPECT_LT(lossless.psnr, 37.0);
}

TEST(PeerVideo, every_codec_decodes_every_frame_in_display_order) {
    const double ceiling = run({.codec = PeerCodec::x264, .quality = 0}).psnr;
    for (const PeerVideoOptions& options :
         {PeerVideoOptions{.codec = PeerCodec::snow, .quality = 1},
          PeerVideoOptions{.codec = PeerCodec::vc2, .kbps = 800},
          PeerVideoOptions{.codec = PeerCodec::x264, .quality = 18}}) {
        SCOPED_TRACE(peer_codec_name(options.codec));
        const PeerRun r = run(options);
        EXPECT_EQ(r.result.frames, kFrames);
        ASSERT_EQ(r.decoded.size(), size_t{kFrames});
        for (const Image& frame : r.decoded) {
            EXPECT_EQ(frame.width, 96);
            EXPECT_EQ(frame.height, 64);
            EXPECT_EQ(frame.channels(), 3);
        }
        EXPECT_GT(r.psnr, 33.0);
        EXPECT_LT(r.psnr, ceiling);
        EXPECT_GT(r.result.bytes, 1000);
        EXPECT_LT(r.result.bytes, 60000);  // raw yuv420p: 92160 bytes
    }
}

TEST(PeerVideo, intra_and_snow_stream_frame_by_frame) {
    // vc2 and snow have no delay: frame t is decoded before frame t + 1 is read, so memory stays
    // flat. x264's lookahead (40 frames at preset medium) holds this short clip until the flush.
    for (const PeerVideoOptions& options :
         {PeerVideoOptions{.codec = PeerCodec::snow, .quality = 2},
          PeerVideoOptions{.codec = PeerCodec::vc2, .kbps = 800}}) {
        SCOPED_TRACE(peer_codec_name(options.codec));
        const PeerRun r = run(options);
        ASSERT_EQ(r.read_before.size(), size_t{kFrames});
        for (int t = 0; t < kFrames; ++t) EXPECT_EQ(r.read_before[t], t + 1);
    }
}

TEST(PeerVideo, more_rate_gives_more_bytes_and_higher_psnr) {
    const std::vector<std::pair<PeerVideoOptions, PeerVideoOptions>> pairs = {
        {{.codec = PeerCodec::snow, .quality = 8}, {.codec = PeerCodec::snow, .quality = 2}},
        {{.codec = PeerCodec::vc2, .kbps = 400}, {.codec = PeerCodec::vc2, .kbps = 800}},
        {{.codec = PeerCodec::x264, .kbps = 50}, {.codec = PeerCodec::x264, .kbps = 200}},
        {{.codec = PeerCodec::x264, .quality = 35}, {.codec = PeerCodec::x264, .quality = 20}},
    };
    for (const auto& [low, high] : pairs) {
        SCOPED_TRACE(peer_codec_name(low.codec));
        const PeerRun a = run(low), b = run(high);
        EXPECT_GT(b.result.bytes, a.result.bytes * 3 / 2);
        EXPECT_GT(b.psnr, a.psnr + 2.0);
    }
}

TEST(PeerVideo, rate_control_lands_near_the_target) {
    // vc2 sizes every frame to the rate, undershooting by at most its 5 % tolerance.
    for (double kbps : {400.0, 800.0}) {
        const PeerRun r = run({.codec = PeerCodec::vc2, .kbps = kbps});
        EXPECT_GT(r.result.bytes, 0.93 * target_bytes(kbps)) << kbps;
        EXPECT_LE(r.result.bytes, target_bytes(kbps)) << kbps;
    }
    // x264's ABR with mb-tree undershoots on a clip this short (0.3 of the target at 400 kbps);
    // at 50 kbps it lands at 0.7, its 700-byte options SEI included.
    const PeerRun x264 = run({.codec = PeerCodec::x264, .kbps = 50});
    EXPECT_GT(x264.result.bytes, 0.5 * target_bytes(50));
    EXPECT_LT(x264.result.bytes, 2.0 * target_bytes(50));
}

TEST(PeerVideo, every_codec_is_deterministic) {
    // The same clip twice gives the same stream: libx264's AVX-512 kernels would not (2 to 6 %
    // of the bytes at 352x288), hence x264's AVX2 code on such CPUs.
    for (const PeerVideoOptions& options :
         {PeerVideoOptions{.codec = PeerCodec::snow, .quality = 4},
          PeerVideoOptions{.codec = PeerCodec::vc2, .kbps = 6000},
          PeerVideoOptions{.codec = PeerCodec::x264, .quality = 23}}) {
        SCOPED_TRACE(peer_codec_name(options.codec));
        const PeerRun a = run(options, 352, 288), b = run(options, 352, 288);
        EXPECT_EQ(a.result.bytes, b.result.bytes);
        ASSERT_EQ(a.decoded.size(), b.decoded.size());
        for (size_t t = 0; t < a.decoded.size(); ++t) {
            EXPECT_TRUE(a.decoded[t].planes == b.decoded[t].planes) << "frame " << t;
        }
    }
}

TEST(PeerVideo, gop_sets_the_key_frame_interval) {
    for (PeerCodec codec : {PeerCodec::snow, PeerCodec::x264}) {
        SCOPED_TRACE(peer_codec_name(codec));
        const double quality = codec == PeerCodec::snow ? 2 : 23;
        const PeerRun inter = run({.codec = codec, .quality = quality});
        const PeerRun intra = run({.codec = codec, .quality = quality, .gop = 1});
        EXPECT_GT(intra.result.bytes, inter.result.bytes * 3 / 2);
    }
}

TEST(PeerVideo, odd_sizes_are_padded_and_cropped_back) {
    for (const PeerVideoOptions& options :
         {PeerVideoOptions{.codec = PeerCodec::snow, .quality = 1},
          PeerVideoOptions{.codec = PeerCodec::vc2, .kbps = 400},
          PeerVideoOptions{.codec = PeerCodec::x264, .quality = 18}}) {
        SCOPED_TRACE(peer_codec_name(options.codec));
        const PeerRun r = run(options, 33, 17);
        ASSERT_EQ(r.decoded.size(), size_t{kFrames});
        EXPECT_EQ(r.decoded[0].width, 33);
        EXPECT_EQ(r.decoded[0].height, 17);
        EXPECT_GT(r.psnr, 28.0);
    }
}

TEST(PeerVideo, bad_options_and_frames_throw) {
    const auto none = [](Image&) { return false; };
    const auto ignore = [](int, const Image&) {};
    EXPECT_THROW(run({.codec = PeerCodec::snow, .kbps = 200}), Error);  // quality only
    EXPECT_THROW(run({.codec = PeerCodec::snow, .quality = 0}), Error);
    EXPECT_THROW(run({.codec = PeerCodec::vc2, .quality = 10}), Error);   // rate only
    EXPECT_THROW(run({.codec = PeerCodec::x264, .quality = -1}), Error);  // neither
    EXPECT_THROW(run({.codec = PeerCodec::x264, .quality = 52}), Error);
    EXPECT_THROW(run({.codec = PeerCodec::x264, .quality = 20, .fps = 0}), Error);
    EXPECT_THROW(run({.codec = PeerCodec::vc2, .kbps = 20}), Error);           // 100 bytes a frame
    EXPECT_THROW(run({.codec = PeerCodec::vc2, .kbps = 800}, 30, 64), Error);  // under a slice
    EXPECT_THROW(encode_peer_video(none, ignore, {.codec = PeerCodec::x264, .quality = 20}), Error);
    int t = 0;
    const auto shrinking = [&](Image& frame) {
        frame = test_frame(t == 0 ? 96 : 64, 64, t);
        return ++t < 3;
    };
    try {
        encode_peer_video(shrinking, ignore, {.codec = PeerCodec::x264, .quality = 20});
        ADD_FAILURE() << "no error for a frame of another size";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("frame 1 is 64x64"), std::string::npos) << e.what();
    }
}

// Default options are x264 at its own CRF 23; a rate overrides the quality, as in our encoder.
TEST(PeerVideo, default_options_are_valid_and_a_rate_overrides_quality) {
    const PeerRun by_default = run({});
    EXPECT_EQ(by_default.decoded.size(), static_cast<size_t>(kFrames));
    const PeerRun crf23 = run({.codec = PeerCodec::x264, .quality = 23});
    EXPECT_EQ(by_default.result.bytes, crf23.result.bytes);
    const PeerRun rate = run({.codec = PeerCodec::x264, .kbps = 50, .quality = 0});
    EXPECT_EQ(rate.result.bytes, run({.codec = PeerCodec::x264, .kbps = 50}).result.bytes);
}

TEST(PeerVideo, codec_names_round_trip) {
    for (PeerCodec codec : {PeerCodec::snow, PeerCodec::vc2, PeerCodec::x264}) {
        EXPECT_EQ(peer_codec_from_name(peer_codec_name(codec)), codec);
    }
    EXPECT_THROW(peer_codec_from_name("h264"), Error);
}

// compare-video notes a clip that a block-transform codec coded, naming the codec, its rate and
// the crop that avoids re-coding its blocks; raw frames, image folders and lossless codecs get
// no note.
TEST(CompareVideo, a_block_coded_source_gets_a_note) {
    eval::ClipInfo clip{.path = "a/chaplin.mp4", .name = "chaplin.mp4", .stem = "chaplin"};
    clip.source_codec = "h264";
    clip.source_bpp = 0.0861;
    const std::string note = eval::source_note(clip);
    EXPECT_NE(note.find("chaplin.mp4 is h264 at 0.086 bpp"), std::string::npos) << note;
    EXPECT_NE(note.find("crop="), std::string::npos) << note;
    clip.source_bpp = 0;  // rate unknown: the note without it
    EXPECT_NE(eval::source_note(clip).find("chaplin.mp4 is h264:"), std::string::npos);
    for (const char* codec : {"", "rawvideo", "ffv1", "png"}) {
        clip.source_codec = codec;
        EXPECT_EQ(eval::source_note(clip), "") << codec;
    }
}

}  // namespace
}  // namespace tesswave
