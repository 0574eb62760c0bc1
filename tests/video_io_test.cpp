#include "core/io/video_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/io/image_io.h"
#include "core/math/error.h"
#include "core/math/heap.h"
#include "core/math/metrics.h"
#include "samples/sample_images.h"
#include "temp_dir.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

struct TempDir : testing::TempDir {
    TempDir() : testing::TempDir("video_io") {}
};

// A smooth colour field drifting right by 2 px a frame, different in each channel.
Image smooth_frame(int w, int h, int t) {
    Image image = make_image(w, h, 3);
    for (int c = 0; c < 3; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                const float u = static_cast<float>(x - 2 * t), v = static_cast<float>(y);
                image.at(c, x, y) =
                    0.5f + 0.25f * std::sin(0.09f * u + 1.3f * c) * std::cos(0.07f * v - 0.4f * c) +
                    0.15f * (static_cast<float>(x) / w - 0.5f);
            }
        }
    }
    return image;
}

// Blobs of several sizes and signs on a slow grating, translated by `shift` px to the right:
// features for motion estimation to lock onto (no period it could alias with), which plain
// averaging doubles.
Image texture(int w, int h, float shift) {
    Image image = make_image(w, h, 3);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const float u = static_cast<float>(x) - shift, v = static_cast<float>(y);
            float a = 0.2f + 0.1f * std::sin(0.07f * u + 0.05f * v);
            for (int i = 0; i < 40; ++i) {
                const float cx = std::fmod(37.7f * i, 150.0f) - 10.0f;
                const float cy = std::fmod(23.3f * i, 110.0f) - 5.0f;
                const float r = 4.0f + 2.0f * static_cast<float>(i % 5);
                const float d2 = (u - cx) * (u - cx) + (v - cy) * (v - cy);
                a += 0.35f * (static_cast<float>(i % 3) - 0.8f) * std::exp(-d2 / (2 * r * r));
            }
            image.at(0, x, y) = a;
            image.at(1, x, y) = 1.0f - 0.8f * a;
            image.at(2, x, y) = 0.3f + 0.4f * std::sin(0.13f * u - 0.21f * v) * a;
        }
    }
    return image;
}

// Every sample on the 8-bit grid (q / 255), so that a lossless 8-bit path reproduces it.
Image on_8bit_grid(Image image) {
    for (auto& plane : image.planes) {
        for (float& v : plane) v = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
    }
    return image;
}

Image crop(const Image& image, int w, int h) {
    Image out = make_image(w, h, image.channels());
    for (int c = 0; c < image.channels(); ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) out.at(c, x, y) = image.at(c, x, y);
        }
    }
    return out;
}

Image average(const Image& a, const Image& b) {
    Image out = a;
    for (int c = 0; c < a.channels(); ++c) {
        for (size_t i = 0; i < a.planes[c].size(); ++i) {
            out.planes[c][i] = 0.5f * (a.planes[c][i] + b.planes[c][i]);
        }
    }
    return out;
}

std::vector<Image> read_all(const std::string& path) {
    VideoReader reader(path);
    std::vector<Image> frames;
    Image frame;
    while (reader.read(frame)) frames.push_back(frame);
    return frames;
}

TEST(VideoIo, h264_mp4_round_trip_keeps_size_count_and_quality) {
    TempDir dir;
    const std::string path = dir / "clip.mp4";
    VideoWriter writer(path, 96, 64);
    EXPECT_EQ(writer.coded_width(), 96);
    for (int t = 0; t < 10; ++t) writer.write(smooth_frame(96, 64, t));
    EXPECT_FALSE(fs::exists(path));  // only the temporary until finish()
    writer.finish();
    ASSERT_TRUE(fs::exists(path));

    VideoReader reader(path);
    EXPECT_EQ(reader.width(), 96);
    EXPECT_EQ(reader.height(), 64);
    EXPECT_DOUBLE_EQ(reader.fps(), 25.0);
    EXPECT_EQ(reader.frame_count_estimate(), 10);
    EXPECT_EQ(reader.bit_depth(), 8);
    Image frame;
    int t = 0;
    for (; reader.read(frame); ++t) {
        ASSERT_LT(t, 10);
        ASSERT_EQ(frame.channels(), 3);
        ASSERT_EQ(frame.width, 96);
        ASSERT_EQ(frame.height, 64);
        const double db = psnr(smooth_frame(96, 64, t), frame).all;
        EXPECT_GT(db, 35.0) << "frame " << t;
        EXPECT_LT(db, 55.0) << "frame " << t;  // lossy: a much higher value means a stale bound
    }
    EXPECT_EQ(t, 10);
    EXPECT_FALSE(reader.read(frame));  // stays at the end
}

