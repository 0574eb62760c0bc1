#include "core/io/image_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "temp_dir.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

struct TempDir : testing::TempDir {
    TempDir() : testing::TempDir("image_io") {}
};

Image pattern(int w, int h, int channels, SampleFormat format) {
    Image image = make_image(w, h, channels, format);
    for (int c = 0; c < channels; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                image.at(c, x, y) = static_cast<float>((x * 7 + y * 3 + c * 50) % 256) / 255.0f;
            }
        }
    }
    return image;
}

// The largest difference, or for lossy files (JPEG) the mean one.
double difference(const Image& a, const Image& b, bool mean) {
    double d = 0, sum = 0;
    size_t n = 0;
    for (int c = 0; c < a.channels(); ++c) {
        for (size_t i = 0; i < a.planes[c].size(); ++i, ++n) {
            const double e = std::abs(a.planes[c][i] - b.planes[c][i]);
            d = std::max(d, e);
            sum += e;
        }
    }
    return mean ? sum / n : d;
}

TEST(ImageIo, round_trips_keep_size_channels_and_bit_depth) {
    TempDir dir;
    struct Case {
        const char* name;
        int channels;
        SampleFormat format;
        double tolerance;
    };
    const Case cases[] = {
        {"grey.png", 1, SampleFormat::u8, 0},   {"rgb.png", 3, SampleFormat::u8, 0},
        {"rgba.png", 4, SampleFormat::u8, 0},   {"rgb16.png", 3, SampleFormat::u16, 0},
        {"rgb16.tif", 3, SampleFormat::u16, 0}, {"rgb.exr", 3, SampleFormat::f32, 1e-3},
        {"grey.pgm", 1, SampleFormat::u8, 0},   {"rgb.ppm", 3, SampleFormat::u8, 0},
        {"rgb.jpg", 3, SampleFormat::u8, 0.05},  // mean error: JPEG is lossy
    };
    for (const Case& k : cases) {
        SCOPED_TRACE(k.name);
        const Image image = pattern(37, 23, k.channels, k.format);
        write_image(image, dir / k.name);
        const Image back = read_image(dir / k.name);
        ASSERT_EQ(back.width, 37);
        ASSERT_EQ(back.height, 23);
        ASSERT_EQ(back.channels(), k.channels);
        EXPECT_EQ(back.format, k.format);
        const bool lossy = std::string(k.name).ends_with(".jpg");
        EXPECT_LE(difference(image, back, lossy), k.tolerance + 1e-6);
    }
}

