#include "core/codec/range_coder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::uniform;

// Bits from a two-state source: runs, skew and changes of statistics, like bit-plane coding.
std::vector<int> source(size_t n, double p1, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<int> bits(n);
    for (size_t i = 0; i < n; ++i) bits[i] = uniform(rng) < (i < n / 2 ? p1 : 1 - p1) ? 1 : 0;
    return bits;
}

std::vector<uint8_t> encode(const std::vector<int>& bits, int contexts) {
    RangeEncoder enc;
    std::vector<BitModel> models(contexts);
    for (size_t i = 0; i < bits.size(); ++i) enc.encode(models[i % contexts], bits[i]);
    return enc.finish();
}

TEST(RangeCoder, round_trips_modelled_and_raw_bits) {
    for (double p1 : {0.5, 0.1, 0.01, 0.999}) {
        const auto bits = source(20000, p1, 7);
        RangeEncoder enc;
        std::vector<BitModel> models(3);
        for (size_t i = 0; i < bits.size(); ++i) {
            enc.encode(models[i % 3], bits[i]);
            if (i % 1000 == 0) enc.encode_raw(static_cast<uint32_t>(i * 2654435761u) >> 8, 24);
        }
        const size_t predicted = enc.size_if_finished();
        const std::vector<uint8_t> stream = enc.finish();
        EXPECT_EQ(stream.size(), predicted) << p1;
        RangeDecoder dec(stream);
        std::vector<BitModel> dmodels(3);
        for (size_t i = 0; i < bits.size(); ++i) {
            ASSERT_EQ(dec.decode(dmodels[i % 3]), bits[i]) << p1 << " bit " << i;
            if (i % 1000 == 0) {
                ASSERT_EQ(dec.decode_raw(24), static_cast<uint32_t>(i * 2654435761u) >> 8);
            }
        }
        EXPECT_FALSE(dec.exhausted());
        EXPECT_LE(dec.position(), stream.size());
    }
}

// An adaptive model pays a little over the entropy (measured: 4.1 % at p = 0.02, less at
// milder skews); both sides of the bound are pinned.
TEST(RangeCoder, size_is_close_to_the_entropy) {
    const size_t n = 200000;
    for (double p1 : {0.02, 0.1, 0.3}) {
        const auto bits = source(n, p1, 11);
        const double entropy_bytes = n / 8.0 * -(p1 * std::log2(p1) + (1 - p1) * std::log2(1 - p1));
        const double size = static_cast<double>(encode(bits, 1).size());
        EXPECT_GE(size, 0.98 * entropy_bytes) << p1;
        EXPECT_LE(size, 1.05 * entropy_bytes + 16) << p1;
    }
}

// Every prefix decodes without reading past its end, and yields exactly the leading bits of
// the stream, more of them the longer the prefix.
TEST(RangeCoder, every_prefix_decodes_the_bits_it_determines) {
    const auto bits = source(3000, 0.2, 3);
    const std::vector<uint8_t> stream = encode(bits, 2);
    size_t previous = 0;
    for (size_t length = 0; length <= stream.size(); ++length) {
        const std::vector<uint8_t> prefix(stream.begin(), stream.begin() + length);
        RangeDecoder dec(prefix);
        std::vector<BitModel> models(2);
        size_t exact = 0;
        for (size_t i = 0; i < bits.size(); ++i) {
            if (dec.exhausted()) break;
            ASSERT_EQ(dec.decode(models[i % 2]), bits[i]) << "prefix " << length << " bit " << i;
            ++exact;
        }
        EXPECT_GE(exact, previous) << length;
        EXPECT_LE(dec.position(), length);
        previous = exact;
    }
    EXPECT_EQ(previous, bits.size());
}

TEST(RangeCoder, empty_and_garbage_input_is_harmless) {
    RangeDecoder empty(std::span<const uint8_t>{});
    BitModel m;
    EXPECT_TRUE(empty.exhausted());
    EXPECT_EQ(empty.decode(m), 0);
    std::mt19937_64 rng(5);
    std::vector<uint8_t> garbage(1000);
    for (auto& b : garbage) b = static_cast<uint8_t>(rng());
    RangeDecoder dec(garbage);
    std::vector<BitModel> models(8);
    for (int i = 0; i < 100000 && !dec.exhausted(); ++i) dec.decode(models[i % 8]);
    EXPECT_TRUE(dec.exhausted());
    EXPECT_LE(dec.position(), garbage.size());
}

}  // namespace
}  // namespace tesswave
