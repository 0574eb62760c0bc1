// Bounds-checked byte serialization for the container formats (.twi, .twv): little-endian fixed
// widths, LEB128 varints, zigzag signed varints, and the CRC-32 that guards headers. The reader
// checks every read against the bytes that remain and throws Error naming the field, so a decoder
// never reads past its input and never trusts a size it has not checked.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace tesswave {

// CRC-32 (the zlib/PNG polynomial 0xEDB88320, reflected, initial and final XOR 0xFFFFFFFF).
uint32_t crc32(std::span<const uint8_t> bytes, uint32_t crc = 0);

class ByteWriter {
  public:
    void u8(uint32_t v) { bytes_.push_back(static_cast<uint8_t>(v)); }
    void u32(uint32_t v);
    void f32(float v);
    void varint(uint64_t v);
    void svarint(int64_t v) {
        varint((static_cast<uint64_t>(v) << 1) ^ static_cast<uint64_t>(v >> 63));
    }
    void bytes(std::span<const uint8_t> b) { bytes_.insert(bytes_.end(), b.begin(), b.end()); }
    size_t size() const { return bytes_.size(); }
    std::vector<uint8_t>& data() { return bytes_; }

  private:
    std::vector<uint8_t> bytes_;
};

class ByteReader {
  public:
    // `what` names the input in messages ("header", a file name).
    ByteReader(std::span<const uint8_t> bytes, std::string what)
        : in_(bytes), what_(std::move(what)) {}
    uint32_t u8(const char* field);
    uint32_t u32(const char* field);
    float f32(const char* field);  // refuses NaN and infinities
    uint64_t varint(const char* field);
    int64_t svarint(const char* field);
    // A varint that must lie in [lo, hi].
    int64_t count(const char* field, int64_t lo, int64_t hi);
    std::span<const uint8_t> bytes(size_t n, const char* field);
    size_t position() const { return pos_; }
    size_t remaining() const { return in_.size() - pos_; }
    [[noreturn]] void fail(const std::string& message) const;

  private:
    std::span<const uint8_t> in_;
    size_t pos_ = 0;
    std::string what_;
};

// Random access to a decoder's input, a file or bytes in memory, for decoders that read part of it
// at a time (the .twv decoder seeks through its index and holds one chunk). read() is false, and
// fills nothing, when [offset, offset + out.size()) is not all there.
class ByteSource {
  public:
    virtual ~ByteSource() = default;
    virtual uint64_t size() const = 0;
    virtual bool read(uint64_t offset, std::span<uint8_t> out) = 0;
};

// Throws Error("<path>: cannot open") for a missing or unreadable file.
std::unique_ptr<ByteSource> file_source(const std::string& path);
// The bytes are not copied: they must outlive the source.
std::unique_ptr<ByteSource> memory_source(std::span<const uint8_t> bytes);

}  // namespace tesswave