TEST(ImageIo, bad_files_are_one_error_naming_the_file) {
    TempDir dir;
    EXPECT_EQ(
        testing::error_of([&] { read_image(dir / "missing.png"); }).rfind(dir / "missing.png", 0),
        0u);
    write_image(pattern(8, 8, 3, SampleFormat::u8), dir / "ok.png");
    const std::string bytes = [&] {
        std::ifstream in(dir / "ok.png", std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    }();
    std::ofstream(dir / "cut.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
    EXPECT_THROW(read_image(dir / "cut.png"), Error);
    std::ofstream(dir / "text.png") << "not an image";
    EXPECT_THROW(read_image(dir / "text.png"), Error);
    EXPECT_THROW(read_image(dir / "ok.png", {.max_pixels = 10}), Error);  // 64 > 10 pixels
    EXPECT_THROW(write_image(Image{}, dir / "empty.png"), Error);
    EXPECT_FALSE(fs::exists(dir / "empty.png"));
}

// An image bomb: a 1 KB PNG whose header claims 8000x8000 (64 M pixels, 1 GB as floats) is
// refused from its header, as is one over the 2^26-pixel limit; a real 8000x8000 one-colour PNG
// is larger than the 63 KB this asks for. NaN pixels are read as 0 and counted;
// an image with nothing but NaN is refused.
// A 16x16 RGB PNG whose header claims w x h pixels (its data still holds 16x16): written to
// `dir`, its path returned.
std::string png_claiming(const fs::path& dir, uint32_t w, uint32_t h) {
    const std::string small = (dir / "small.png").string();
    write_image(pattern(16, 16, 3, SampleFormat::u8), small);
    std::ifstream in(small, std::ios::binary);
    std::vector<uint8_t> out(std::istreambuf_iterator<char>(in), {});
    if (out.size() <= 33) throw Error("the PNG writer wrote no IHDR");
    // IHDR: length (4), type (4), width and height (big-endian), ..., CRC over type and data.
    for (int k = 0; k < 4; ++k) {
        out[16 + k] = static_cast<uint8_t>(w >> (24 - 8 * k));
        out[20 + k] = static_cast<uint8_t>(h >> (24 - 8 * k));
    }
    const uint32_t crc = crc32(std::span<const uint8_t>(out).subspan(12, 17));
    for (int k = 0; k < 4; ++k) out[29 + k] = static_cast<uint8_t>(crc >> (24 - 8 * k));
    const std::string path = (dir / str("claims_", w, "x", h, ".png")).string();
    std::ofstream(path, std::ios::binary)
        .write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
    return path;
}

TEST(ImageIo, a_small_file_may_not_declare_a_huge_image) {
    const TempDir dir;
    const std::string small = (dir.path / "small.png").string();
    write_image(pattern(16, 16, 3, SampleFormat::u8), small);
    auto claim = [&](uint32_t w, uint32_t h) { return png_claiming(dir.path, w, h); };
    EXPECT_NE(testing::error_of([&] { read_image(claim(8000, 8000)); }).find("may claim"),
              std::string::npos);
    EXPECT_NE(testing::error_of([&] { read_image(claim(20000, 20000)); }).find("exceeds the limit"),
              std::string::npos);
    EXPECT_NO_THROW(read_image(small));

    Image nan = make_image(4, 4, 1, SampleFormat::f32);
    nan.planes[0][3] = std::numeric_limits<float>::quiet_NaN();
    nan.planes[0][5] = std::numeric_limits<float>::infinity();
    const std::string exr = (dir.path / "nan.exr").string();
    write_image(nan, exr);
    ImageNotes notes;
    const Image back = read_image(exr, {}, &notes);
    int64_t stored = 0;  // what the EXR kept non-finite (the writer may clamp infinities)
    for (const int i : {3, 5}) {
        stored += back.planes[0][i] == 0.0f;
    }
    EXPECT_GE(notes.non_finite, 1);
    EXPECT_EQ(notes.non_finite, stored);
    EXPECT_EQ(back.planes[0][3], 0.0f);  // the NaN

    Image all_nan = make_image(4, 4, 3, SampleFormat::f32);
    for (auto& plane : all_nan.planes) {
        std::fill(plane.begin(), plane.end(), std::numeric_limits<float>::quiet_NaN());
    }
    const std::string all_exr = (dir.path / "all_nan.exr").string();
    write_image(all_nan, all_exr);
    const std::string why = testing::error_of([&] { read_image(all_exr); });
    EXPECT_NE(why.find("all_nan.exr: every value is NaN or infinite"), std::string::npos) << why;
}

// The caller's own size check (the still codec's: a mesh of too many samples) sees the declared
// size and channels and refuses before any pixel is decoded: this file's data holds 16x16 pixels
// for a claim of 2000x2000, so a decode would fail with another message.
TEST(ImageIo, the_callers_size_check_runs_before_the_pixels_are_decoded) {
    const TempDir dir;
    const std::string claimed = png_claiming(dir.path, 2000, 2000);
    std::array<int, 3> seen{};
    ImageLimits limits;
    limits.check_size = [&](int width, int height, int channels) {
        seen = {width, height, channels};
        throw Error("too many samples");
    };
    EXPECT_EQ(testing::error_of([&] { read_image(claimed, limits); }),
              claimed + ": too many samples");
    EXPECT_EQ(seen, (std::array<int, 3>{2000, 2000, 3}));
    limits.check_size = [](int, int, int) {};
    EXPECT_NE(testing::error_of([&] { read_image(claimed, limits); }).find("cannot decode"),
              std::string::npos);
}

}  // namespace
}  // namespace tesswave
