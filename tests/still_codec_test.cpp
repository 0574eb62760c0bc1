#include "core/still_codec.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"
#include "core/metrics.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"

namespace tesswave {
namespace {

// The procedural scene with `channels` channels, quantized to 8 bits like a file's pixels (an
// alpha channel is a soft disc).
Image scene(int w, int h, int channels) {
    const Image rgb = samples::scene_image(w, h);
    Image image = make_image(w, h, channels);
    for (int c = 0; c < channels; ++c) {
        for (int y = 0; y < h; ++y) {
            for (int x = 0; x < w; ++x) {
                float v = rgb.at(std::min(c, 2), x, y);
                if (c == 3)
                    v = std::clamp(1.5f - std::hypot(x - w / 2.0f, y - h / 2.0f) / (0.3f * w), 0.0f,
                                   1.0f);
                image.at(c, x, y) = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
            }
        }
    }
    return image;
}

std::vector<int> bytes_of(const Image& image) {
    std::vector<int> out;
    for (const auto& plane : image.planes) {
        for (float v : plane) out.push_back(static_cast<int>(std::lround(v * 255.0f)));
    }
    return out;
}

double quality(const Image& a, const Image& b) { return psnr(a, b).all; }

TEST(StillCodec, lossless_grid_53_round_trip_is_bit_exact) {
    for (int channels : {1, 3, 4}) {
        for (auto [w, h] :
             {std::pair{37, 23}, std::pair{64, 48}, std::pair{1, 9}, std::pair{2, 1}}) {
            SCOPED_TRACE(testing::Message() << channels << " channels, " << w << "x" << h);
            const Image image = scene(w, h, channels);
            const StillResult r =
                compress_image(image, {.transform = TwiTransform::grid53, .lossless = true});
            const Image back = decompress_image(r.file, "test");
            ASSERT_EQ(back.channels(), channels);
            EXPECT_EQ(bytes_of(back), bytes_of(image));
        }
    }
}

TEST(StillCodec, lossless_on_an_aligned_grid_mesh_round_trips_the_image_bit_exactly) {
    for (int channels : {1, 3, 4}) {
        for (auto [w, h] :
             {std::pair{65, 33}, std::pair{33, 49}, std::pair{64, 48}, std::pair{1, 7}}) {
            SCOPED_TRACE(testing::Message() << channels << " channels, " << w << "x" << h);
            const Image image = scene(w, h, channels);
            const StillResult r = compress_image(image, {.lossless = true, .aligned = true});
            EXPECT_EQ(r.header.placement, MeshPlacement::centres);
            EXPECT_EQ(bytes_of(decompress_image(r.file, "test")), bytes_of(image));
        }
    }
}

TEST(StillCodec, lossless_mesh_round_trips_its_samples_bit_exactly) {
    const Image image = scene(61, 47, 3);
    for (const Mesh& mesh :
         {Mesh{}, samples::paper_t0(61, 47), samples::paper_t0_with_features(61, 47)}) {
        const StillResult r = compress_image(image, {.lossless = true, .mesh = mesh, .levels = 3});
        EXPECT_EQ(decode_lossless_samples(r.file), lossless_samples(image, r.header));
    }
}

TEST(StillCodec, byte_budget_is_met_exactly) {
    const Image image = scene(96, 64, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid53, TwiTransform::grid97}) {
        for (int64_t budget : {200, 700, 1500}) {
            const StillResult r = compress_image(image, {.transform = t, .max_bytes = budget});
            EXPECT_EQ(static_cast<int64_t>(r.file.size()), budget);
        }
    }
}

TEST(StillCodec, every_prefix_of_a_small_stream_decodes) {
    const Image image = scene(24, 20, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid97}) {
        for (bool lossless : {false, true}) {
            if (lossless && t == TwiTransform::grid97) continue;
            const StillResult r = compress_image(
                image, {.transform = t, .lossless = lossless, .max_bytes = lossless ? 0 : 600});
            for (size_t n = r.header.header_bytes; n <= r.file.size(); ++n) {
                const Image out = decompress_image(r.file, "prefix", {.max_bytes = n});
                ASSERT_EQ(out.width, 24);
                ASSERT_EQ(out.channels(), 3);
            }
            for (size_t n = 0; n < r.header.header_bytes; ++n) {
                EXPECT_THROW(decompress_image(r.file, "prefix", {.max_bytes = n}), Error);
            }
        }
    }
}

TEST(StillCodec, quality_rises_with_the_bytes_decoded) {
    const Image image = scene(128, 96, 3);
    for (TwiTransform t : {TwiTransform::mesh, TwiTransform::grid53, TwiTransform::grid97}) {
        const StillResult r = compress_image(image, {.transform = t, .max_bytes = 4000});
        double last = 0;
        for (size_t n = r.header.header_bytes + 16;; n = std::min(n * 5 / 4, r.file.size())) {
            const double q = quality(image, decompress_image(r.file, "prefix", {.max_bytes = n}));
            EXPECT_GE(q, last) << n << " bytes";
            last = q;
            if (n == r.file.size()) break;
        }
        EXPECT_EQ(last, r.psnr);
    }
}

}  // namespace
}  // namespace tesswave
