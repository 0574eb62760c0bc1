#include "core/math/metrics.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/io/image_io.h"
#include "core/math/error.h"
#include "temp_dir.h"

namespace tesswave {
namespace {

namespace fs = std::filesystem;

const double kInf = std::numeric_limits<double>::infinity();

// Uniform in [0, 1) from the engine's bits alone, so the images are the same on every library.
float uniform01(std::mt19937& rng) { return static_cast<float>(rng() >> 8) * 0x1p-24f; }

// Smooth gradients, a ripple, a disc and a bar, different in each channel so that a channel
// mix-up shows. Values are not on the 8-bit grid, so quantization is exercised too.
Image scene(int width, int height, int channels, SampleFormat format = SampleFormat::u8) {
    Image image = make_image(width, height, channels, format);
    for (int c = 0; c < channels; ++c) {
        for (int y = 0; y < height; ++y) {
            for (int x = 0; x < width; ++x) {
                const float u = (x + 0.5f) / width, v = (y + 0.5f) / height;
                float value = 0.1f +
                              0.6f * (c == 0   ? u
                                      : c == 1 ? v
                                               : 0.5f * (u + v)) +
                              0.07f * std::sin(21.0f * u + 13.0f * v + 2.0f * c);
                if ((u - 0.4f) * (u - 0.4f) + (v - 0.5f) * (v - 0.5f) < 0.06f) {
                    value = 0.95f - 0.2f * c;
                }
                if (u > 0.7f && u < 0.8f) value = 0.05f + 0.1f * c;
                image.at(c, x, y) = value;
            }
        }
    }
    return image;
}

// Pushes some values outside [0, 1] (the disc is at 0.95), so clamping is exercised.
Image noisy(Image image, float amplitude, unsigned seed) {
    std::mt19937 rng(seed);
    for (auto& plane : image.planes) {
        for (float& value : plane) value += amplitude * (uniform01(rng) + uniform01(rng) - 1.0f);
    }
    return image;
}

Image blurred(const Image& image) {
    Image out = image;
    for (int c = 0; c < image.channels(); ++c) {
        for (int y = 0; y < image.height; ++y) {
            for (int x = 0; x < image.width; ++x) {
                float sum = 0.0f;
                for (int dy = -1; dy <= 1; ++dy) {
                    for (int dx = -1; dx <= 1; ++dx) {
                        sum += image.at(c, std::clamp(x + dx, 0, image.width - 1),
                                        std::clamp(y + dy, 0, image.height - 1));
                    }
                }
                out.at(c, x, y) = sum / 9.0f;
            }
        }
    }
    return out;
}

// JPEG-like: each 8x8 block pulled towards its mean, then posterized.
Image blocky(const Image& image) {
    Image out = image;
    for (int c = 0; c < image.channels(); ++c) {
        for (int by = 0; by < image.height; by += 8) {
            for (int bx = 0; bx < image.width; bx += 8) {
                const int x1 = std::min(bx + 8, image.width), y1 = std::min(by + 8, image.height);
                float mean = 0.0f;
                for (int y = by; y < y1; ++y)
                    for (int x = bx; x < x1; ++x) mean += image.at(c, x, y);
                mean /= static_cast<float>((x1 - bx) * (y1 - by));
                for (int y = by; y < y1; ++y) {
                    for (int x = bx; x < x1; ++x) {
                        const float v = 0.6f * mean + 0.4f * image.at(c, x, y);
                        out.at(c, x, y) = std::round(v * 20.0f) / 20.0f;
                    }
                }
            }
        }
    }
    return out;
}

// ---------------------------------------------------------------------------------------------
// Running the ffmpeg CLI

struct CommandResult {
    int status = -1;
    std::string output;  // stdout and stderr together
};

CommandResult run(const std::string& command) {
    CommandResult result;
    FILE* pipe = popen((command + " 2>&1").c_str(), "r");
    if (!pipe) return result;
    char buffer[4096];
    size_t n = 0;
    while ((n = fread(buffer, 1, sizeof buffer, pipe)) > 0) result.output.append(buffer, n);
    result.status = pclose(pipe);
    return result;
}

bool ffmpeg_available() { return run("ffmpeg -nostdin -hide_banner -version").status == 0; }

// The key:value fields of ffmpeg's summary line that starts with `tag` ("PSNR" or "SSIM"),
// e.g. {"r", "31.123456"}, {"average", "30.5"}; values stay text so that their precision shows.
std::map<std::string, std::string> ffmpeg_summary(const std::string& filter, const fs::path& test,
                                                  const fs::path& reference,
                                                  const std::string& tag) {
    const CommandResult result =
        run("ffmpeg -nostdin -hide_banner -nostats -i '" + test.string() + "' -i '" +
            reference.string() + "' -lavfi " + filter + " -f null -");
    std::map<std::string, std::string> fields;
    const size_t start = result.output.find("] " + tag + " ");
    if (result.status != 0 || start == std::string::npos) {
        ADD_FAILURE() << "ffmpeg " << filter << " printed no " << tag << " line:\n"
                      << result.output;
        return fields;
    }
    const size_t end = result.output.find('\n', start);
    std::string line = result.output.substr(start + tag.size() + 3, end - start - tag.size() - 3);
    size_t pos = 0;
    while (pos < line.size()) {
        size_t next = line.find(' ', pos);
        if (next == std::string::npos) next = line.size();
        const std::string token = line.substr(pos, next - pos);
        const size_t colon = token.find(':');
        if (colon != std::string::npos) fields[token.substr(0, colon)] = token.substr(colon + 1);
        pos = next + 1;
    }
    return fields;
}

// Half a unit in the last printed digit: FFmpeg 5.1 prints 6 decimals, older ones 2.
double print_precision(const std::string& text) {
    const size_t dot = text.find('.');
    if (dot == std::string::npos) return 0.5;
    return 0.5 * std::pow(10.0, -static_cast<double>(text.size() - dot - 1));
}

// `ours` matches FFmpeg's printed `text` to its precision plus `slack`; both may be inf.
void expect_matches(double ours, const std::string& text, double slack, const std::string& what) {
    const double theirs = std::strtod(text.c_str(), nullptr);
    if (std::isinf(theirs) || std::isinf(ours)) {
        EXPECT_EQ(ours, theirs) << what << ": ffmpeg printed " << text;
        return;
    }
    EXPECT_NEAR(ours, theirs, print_precision(text) + slack) << what << ": ffmpeg printed " << text;
}

struct TempDir : testing::TempDir {
    TempDir() : testing::TempDir("metrics") {}
};

struct Pair {
    std::string name;
    Image reference;
    Image test;
    int bit_depth = 8;
};

std::vector<Pair> cross_check_pairs() {
    const Image rgb = scene(97, 61, 3);
    const Image rgb_even = scene(128, 96, 3);
    const Image rgb_tall = scene(61, 97, 3);
    const Image grey = scene(97, 61, 1);
    const Image grey_small = scene(37, 22, 1);
    const Image grey16 = scene(50, 37, 1, SampleFormat::u16);
    const Image rgb16 = scene(45, 31, 3, SampleFormat::u16);
    return {
        {"rgb 97x61 noise", rgb, noisy(rgb, 0.08f, 1)},
        {"rgb 128x96 blur", rgb_even, blurred(rgb_even)},
        {"rgb 61x97 blocky", rgb_tall, blocky(rgb_tall)},
        {"rgb 97x61 identical", rgb, rgb},
        {"grey 97x61 blur+noise", grey, noisy(blurred(grey), 0.03f, 2)},
        {"grey 37x22 blocky", grey_small, blocky(grey_small)},
        {"grey16 50x37 noise", grey16, noisy(grey16, 0.01f, 3), 16},
        {"rgb16 45x31 blur", rgb16, blurred(rgb16), 16},
    };
}

TEST(Metrics, identical_images_give_infinite_psnr_and_unit_ssim) {
    const Image image = scene(33, 19, 3);
    const Psnr p = psnr(image, image);
    EXPECT_EQ(p.all, kInf);
    EXPECT_EQ(p.mse_all, 0.0);
    ASSERT_EQ(p.per_channel.size(), 3u);
    for (double v : p.per_channel) EXPECT_EQ(v, kInf);
    const Ssim s = ssim(image, image);
    EXPECT_EQ(s.all, 1.0);
    ASSERT_EQ(s.per_channel.size(), 3u);
    for (double v : s.per_channel) EXPECT_EQ(v, 1.0);
}

TEST(Metrics, constant_offset_gives_exact_psnr) {
    for (int bit_depth : {8, 16}) {
        const int peak = (1 << bit_depth) - 1;
        for (int d : {1, 3, 17}) {
            Image reference = make_image(23, 11, 2), test = make_image(23, 11, 2);
            for (int c = 0; c < 2; ++c) {
                for (size_t i = 0; i < reference.planes[c].size(); ++i) {
                    const int level = static_cast<int>((i * 7 + c * 5) % (peak + 1 - d));
                    reference.planes[c][i] = static_cast<float>(level) / peak;
                    test.planes[c][i] = static_cast<float>(level + d) / peak;
                }
            }
            const Psnr p = psnr(reference, test, {.bit_depth = bit_depth});
            const double expected = 20.0 * std::log10(static_cast<double>(peak) / d);
            EXPECT_NEAR(p.all, expected, 1e-12) << bit_depth << " bits, d = " << d;
            EXPECT_EQ(p.mse_all, static_cast<double>(d) * d);
            for (double v : p.per_channel) EXPECT_NEAR(v, expected, 1e-12);
        }
    }
}

TEST(Metrics, values_are_quantized_and_clamped_first) {
    Image reference = make_image(8, 8, 1), test = make_image(8, 8, 1);
    for (size_t i = 0; i < 64; ++i) {
        reference.planes[0][i] = i % 2 ? 1.0f : 0.0f;
        test.planes[0][i] = i % 2 ? 1.7f : -0.3f + 0.4f / 255;  // clamp to 255; round to 0
    }
    EXPECT_EQ(psnr(reference, test).all, kInf);
    EXPECT_EQ(ssim(reference, test).all, 1.0);
    test.planes[0][5] = 254.6f / 255;  // rounds to 255
    EXPECT_EQ(psnr(reference, test).all, kInf);
    test.planes[0][5] = 254.4f / 255;  // rounds to 254
    EXPECT_NEAR(psnr(reference, test).mse_all, 1.0 / 64, 1e-15);
}

// The quantizer rounds as roundf(v * peak) does (half away from zero), clamped to [0, peak], NaN
// to 0: checked through the squared errors against a zero image, on the values next to every
// half step (v * peak = n + 1/2 and its neighbouring floats), both ends, the infinities and NaN.
TEST(Metrics, quantization_rounds_as_roundf_does) {
    for (const int depth : {8, 10, 16}) {
        const int32_t peak = (int32_t{1} << depth) - 1;
        const float scale = static_cast<float>(peak);
        std::vector<float> values = {0.0f,
                                     -0.0f,
                                     1.0f,
                                     2.0f,
                                     -1.0f,
                                     std::numeric_limits<float>::infinity(),
                                     -std::numeric_limits<float>::infinity(),
                                     std::numeric_limits<float>::quiet_NaN()};
        for (int32_t n = -2; n <= peak + 1; ++n) {
            const float half = (static_cast<float>(n) + 0.5f) / scale;
            float v = std::nextafter(std::nextafter(half, -1.0f), -1.0f);
            for (int k = 0; k < 5; ++k, v = std::nextafter(v, 2.0f)) values.push_back(v);
        }
        const auto expected = [&](float v) -> double {
            const float s = std::round(v * scale);
            if (!(s > 0.0f)) return 0;
            return s >= scale ? peak : s;
        };
        const int w = 64, h = static_cast<int>((values.size() + w - 1) / w);
        Image zero = make_image(w, h, 1), test = make_image(w, h, 1);
        double sum = 0;
        for (size_t i = 0; i < values.size(); ++i) {
            test.planes[0][i] = values[i];
            sum += expected(values[i]) * expected(values[i]);
        }
        EXPECT_EQ(psnr(zero, test, {.bit_depth = depth}).mse_all, sum / (w * h)) << depth;
    }
}

// One 8x8 window of constants p and q: no variance, so SSIM = (2 pq 64^2 + C1) / ((p^2 + q^2)
// 64^2 + C1) with C1 = 416, and samples outside the last whole 4x4 block do not count.
TEST(Metrics, ssim_of_one_window_uses_ffmpeg_constant) {
    Image reference = make_image(11, 9, 1), test = make_image(11, 9, 1);
    for (float& v : reference.planes[0]) v = 100.0f / 255;
    for (float& v : test.planes[0]) v = 104.0f / 255;
    const double expected =
        (2.0 * 100 * 104 * 4096 + 416) / ((100.0 * 100 + 104 * 104) * 4096 + 416);
    EXPECT_DOUBLE_EQ(ssim(reference, test).all, expected);
    for (int y = 0; y < 9; ++y) test.at(0, 10, y) = 0.0f;  // column 10 is outside the blocks
    for (int x = 0; x < 11; ++x) test.at(0, x, 8) = 1.0f;  // row 8 too
    EXPECT_DOUBLE_EQ(ssim(reference, test).all, expected);
    EXPECT_LT(psnr(reference, test).all, 30.0);  // while PSNR sees every sample
}

TEST(Metrics, ssim_is_symmetric_and_orders_degradations) {
    const Image reference = scene(64, 48, 3);
    const Image light = noisy(reference, 0.02f, 7), heavy = noisy(reference, 0.2f, 7);
    EXPECT_DOUBLE_EQ(ssim(reference, heavy).all, ssim(heavy, reference).all);
    EXPECT_GT(ssim(reference, light).all, ssim(reference, heavy).all);
    EXPECT_GT(psnr(reference, light).all, psnr(reference, heavy).all);
}

TEST(Metrics, rejects_mismatched_or_unusable_images) {
    const Image a = scene(20, 10, 3);
    try {
        psnr(a, scene(10, 20, 3));
        FAIL() << "no error for different sizes";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("20x10"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("10x20"), std::string::npos) << e.what();
    }
    EXPECT_THROW(ssim(a, scene(20, 10, 1)), Error);
    EXPECT_THROW(psnr(a, a, {.bit_depth = 0}), Error);
    EXPECT_THROW(psnr(a, a, {.bit_depth = 17}), Error);
    EXPECT_THROW(psnr(Image{}, Image{}), Error);
    EXPECT_THROW(ssim(scene(7, 30, 1), scene(7, 30, 1)), Error);
    Image broken = a;
    broken.planes[1].pop_back();
    EXPECT_THROW(psnr(a, broken), Error);
}

// FFmpeg reads the PNGs as rgb24 (or gray8, rgb48be, gray16be) and both filters negotiate gbrp
// (gbrp16, gray16): planar but still RGB, so FFmpeg's r/g/b are our channels 0/1/2.
TEST(Metrics, matches_ffmpeg_psnr_and_ssim_filters) {
    ASSERT_TRUE(ffmpeg_available())
        << "the ffmpeg command is not on PATH; this test compares against it (apt install ffmpeg)";
    const TempDir dir;
    for (const Pair& pair : cross_check_pairs()) {
        SCOPED_TRACE(pair.name);
        const fs::path ref_path = dir.path / "reference.png", test_path = dir.path / "test.png";
        write_image(pair.reference, ref_path.string());
        write_image(pair.test, test_path.string());
        const QualityOptions options{.bit_depth = pair.bit_depth};
        const bool rgb = pair.reference.channels() == 3;

        const Psnr p = psnr(pair.reference, pair.test, options);
        auto fields = ffmpeg_summary("psnr", test_path, ref_path, "PSNR");
        expect_matches(p.all, fields["average"], 1e-9, "psnr all");
        for (int c = 0; c < pair.reference.channels(); ++c) {
            const std::string key = rgb ? std::string(1, "rgb"[c]) : "y";
            expect_matches(p.per_channel[c], fields[key], 1e-9, "psnr " + key);
        }

        // FFmpeg rounds each window's factors to float; that moves a channel by ~1e-7.
        const Ssim s = ssim(pair.reference, pair.test, options);
        fields = ffmpeg_summary("ssim", test_path, ref_path, "SSIM");
        expect_matches(s.all, fields["All"], 2e-6, "ssim all");
        for (int c = 0; c < pair.reference.channels(); ++c) {
            const std::string key = rgb ? std::string(1, "RGB"[c]) : "Y";
            expect_matches(s.per_channel[c], fields[key], 2e-6, "ssim " + key);
        }
    }
}

}  // namespace
}  // namespace tesswave