// The same frames give the same file, also when the encoder's buffers come from memory that held
// something else: x264's AVX-512 kernels did not (video_io.cpp). The heap keeps freed blocks, as
// the command's does, and is filled with other bytes before each run.
TEST(VideoIo, h264_gives_the_same_bytes_for_the_same_frames) {
    keep_freed_blocks();
    TempDir dir;
    const Image a = samples::scene_image(600, 400, 1), b = samples::scene_image(600, 400, 2);
    std::vector<std::string> bytes;
    for (int run = 0; run < 3; ++run) {
        {
            std::vector<std::vector<uint8_t>> garbage;
            for (int k = 0; k < 32; ++k) garbage.emplace_back(1 << 21, uint8_t(37 * run + k));
        }
        const std::string path = dir / ("clip" + std::to_string(run) + ".mp4");
        VideoWriter writer(path, 600, 400, {.preset = "veryfast"});
        for (int t = 0; t < 16; ++t) {
            Image frame = make_image(600, 400, 3, SampleFormat::f32);
            for (int c = 0; c < 3; ++c) {
                for (size_t i = 0; i < frame.planes[c].size(); ++i) {
                    frame.planes[c][i] =
                        a.planes[c][i] + (b.planes[c][i] - a.planes[c][i]) * (t / 15.0f);
                }
            }
            writer.write(frame);
        }
        writer.finish();
        std::ifstream in(path, std::ios::binary);
        bytes.emplace_back(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    EXPECT_TRUE(bytes[0] == bytes[1]) << "the first and second files differ";
    EXPECT_TRUE(bytes[0] == bytes[2]) << "the first and third files differ";
}

TEST(VideoIo, h264_pads_odd_sizes_to_even) {
    TempDir dir;
    const std::string path = dir / "odd.mkv";
    VideoWriter writer(path, 95, 63);
    EXPECT_EQ(writer.coded_width(), 96);
    EXPECT_EQ(writer.coded_height(), 64);
    for (int t = 0; t < 3; ++t) writer.write(smooth_frame(95, 63, t));
    writer.finish();
    const std::vector<Image> frames = read_all(path);
    ASSERT_EQ(frames.size(), 3u);
    for (int t = 0; t < 3; ++t) {
        ASSERT_EQ(frames[t].width, 96);
        ASSERT_EQ(frames[t].height, 64);
        EXPECT_GT(psnr(smooth_frame(95, 63, t), crop(frames[t], 95, 63)).all, 35.0);
        // The padding repeats the last column and row.
        EXPECT_NEAR(frames[t].at(1, 95, 10), frames[t].at(1, 94, 10), 0.03f);
        EXPECT_NEAR(frames[t].at(1, 10, 63), frames[t].at(1, 10, 62), 0.03f);
    }
}

TEST(VideoIo, ffv1_mkv_round_trip_is_bit_exact) {
    TempDir dir;
    for (const int depth : {8, 16}) {
        const std::string path = dir / ("lossless" + std::to_string(depth) + ".mkv");
        std::vector<Image> frames;
        for (int t = 0; t < 4; ++t) {
            Image f = on_8bit_grid(smooth_frame(33, 17, t));  // odd sizes are fine losslessly
            if (depth == 16) {
                for (auto& p : f.planes) {
                    for (float& v : p) v = std::round(v * 65535.0f - 77.0f * t) / 65535.0f;
                }
            }
            frames.push_back(f);
        }
        VideoWriter writer(path, 33, 17,
                           {.fps = 10, .codec = VideoCodec::ffv1, .bit_depth = depth});
        for (const Image& f : frames) writer.write(f);
        writer.finish();

        VideoReader reader(path);
        EXPECT_EQ(reader.bit_depth(), depth);
        EXPECT_DOUBLE_EQ(reader.fps(), 10.0);
        Image frame;
        size_t n = 0;
        for (; reader.read(frame); ++n) {
            ASSERT_LT(n, frames.size());
            ASSERT_EQ(frame.width, 33);
            ASSERT_EQ(frame.height, 17);
            EXPECT_EQ(frame.format, depth == 8 ? SampleFormat::u8 : SampleFormat::u16);
            EXPECT_EQ(frame.planes, frames[n].planes) << "depth " << depth << " frame " << n;
        }
        EXPECT_EQ(n, frames.size());
    }
}

TEST(VideoIo, grey_and_rgba_frames_are_written_as_rgb) {
    TempDir dir;
    const std::string path = dir / "grey.mkv";
    Image grey = make_image(8, 6, 1);
    Image rgba = make_image(8, 6, 4);
    for (int i = 0; i < 48; ++i) {
        grey.planes[0][i] = static_cast<float>(i * 5) / 255.0f;
        for (int c = 0; c < 4; ++c) rgba.planes[c][i] = static_cast<float>(i + 60 * c) / 255.0f;
    }
    VideoWriter writer(path, 8, 6, {.codec = VideoCodec::ffv1});
    writer.write(grey);
    writer.write(rgba);
    writer.finish();
    const std::vector<Image> frames = read_all(path);
    ASSERT_EQ(frames.size(), 2u);
    for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(frames[0].planes[c], grey.planes[0]);
        EXPECT_EQ(frames[1].planes[c], rgba.planes[c]);
    }
}

TEST(VideoIo, y4m_rawvideo_round_trip) {
    TempDir dir;
    const std::string path = dir / "clip.y4m";
    VideoWriter writer(path, 48, 32, {.fps = 30, .codec = VideoCodec::rawvideo});
    for (int t = 0; t < 3; ++t) writer.write(smooth_frame(48, 32, t));
    writer.finish();
    VideoReader reader(path);
    EXPECT_DOUBLE_EQ(reader.fps(), 30.0);
    Image frame;
    int t = 0;
    for (; reader.read(frame); ++t) {
        const double db = psnr(smooth_frame(48, 32, t), frame).all;
        EXPECT_GT(db, 45.0);  // 4:2:0 and 8-bit YUV only
        EXPECT_LT(db, 60.0);
    }
    EXPECT_EQ(t, 3);
}

TEST(VideoIo, gif_has_right_count_size_and_quality) {
    TempDir dir;
    const std::string path = dir / "anim.gif";
    std::vector<Image> frames;
    for (int t = 0; t < 6; ++t) frames.push_back(smooth_frame(64, 48, t));
    write_gif(frames, path, 10);
    VideoReader reader(path);
    EXPECT_EQ(reader.width(), 64);
    EXPECT_EQ(reader.height(), 48);
    Image frame;
    int t = 0;
    for (; reader.read(frame); ++t) {
        ASSERT_LT(t, 6);
        const double db = psnr(frames[t], frame).all;
        EXPECT_GT(db, 25.0) << "frame " << t;
        EXPECT_LT(db, 50.0) << "frame " << t;  // 256 colours cannot be near lossless here
    }
    EXPECT_EQ(t, 6);
}

TEST(VideoIo, gif_filter_string) {
    EXPECT_EQ(gif_filter(),
              "split[a][b];[a]palettegen=stats_mode=full:max_colors=256:reserve_transparent=0[p];"
              "[b][p]paletteuse=dither=sierra2_4a");
    EXPECT_THROW(gif_filter({.dither = "sierra2_4a[x];"}), Error);
}

TEST(VideoIo, minterpolate_beats_averaging_on_a_translation) {
    const int w = 128, h = 96;
    const Image frame0 = texture(w, h, 0), frame1 = texture(w, h, 8), truth = texture(w, h, 4);
    const Image middle = minterpolate_middle(frame0, frame1);
    ASSERT_EQ(middle.width, w);
    ASSERT_EQ(middle.height, h);
    ASSERT_EQ(middle.channels(), 3);
    const double mci = psnr(truth, middle).all;
    const double blend = psnr(truth, average(frame0, frame1)).all;
    EXPECT_GT(mci, blend + 5.0) << "minterpolate " << mci << " dB, average " << blend << " dB";
    EXPECT_LT(mci, 60.0);  // the borders cannot be exact

    // Identical frames come back through the 4:4:4 full-range YUV round trip almost unchanged.
    const Image still = minterpolate_middle(frame0, frame0);
    EXPECT_GT(psnr(frame0, still).all, 45.0);
    EXPECT_EQ(minterpolate_filter(),
              "format=yuvj444p,minterpolate=fps=2:mi_mode=mci:mc_mode=obmc:me_mode=bilat:me=epzs:"
              "mb_size=16:search_param=32:vsbmc=0:scd=none,format=gbrp");
}

TEST(VideoIo, minterpolate_rejects_bad_input) {
    EXPECT_THROW(minterpolate_middle(texture(31, 40, 0), texture(31, 40, 1)), Error);  // < 2 blocks
    EXPECT_THROW(minterpolate_middle(texture(64, 40, 0), texture(40, 64, 1)), Error);
    EXPECT_THROW(minterpolate_middle(texture(64, 64, 0), texture(64, 64, 1), {.me = "x,y"}), Error);
    EXPECT_NO_THROW(minterpolate_middle(texture(16, 16, 0), texture(16, 16, 1), {.mb_size = 8}));
}

TEST(VideoIo, reader_errors_name_the_file) {
    TempDir dir;
    const auto expect_error = [](const std::string& path) {
        try {
            VideoReader reader(path);
            ADD_FAILURE() << path << ": no error";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        }
    };
    expect_error(dir / "missing.mp4");
    std::ofstream(dir / "empty.mp4").close();
    expect_error(dir / "empty.mp4");
    std::ofstream(dir / "text.mp4") << "not a video at all, just some words\n";
    expect_error(dir / "text.mp4");
    write_image(smooth_frame(16, 16, 0), dir / "still.png");
    fs::rename(dir / "still.png", dir / "still.mp4");
    expect_error(dir / "still.mp4");
    expect_error(dir.path.string());  // a directory
    // Allowed explicitly, the still reads as a one-frame clip.
    VideoReader still(dir / "still.mp4", {.allow_still_images = true});
    Image frame;
    EXPECT_TRUE(still.read(frame));
    EXPECT_FALSE(still.read(frame));
    // A frame over the pixel limit is refused before decoding.
    EXPECT_THROW(VideoReader(dir / "still.mp4", {.max_pixels = 255, .allow_still_images = true}),
                 Error);
}

TEST(VideoIo, failed_writes_leave_no_file) {
    TempDir dir;
    EXPECT_THROW(VideoWriter(dir / "no_such_dir/clip.mp4", 32, 32), Error);
    EXPECT_THROW(VideoWriter(dir / "clip.avi", 32, 32), Error);
    EXPECT_THROW(VideoWriter(dir / "clip.mp4", 32, 32, {.codec = VideoCodec::ffv1}), Error);
    EXPECT_THROW(VideoWriter(dir / "clip.mp4", 32, 32, {.preset = "warp"}), Error);
    EXPECT_THROW(VideoWriter(dir / "clip.mp4", 0, 32), Error);
    {
        VideoWriter writer(dir / "clip.mp4", 32, 32);
        writer.write(smooth_frame(32, 32, 0));
        EXPECT_THROW(writer.write(smooth_frame(30, 32, 1)), Error);
        EXPECT_THROW(writer.finish(), Error);  // failed writers stay failed
    }
    {
        VideoWriter writer(dir / "abandoned.mkv", 32, 32, {.codec = VideoCodec::ffv1});
        writer.write(smooth_frame(32, 32, 0));
    }  // never finished
    {
        VideoWriter writer(dir / "nothing.mp4", 32, 32);
        EXPECT_THROW(writer.finish(), Error);  // no frames
    }
    EXPECT_THROW(write_gif({smooth_frame(32, 32, 0), smooth_frame(32, 30, 1)}, dir / "a.gif", 10),
                 Error);
    EXPECT_THROW(write_gif({}, dir / "b.gif", 10), Error);
    EXPECT_THROW(write_gif({smooth_frame(32, 32, 0)}, dir / "c.gif", 10, {.dither = "x"}), Error);
    EXPECT_TRUE(dir.empty());
}

}  // namespace
}  // namespace tesswave
