#include "core/codec/byte_io.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <fstream>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

constexpr std::array<uint32_t, 256> make_crc_table() {
    std::array<uint32_t, 256> table{};
    for (uint32_t i = 0; i < 256; ++i) {
        uint32_t c = i;
        for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        table[i] = c;
    }
    return table;
}
constexpr std::array<uint32_t, 256> kCrcTable = make_crc_table();

}  // namespace

uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc) {
    crc = ~crc;
    for (uint8_t b : bytes) crc = kCrcTable[(crc ^ b) & 0xFF] ^ (crc >> 8);
    return ~crc;
}

void ByteWriter::u32(uint32_t v) {
    for (int k = 0; k < 4; ++k) u8(v >> (8 * k));
}

void ByteWriter::f32(float v) { u32(std::bit_cast<uint32_t>(v)); }

void ByteWriter::varint(uint64_t v) {
    while (v >= 0x80) {
        u8((v & 0x7F) | 0x80);
        v >>= 7;
    }
    u8(v);
}

void ByteReader::fail(const std::string& message) const { throw Error(str(what_, ": ", message)); }

std::span<const uint8_t> ByteReader::bytes(size_t n, const char* field) {
    if (n > remaining()) {
        fail(str("truncated: ", field, " needs ", n, " bytes at offset ", pos_, ", ", remaining(),
                 " remain"));
    }
    auto out = in_.subspan(pos_, n);
    pos_ += n;
    return out;
}

uint32_t ByteReader::u8(const char* field) { return bytes(1, field)[0]; }

uint32_t ByteReader::u32(const char* field) {
    auto b = bytes(4, field);
    return uint32_t{b[0]} | uint32_t{b[1]} << 8 | uint32_t{b[2]} << 16 | uint32_t{b[3]} << 24;
}

float ByteReader::f32(const char* field) {
    const float v = std::bit_cast<float>(u32(field));
    if (!std::isfinite(v)) fail(str(field, " is not a finite number"));
    return v;
}

uint64_t ByteReader::varint(const char* field) {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
        const uint32_t b = u8(field);
        v |= uint64_t{b & 0x7F} << shift;
        if (!(b & 0x80)) return v;
    }
    fail(str(field, ": varint longer than 10 bytes"));
}

int64_t ByteReader::svarint(const char* field) {
    const uint64_t v = varint(field);
    return static_cast<int64_t>(v >> 1) ^ -static_cast<int64_t>(v & 1);
}

int64_t ByteReader::count(const char* field, int64_t lo, int64_t hi) {
    const uint64_t v = varint(field);
    if (v < static_cast<uint64_t>(lo) || v > static_cast<uint64_t>(hi)) {
        fail(str(field, " = ", v, " is outside [", lo, ", ", hi, "]"));
    }
    return static_cast<int64_t>(v);
}

namespace {

class FileSource final : public ByteSource {
  public:
    explicit FileSource(const std::string& path) : file_(path, std::ios::binary) {
        if (!file_) throw Error(str(path, ": cannot open"));
        file_.seekg(0, std::ios::end);
        const auto end = file_.tellg();
        if (end < 0) throw Error(str(path, ": cannot read"));
        size_ = static_cast<uint64_t>(end);
    }
    uint64_t size() const override { return size_; }
    bool read(uint64_t offset, std::span<uint8_t> out) override {
        if (offset > size_ || out.size() > size_ - offset) return false;
        file_.clear();
        file_.seekg(static_cast<std::streamoff>(offset));
        return static_cast<bool>(file_.read(reinterpret_cast<char*>(out.data()),
                                            static_cast<std::streamsize>(out.size())));
    }

  private:
    std::ifstream file_;
    uint64_t size_ = 0;
};

class MemorySource final : public ByteSource {
  public:
    explicit MemorySource(std::span<const uint8_t> bytes) : bytes_(bytes) {}
    uint64_t size() const override { return bytes_.size(); }
    bool read(uint64_t offset, std::span<uint8_t> out) override {
        if (offset > bytes_.size() || out.size() > bytes_.size() - offset) return false;
        std::copy_n(bytes_.begin() + static_cast<std::ptrdiff_t>(offset), out.size(), out.begin());
        return true;
    }

  private:
    std::span<const uint8_t> bytes_;
};

}  // namespace

std::unique_ptr<ByteSource> file_source(const std::string& path) {
    return std::make_unique<FileSource>(path);
}

std::unique_ptr<ByteSource> memory_source(std::span<const uint8_t> bytes) {
    return std::make_unique<MemorySource>(bytes);
}

}  // namespace tesswave
