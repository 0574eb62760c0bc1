#include "core/io/frame_source.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/io/image_io.h"
#include "core/io/video_io.h"
#include "core/math/error.h"
#include "temp_dir.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

struct TempDir : testing::TempDir {
    TempDir() : testing::TempDir("frame_source") {}
};

// Frame t of a small clip, every sample on the 8-bit grid (q / 255), different in each channel,
// so that a lossless path reproduces it exactly.
Image grid_frame(int w, int h, int t) {
    Image image = make_image(w, h, 3);
    for (int c = 0; c < 3; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                image.at(c, x, y) =
                    static_cast<float>((7 * x + 11 * y + 40 * c + 9 * t) % 256) / 255;
            }
        }
    }
    return image;
}

// A uniform image whose value tells frame t apart.
Image uniform(int w, int h, int channels, int t) {
    Image image = make_image(w, h, channels);
    for (auto& plane : image.planes) std::fill(plane.begin(), plane.end(), (10.0f * t + 5) / 255);
    return image;
}

std::vector<Image> read_all(FrameSource& source) {
    std::vector<Image> frames;
    for (Image frame; source.read(frame);) frames.push_back(frame);
    return frames;
}

void write_bytes(const std::string& path, const std::vector<uint8_t>& bytes) {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()),
              static_cast<std::streamsize>(bytes.size()));
}

std::string error_of(const std::string& path, const FrameSourceOptions& options = {}) {
    try {
        FrameSource source(path, options);
        read_all(source);
    } catch (const Error& e) {
        return e.what();
    }
    return "no error";
}

TEST(FrameSource, reads_a_lossless_mkv_exactly) {
    TempDir dir;
    const std::string path = dir / "clip.mkv";
    VideoWriter writer(path, 40, 30, {.fps = 12, .codec = VideoCodec::ffv1});
    for (int t = 0; t < 6; ++t) writer.write(grid_frame(40, 30, t));
    writer.finish();
    FrameSource source(path);
    EXPECT_EQ(source.width(), 40);
    EXPECT_EQ(source.height(), 30);
    EXPECT_DOUBLE_EQ(source.fps(), 12);
    EXPECT_EQ(source.trailing_bytes(), 0);
    const std::vector<Image> frames = read_all(source);
    ASSERT_EQ(frames.size(), 6u);
    for (int t = 0; t < 6; ++t) EXPECT_EQ(frames[t].planes, grid_frame(40, 30, t).planes) << t;
    EXPECT_DOUBLE_EQ(FrameSource(path, {.fps = 30}).fps(), 30);  // the caller's rate wins
}

TEST(FrameSource, reads_y4m_as_video_reader_does) {
    TempDir dir;
    const std::string path = dir / "clip.y4m";
    VideoWriter writer(path, 36, 20, {.codec = VideoCodec::rawvideo});
    for (int t = 0; t < 4; ++t) writer.write(grid_frame(36, 20, t));
    writer.finish();
    FrameSource source(path);
    EXPECT_EQ(source.frame_count_estimate(), VideoReader(path).frame_count_estimate());
    const std::vector<Image> frames = read_all(source);
    VideoReader reader(path);
    ASSERT_EQ(frames.size(), 4u);
    for (const Image& frame : frames) {
        Image expected;
        ASSERT_TRUE(reader.read(expected));
        EXPECT_EQ(frame.planes, expected.planes);
    }
}

