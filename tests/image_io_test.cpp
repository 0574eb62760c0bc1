#include "core/io/image_io.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/math/error.h"
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

}  // namespace
}  // namespace tesswave
