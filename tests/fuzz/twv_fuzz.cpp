// libFuzzer target: arbitrary bytes as a .twv clip through VideoDecoder with small limits. Every
// chunk's CRC is first recomputed (and the header's), so that mutations reach the group, frame,
// motion and index parsers instead of stopping at a CRC mismatch; the input is then decoded as
// given and with the CRCs repaired. tesswave::Error from the constructor (one line) is the only
// acceptable failure there; later damage must stop read() with a message, and decoded frames
// must have the header's size.
#include <cstdint>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "core/codec/byte_io.h"
#include "core/math/error.h"
#include "fuzz_check.h"
#include "video/dec_video.h"
#include "video/twv_format.h"

namespace {

using namespace tesswave;

constexpr video::TwvLimits kLimits{
    .max_pixels = 1 << 15, .max_samples = 1 << 16, .max_chunk_bytes = 1 << 20, .max_frames = 64};

[[noreturn]] void fail(const char* what) { fuzz::fail("twv_fuzz", what); }

// Reads a varint at `at`; false past the end or beyond 10 bytes.
bool varint(std::span<const uint8_t> b, size_t& at, uint64_t& value) {
    value = 0;
    for (int i = 0; i < 10 && at < b.size(); ++i) {
        const uint8_t byte = b[at++];
        value |= uint64_t{byte & 0x7Fu} << (7 * i);
        if (!(byte & 0x80)) return true;
    }
    return false;
}

void put_crc(std::vector<uint8_t>& b, size_t from, size_t at) {
    const uint32_t crc = crc32(std::span<const uint8_t>(b).subspan(from, at - from));
    for (int k = 0; k < 4; ++k) b[at + k] = static_cast<uint8_t>(crc >> (8 * k));
}

// The file with every CRC recomputed where the structure can be followed.
std::vector<uint8_t> repaired(std::span<const uint8_t> file) {
    std::vector<uint8_t> b(file.begin(), file.end());
    size_t at = 5;  // magic and version
    uint64_t v = 0;
    for (int i = 0; i < 4; ++i) {
        if (!varint(b, at, v)) return b;
    }
    at += 2;  // channels, bit depth
    if (at + 4 > b.size()) return b;
    put_crc(b, 0, at);
    at += 4;
    while (at < b.size()) {
        const size_t start = at++;
        if (!varint(b, at, v) || v > b.size() || at + v + 4 > b.size()) return b;
        at += v;
        put_crc(b, start, at);
        at += 4;
    }
    return b;
}

void decode(const std::vector<uint8_t>& bytes) {
    try {
        video::VideoDecoder decoder(memory_source(bytes), "fuzz.twv", kLimits);
        Image frame;
        int frames = 0;
        while (frames < 64 && decoder.read(frame)) {
            if (frame.width != decoder.header().width || frame.height != decoder.header().height) {
                fail("a decoded frame does not have the header's size");
            }
            ++frames;
        }
        if (!decoder.damage().empty() && decoder.damage().find('\n') != std::string::npos) {
            fail("a damage message is not one line");
        }
        if (frames > 0) decoder.seek(frames / 2);
    } catch (const Error& e) {
        fuzz::check_message("twv_fuzz", e);
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::span<const uint8_t> file(data, size);
    decode(std::vector<uint8_t>(file.begin(), file.end()));
    decode(repaired(file));
    return 0;
}