// A video file tells its codec and bits a pixel (its bit rate over its own pixels a second, not
// the caller's rate); raw frames and folders tell none.
TEST(FrameSource, a_video_file_tells_its_codec_and_rate) {
    TempDir dir;
    const std::string mp4 = dir / "clip.mp4", y4m = dir / "clip.y4m";
    VideoWriter h264(mp4, 64, 48, {.fps = 10, .codec = VideoCodec::h264, .crf = 30});
    VideoWriter raw(y4m, 64, 48, {.fps = 10, .codec = VideoCodec::rawvideo});
    for (int t = 0; t < 10; ++t) {
        h264.write(grid_frame(64, 48, t));
        raw.write(grid_frame(64, 48, t));
    }
    h264.finish();
    raw.finish();
    const FrameSource coded(mp4);
    EXPECT_EQ(coded.source_codec(), "h264");
    const double bpp = coded.source_bits_per_pixel();
    const double bytes = static_cast<double>(std::filesystem::file_size(mp4));
    EXPECT_GT(bpp, 0);
    EXPECT_LT(bpp, 8 * bytes / (64.0 * 48 * 10));  // at most the whole file's bits a pixel
    EXPECT_DOUBLE_EQ(FrameSource(mp4, {.fps = 40}).source_bits_per_pixel(), bpp);
    EXPECT_EQ(FrameSource(y4m).source_codec(), "rawvideo");
    const std::filesystem::path frames = dir.path / "frames";
    std::filesystem::create_directories(frames);
    write_image(uniform(8, 6, 3, 1), (frames / "f1.png").string());
    EXPECT_EQ(FrameSource(frames.string()).source_codec(), "");
    EXPECT_EQ(FrameSource(frames.string()).source_bits_per_pixel(), 0);
}

TEST(FrameSource, folder_frames_come_in_natural_order) {
    TempDir dir;
    // Frame t is named names[t]; written out of order, with a file that is not an image.
    const std::vector<std::string> names = {"f1.png",   "f2.png",  "f9.png",
                                            "f010.png", "f11.PNG", "g1.png"};
    for (int t : {3, 0, 5, 2, 4, 1}) write_image(uniform(8, 6, 3, t), dir / names[t]);
    std::ofstream(dir / "notes.txt") << "not a frame";
    FrameSource source(dir.path.string());
    EXPECT_EQ(source.frame_count_estimate(), 6);
    EXPECT_DOUBLE_EQ(source.fps(), 25);
    const std::vector<Image> frames = read_all(source);
    ASSERT_EQ(frames.size(), 6u);
    for (int t = 0; t < 6; ++t) {
        EXPECT_EQ(frames[t].channels(), 3);
        EXPECT_FLOAT_EQ(frames[t].at(1, 3, 2), (10.0f * t + 5) / 255) << names[t];
    }
}

TEST(FrameSource, folder_frames_become_rgb) {
    TempDir dir;
    write_image(uniform(8, 6, 1, 1), dir / "a1.png");  // grey
    Image rgba = grid_frame(8, 6, 2);
    rgba.planes.push_back(std::vector<float>(48, 0.5f));
    write_image(rgba, dir / "a2.png");
    FrameSource source(dir.path.string(), {.fps = 8});
    EXPECT_DOUBLE_EQ(source.fps(), 8);
    const std::vector<Image> frames = read_all(source);
    ASSERT_EQ(frames.size(), 2u);
    EXPECT_EQ(frames[0].channels(), 3);
    EXPECT_EQ(frames[0].planes[0], frames[0].planes[2]);
    EXPECT_FLOAT_EQ(frames[0].at(0, 0, 0), 15.0f / 255);
    // Alpha dropped; OpenImageIO's 8-bit to float conversion may differ from q / 255 by an ulp.
    const Image rgb = grid_frame(8, 6, 2);
    ASSERT_EQ(frames[1].channels(), 3);
    for (int c = 0; c < 3; ++c) {
        for (size_t i = 0; i < rgb.planes[c].size(); ++i) {
            EXPECT_NEAR(frames[1].planes[c][i], rgb.planes[c][i], 1e-6) << c << " " << i;
        }
    }
}

TEST(FrameSource, folder_frame_of_another_size_names_the_file) {
    TempDir dir;
    for (int t = 0; t < 7; ++t)
        write_image(uniform(8, 6, 3, t), dir / ("frame" + std::to_string(t) + ".png"));
    write_image(uniform(6, 8, 3, 7), dir / "frame7.png");
    FrameSource source(dir.path.string());
    Image frame;
    for (int t = 0; t < 7; ++t) ASSERT_TRUE(source.read(frame));
    try {
        source.read(frame);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()), dir / "frame7.png" + ": frame 7 is 6x8, the clip is 8x6");
    }
}

