#include "core/codec/range_coder.h"

namespace tesswave {

// low_ holds 33 bits: bit 32 is a carry into the bytes already cached.
void RangeEncoder::shift_low() {
    if (static_cast<uint32_t>(low_) < 0xFF000000u || (low_ >> 32) != 0) {
        const uint8_t carry = static_cast<uint8_t>(low_ >> 32);
        uint8_t byte = cache_;
        do {
            bytes_.push_back(static_cast<uint8_t>(byte + carry));
            byte = 0xFF;
        } while (--pending_ != 0);
        cache_ = static_cast<uint8_t>(low_ >> 24);
    }
    ++pending_;
    low_ = (low_ & 0x00FFFFFFu) << 8;
}

void RangeEncoder::encode_raw(uint32_t value, int bits) {
    for (int i = bits - 1; i >= 0; --i) {
        range_ >>= 1;
        if ((value >> i) & 1) low_ += range_;
        while (range_ < kRangeTop) {
            range_ <<= 8;
            shift_low();
        }
    }
}

std::vector<uint8_t> RangeEncoder::finish() {
    for (int i = 0; i < 5; ++i) shift_low();
    // The first byte is always the initial zero cache; the decoder skips it, so it is dropped.
    std::vector<uint8_t> out(bytes_.begin() + 1, bytes_.end());
    *this = RangeEncoder();
    return out;
}

RangeDecoder::RangeDecoder(std::span<const uint8_t> input) : in_(input) {
    for (int i = 0; i < 4; ++i) code_ = (code_ << 8) | next_byte();
}

uint32_t RangeDecoder::decode_raw(int bits) {
    uint32_t value = 0;
    for (int i = 0; i < bits; ++i) {
        if (exhausted_) return value << (bits - i);
        range_ >>= 1;
        const uint32_t bit = code_ >= range_ ? 1 : 0;
        if (bit) code_ -= range_;
        value = (value << 1) | bit;
        while (range_ < kRangeTop) {
            range_ <<= 8;
            code_ = (code_ << 8) | next_byte();
        }
    }
    return value;
}

}  // namespace tesswave
