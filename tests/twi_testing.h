// Shared by the .twi bad-input suites (twi_robustness_test.cpp: damaged and foreign files;
// twi_header_test.cpp: crafted headers): one small file of each class, CRC patching, and the
// check that decoding fails with a one-line Error naming the problem.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/codec/byte_io.h"
#include "core/codec/still_codec.h"
#include "core/codec/twi_format.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "robustness.h"
#include "samples/sample_images.h"
#include "samples/sample_meshes.h"

namespace tesswave::testing {

using Bytes = std::vector<uint8_t>;

// Limits for headers that claim more than a test should decode: small enough that a decoder which
// believed them would still finish quickly, and far below what the absurd headers claim.
constexpr TwiLimits kSmall{
    .max_pixels = 1 << 16, .max_samples = 1 << 16, .max_mesh_vertices = 4096};

// The procedural scene quantized to 8 bits, like a file's pixels.
inline Image scene(int w, int h) {
    Image image = samples::scene_image(w, h);
    for (auto& plane : image.planes) {
        for (float& v : plane) v = std::round(std::clamp(v, 0.0f, 1.0f) * 255.0f) / 255.0f;
    }
    return image;
}

// One small file of each class.
struct Coded {
    std::string name;
    StillResult result;
};

inline const std::vector<Coded>& coded_files() {
    static const std::vector<Coded> files = [] {
        const Image small = scene(24, 20), wide = scene(40, 30);
        const Mesh paper = samples::paper_t0(40, 30);
        const auto grid53 = TwiTransform::grid53, grid97 = TwiTransform::grid97;
        std::vector<Coded> out;
        auto add = [&](std::string name, const Image& image, const StillOptions& o) {
            out.push_back({std::move(name), compress_image(image, o)});
        };
        add("grid mesh, lossy", small, {.max_bytes = 300});
        add("grid mesh, lifted wavelet, lossy", small,
            {.max_bytes = 300, .mesh_wavelet = MeshWavelet::lifted});
        add("grid mesh, lossless", small, {.lossless = true});
        add("explicit mesh, lossy", wide, {.max_bytes = 400, .mesh = paper, .levels = 2});
        add("explicit mesh, lossless", wide, {.lossless = true, .mesh = paper, .levels = 2});
        add("aligned mesh, lossy", small, {.max_bytes = 300, .aligned = true});
        add("aligned mesh, lossless", small, {.lossless = true, .aligned = true});
        add("grid 5/3, lossy", small, {.transform = grid53, .max_bytes = 300});
        add("grid 5/3, lossless", small, {.transform = grid53, .lossless = true});
        add("grid 9/7, lossy", wide, {.transform = grid97, .max_bytes = 400});
        return out;
    }();
    return files;
}

inline const Coded& file_of(std::string_view name) {
    for (const Coded& c : coded_files()) {
        if (c.name == name) return c;
    }
    throw Error(str("no test file ", name));
}

// What decoding one input did, counted; the first few failures are reported with the input's

// The last 4 bytes of a header replaced by the CRC of the bytes before them.
inline Bytes with_crc(const Bytes& header) {
    const std::span<const uint8_t> body = std::span(header).first(header.size() - 4);
    ByteWriter w;
    w.bytes(body);
    w.u32(crc32(body));
    return w.data();
}

inline Bytes varint_bytes(uint64_t v) {
    ByteWriter w;
    w.varint(v);
    return w.data();
}

inline std::string message_of(std::span<const uint8_t> file,
                              const StillDecodeOptions& options = {}) {
    const Outcome o = outcome_of([&] { decompress_image(file, "t.twi", options); });
    if (o.kind == Outcome::error) return o.what;
    return o.kind == Outcome::returned ? "(decoded)" : "(other exception) " + o.what;
}

// Expects decoding to fail with an Error whose message contains `word`.
inline void expect_refused(std::span<const uint8_t> file, std::string_view word,
                           const StillDecodeOptions& options = {}) {
    const std::string message = message_of(file, options);
    EXPECT_TRUE(message.rfind("t.twi: ", 0) == 0 && message.find(word) != std::string::npos &&
                message.find('\n') == std::string::npos)
        << "expected an Error about \"" << word << "\", got: " << message;
}

// ---- 1. Single-byte damage ----

// Every header byte is tried; in the stream, every byte at -O3 (the campaigns below take about
// 3 s) and every 4th under AddressSanitizer, where each decode costs about 20 ms with the slow
// unwinder run.sh asks for.

}  // namespace tesswave::testing