// BT.601, limited range (Y 16..235, Cb and Cr 16..240 around 128): R, G, B in [0, 1].
std::array<double, 3> bt601_rgb(int Y, int Cb, int Cr) {
    const double y = (Y - 16) / 219.0, cb = (Cb - 128) / 224.0, cr = (Cr - 128) / 224.0;
    return {y + 1.402 * cr, y - 0.344136 * cb - 0.714136 * cr, y + 1.772 * cb};
}

// Raw planar frames of w x h: a luma ramp and one chroma value a frame (so that chroma
// interpolation cannot matter). Chroma planes are cw x ch; none for gray.
struct RawClip {
    int w = 33, h = 17, cw = 0, ch = 0, frames = 3;
    int luma(int x, int y, int t) const { return 60 + (3 * x + 5 * y + 7 * t) % 120; }
    int cb(int t) const { return 110 + 10 * t; }
    int cr(int t) const { return 150 - 8 * t; }
    std::vector<uint8_t> bytes() const {
        std::vector<uint8_t> out;
        for (int t = 0; t < frames; ++t) {
            for (int y = 0; y < h; ++y) {
                for (int x = 0; x < w; ++x) out.push_back(static_cast<uint8_t>(luma(x, y, t)));
            }
            out.insert(out.end(), static_cast<size_t>(cw) * ch, static_cast<uint8_t>(cb(t)));
            out.insert(out.end(), static_cast<size_t>(cw) * ch, static_cast<uint8_t>(cr(t)));
        }
        return out;
    }
};

TEST(FrameSource, raw_yuv_converts_as_bt601_limited_range) {
    TempDir dir;
    struct Layout {
        const char* name;
        int cw, ch;
    };
    for (const Layout& layout :
         {Layout{"yuv420p", 17, 9}, Layout{"yuv422p", 17, 17}, Layout{"yuv444p", 33, 17}}) {
        SCOPED_TRACE(layout.name);
        const RawClip clip{.cw = layout.cw, .ch = layout.ch};
        const std::string path = dir / (std::string(layout.name) + ".YUV");
        write_bytes(path, clip.bytes());
        FrameSource source(path, {.width = 33, .height = 17, .pixel_format = layout.name});
        EXPECT_EQ(source.frame_count_estimate(), 3);
        EXPECT_DOUBLE_EQ(source.fps(), 25);
        const std::vector<Image> frames = read_all(source);
        ASSERT_EQ(frames.size(), 3u);
        double worst = 0;
        for (int t = 0; t < 3; ++t) {
            ASSERT_EQ(frames[t].width, 33);
            ASSERT_EQ(frames[t].height, 17);
            for (int y = 0; y < 17; ++y) {
                for (int x = 0; x < 33; ++x) {
                    const auto rgb = bt601_rgb(clip.luma(x, y, t), clip.cb(t), clip.cr(t));
                    for (int c = 0; c < 3; ++c) {
                        worst = std::max(worst, std::abs(frames[t].at(c, x, y) - rgb[c]));
                    }
                }
            }
        }
        EXPECT_LE(worst, 1.0 / 255);
    }
}

TEST(FrameSource, raw_gray_is_full_range) {
    TempDir dir;
    const RawClip clip;  // no chroma planes
    const std::string path = dir / "grey.yuv";
    write_bytes(path, clip.bytes());
    FrameSource source(path, {.width = 33, .height = 17, .pixel_format = "gray"});
    const std::vector<Image> frames = read_all(source);
    ASSERT_EQ(frames.size(), 3u);
    for (int c = 0; c < 3; ++c) {
        EXPECT_FLOAT_EQ(frames[2].at(c, 4, 5), static_cast<float>(clip.luma(4, 5, 2)) / 255);
    }
}

