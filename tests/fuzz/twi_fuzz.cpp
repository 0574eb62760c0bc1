// libFuzzer target: arbitrary bytes as a .twi file through decompress_image with small limits.
// tesswave::Error (one line) is the only acceptable failure; a file that decodes must give an
// image of its header's size, and so must a cut of it halfway through the stream (any prefix that
// holds the header decodes). A mutated header almost always fails its CRC, which would keep the
// fuzzer away from the fields behind it: when the CRC is the only problem, the input is also
// decoded with the CRC made to match. Build with clang's -fsanitize=fuzzer, or with
// fuzz_driver.cpp to replay inputs with any compiler.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <span>
#include <string_view>
#include <vector>

#include "core/codec/byte_io.h"
#include "core/codec/still_codec.h"
#include "core/codec/twi_format.h"
#include "core/math/error.h"
#include "fuzz_check.h"

namespace {

using namespace tesswave;

// Small enough that every input decodes in milliseconds, large enough for the seed files.
constexpr TwiLimits kLimits{
    .max_pixels = 1 << 14, .max_samples = 1 << 15, .max_mesh_vertices = 1 << 12};

[[noreturn]] void fail(const char* what) { fuzz::fail("twi_fuzz", what); }
void check_message(const Error& e) { fuzz::check_message("twi_fuzz", e); }

void check_size(const Image& image, const TwiHeader& h) {
    if (image.width != h.width || image.height != h.height || image.channels() != h.channels) {
        fail("the decoded image does not have the header's size");
    }
}

// Decodes a file whose header reads, whole and cut halfway through its stream.
void decode(std::span<const uint8_t> file, const TwiHeader& header) {
    try {
        check_size(decompress_image(file, "fuzz.twi", {.limits = kLimits}), header);
        const size_t cut = header.header_bytes + (file.size() - header.header_bytes) / 2;
        check_size(decompress_image(file, "fuzz.twi", {.max_bytes = cut, .limits = kLimits}),
                   header);
    } catch (const Error& e) {
        check_message(e);
        fail("a file whose header reads did not decode");
    }
}

// The file with the CRC at bytes [at, at + 4) recomputed over the bytes before it, for the first
// `at` whose header then reads (the parse reaches the CRC at one place only). Headers are short;
// positions past 1024 are not tried.
std::optional<std::pair<std::vector<uint8_t>, TwiHeader>> with_matching_crc(
    std::span<const uint8_t> file) {
    std::vector<uint8_t> fixed(file.begin(), file.end());
    for (size_t at = 4; at + 4 <= std::min<size_t>(file.size(), 1024); ++at) {
        std::copy(file.begin(), file.end(), fixed.begin());
        const uint32_t crc = crc32(file.first(at));
        for (int k = 0; k < 4; ++k) fixed[at + k] = static_cast<uint8_t>(crc >> (8 * k));
        try {
            TwiHeader header = read_twi_header(fixed, "fuzz.twi", kLimits);
            return std::pair{std::move(fixed), std::move(header)};
        } catch (const Error&) {
        }
    }
    return std::nullopt;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::span<const uint8_t> file(data, size);
    try {
        decode(file, read_twi_header(file, "fuzz.twi", kLimits));
        return 0;
    } catch (const Error& e) {
        check_message(e);
        if (std::string_view(e.what()).find("CRC mismatch") == std::string_view::npos) return 0;
    }
    try {
        decompress_image(file, "fuzz.twi", {.limits = kLimits});
        fail("decompress_image accepted a file with a bad header CRC");
    } catch (const Error& e) {
        check_message(e);
    }
    if (auto fixed = with_matching_crc(file)) decode(fixed->first, fixed->second);
    return 0;
}