TEST(FrameSource, raw_yuv_reads_whole_frames_and_reports_the_rest) {
    TempDir dir;
    const RawClip clip{.cw = 17, .ch = 9};
    std::vector<uint8_t> bytes = clip.bytes();
    bytes.resize(bytes.size() + 100, 128);
    const std::string path = dir / "clip.yuv";
    write_bytes(path, bytes);
    FrameSource source(path, {.width = 33, .height = 17});
    EXPECT_EQ(source.frame_count_estimate(), 3);
    EXPECT_EQ(source.trailing_bytes(), 100);
    EXPECT_EQ(read_all(source).size(), 3u);

    write_bytes(path, std::vector<uint8_t>(100, 128));  // less than one frame (867 bytes)
    EXPECT_EQ(error_of(path, {.width = 33, .height = 17}),
              path + ": 100 trailing bytes are not a whole frame of 33x17 yuv420p");
}

TEST(FrameSource, raw_yuv_needs_a_size_and_a_known_format) {
    TempDir dir;
    const std::string path = dir / "clip.yuv";
    write_bytes(path, RawClip{.cw = 17, .ch = 9}.bytes());
    EXPECT_NE(error_of(path).find("needs its frame size"), std::string::npos) << error_of(path);
    EXPECT_NE(error_of(path, {.width = 33}).find("needs its frame size"), std::string::npos);
    const std::string nv12 = error_of(path, {.width = 33, .height = 17, .pixel_format = "nv12"});
    EXPECT_NE(nv12.find("pixel format 'nv12'"), std::string::npos) << nv12;
    const std::string big = error_of(path, {.width = 33, .height = 17, .max_pixels = 500});
    EXPECT_NE(big.find("exceed the limit"), std::string::npos) << big;
    write_bytes(dir / "empty.yuv", {});
    EXPECT_EQ(error_of(dir / "empty.yuv", {.width = 33, .height = 17}),
              dir / "empty.yuv" + ": empty file");
}

TEST(FrameSource, missing_empty_and_unreadable_inputs_throw) {
    TempDir dir;
    EXPECT_EQ(error_of(dir / "missing.mkv"), dir / "missing.mkv" + ": no such file or folder");
    fs::create_directories(dir / "empty");
    EXPECT_NE(error_of(dir / "empty").find("no image files"), std::string::npos);
    fs::create_directories(dir / "text");
    std::ofstream(dir / "text/notes.txt") << "not a frame";
    EXPECT_NE(error_of(dir / "text").find("no image files"), std::string::npos);
    write_bytes(dir / "empty.mkv", {});
    EXPECT_NE(error_of(dir / "empty.mkv").find("empty file"), std::string::npos);
    write_bytes(dir / "noise.mp4", std::vector<uint8_t>(4096, 0x5a));
    EXPECT_NE(error_of(dir / "noise.mp4").find(dir / "noise.mp4"), std::string::npos);
    // A valid YUV4MPEG header and no frame: a clip of zero frames.
    const std::string header = "YUV4MPEG2 W8 H8 F25:1 Ip A1:1 C420jpeg\n";
    write_bytes(dir / "none.y4m", std::vector<uint8_t>(header.begin(), header.end()));
    EXPECT_NE(error_of(dir / "none.y4m").find("no decodable video frame"), std::string::npos)
        << error_of(dir / "none.y4m");
    // A damaged image in a folder: the error names it.
    fs::create_directories(dir / "broken");
    write_image(uniform(8, 6, 3, 0), dir / "broken/f1.png");
    write_bytes(dir / "broken/f2.png", {0x89, 'P', 'N', 'G', 1, 2, 3});
    EXPECT_NE(error_of(dir / "broken").find(dir / "broken/f2.png"), std::string::npos)
        << error_of(dir / "broken");
    EXPECT_NE(error_of(dir / "clip.yuv", {.fps = -1}).find("fps"), std::string::npos);
}

}  // namespace
}  // namespace tesswave
