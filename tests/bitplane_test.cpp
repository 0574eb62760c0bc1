// The embedded bit-plane coder on its own: full and partial decodes, plane counts, the byte cap,
// and the dead-zone quantizer with its reconstruction rule.
#include "core/codec/bitplane.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <utility>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "core/math/hierarchy.h"

namespace tesswave {
namespace {

using Planes32 = std::vector<std::vector<int32_t>>;

std::vector<std::span<const int32_t>> views(const Planes32& q) { return {q.begin(), q.end()}; }

// Laplacian-like magnitudes, larger in coarse bands, about half of them zero.
Planes32 random_coefficients(const CodingLayout& layout, int channels, uint32_t seed) {
    std::mt19937 rng(seed);
    std::exponential_distribution<double> magnitude(0.15);
    Planes32 q(channels, std::vector<int32_t>(layout.size, 0));
    for (auto& plane : q) {
        for (int32_t& v : plane) {
            if (rng() % 2) continue;
            const int32_t m = static_cast<int32_t>(magnitude(rng));
            v = rng() % 2 ? m : -m;
        }
    }
    q[0][0] = 300;  // one large coefficient: many planes
    return q;
}

// Mostly zero: in each band, coefficients at the end of the first block of 64 (the last run of its
// last block of 16), in the middle of the second, at the end of the third's first run, and about
// one in 97 elsewhere: the zero blocks' decisions, skips and known last blocks all occur.
Planes32 sparse_coefficients(const CodingLayout& layout, int channels, uint32_t seed) {
    std::mt19937 rng(seed);
    Planes32 q(channels, std::vector<int32_t>(layout.size, 0));
    for (auto& plane : q) {
        const auto set = [&](int32_t k) {
            const auto m = static_cast<int32_t>(1 + rng() % 40);
            plane[layout.order[k]] = rng() % 2 ? m : -m;
        };
        for (const CodingBand& band : layout.bands) {
            for (const int32_t offset : {63, 64 + 20, 128 + 3}) {
                if (band.begin + offset < band.end) set(band.begin + offset);
            }
            for (int32_t k = band.begin; k < band.end; ++k) {
                if (rng() % 97 == 0) set(k);
            }
        }
    }
    return q;
}

CodingLayout mesh_test_layout() {
    const Hierarchy h = build_hierarchy(grid_mesh(48, 32, 3, 2), {.levels = 3});
    return mesh_layout(h, 48.0 * 32, 0);
}

// Layouts whose finest bands are large enough for zero blocks (4096 coefficients and more).
CodingLayout grid_block_layout() { return grid_layout(200, 100, 2, GridWavelet::cdf97, false); }
CodingLayout mesh_block_layout() {
    const Hierarchy h = build_hierarchy(grid_mesh(48, 32, 3, 2), {.levels = 6});
    return mesh_layout(h, 48.0 * 32, 0);
}

TEST(Bitplane, plane_counts_are_one_plus_the_top_bit_of_the_largest_magnitude) {
    const CodingLayout layout = grid_layout(16, 16, 2, GridWavelet::cdf53, false);
    Planes32 q(1, std::vector<int32_t>(layout.size, 0));
    q[0][0] = -5;  // band 0 holds coefficient 0: 3 bits
    const PlaneCounts planes = count_planes(layout, views(q));
    ASSERT_EQ(planes.size(), 1u);
    EXPECT_EQ(planes[0][0], 3);
    for (size_t b = 1; b < planes[0].size(); ++b) EXPECT_EQ(planes[0][b], 0) << "band " << b;
}

TEST(Bitplane, a_whole_stream_decodes_every_coefficient_exactly) {
    for (const CodingLayout& layout :
         {grid_layout(40, 24, 3, GridWavelet::cdf97, false), mesh_test_layout()}) {
        const Planes32 q = random_coefficients(layout, 3, 7);
        const PlaneCounts planes = count_planes(layout, views(q));
        const BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0)};
        const std::vector<uint8_t> stream = encode_bitplanes(layout, views(q), planes, options);
        const DecodedPlanes d = decode_bitplanes(layout, planes, stream, options);
        EXPECT_TRUE(d.complete);
        EXPECT_EQ(d.value, q);
    }
}

// A grid layout's relations, computed by the coder from the bands' rectangles, are the ones its
// lists spell out (grid_layout's listed form, which coding_layout_test checks): the streams are
// the same bytes, dense or sparse, on sizes whose bands are odd, one wide or one high.
TEST(Bitplane, computed_grid_relations_code_as_the_listed_ones) {
    struct Size {
        int width, height, levels;
    };
    for (const Size& s : {Size{40, 24, 3}, Size{37, 23, 4}, Size{1, 9, 3}, Size{64, 3, 4},
                          Size{7, 5, 2}, Size{33, 17, 5}}) {
        SCOPED_TRACE(::testing::Message() << s.width << "x" << s.height << ", " << s.levels);
        const CodingLayout computed = grid_layout(s.width, s.height, s.levels, GridWavelet::cdf53,
                                                  false, GridRelations::computed);
        const CodingLayout listed = grid_layout(s.width, s.height, s.levels, GridWavelet::cdf53,
                                                false, GridRelations::listed);
        ASSERT_TRUE(computed.nb.empty() && computed.ch.empty());
        ASSERT_EQ(computed.order, listed.order);
        for (const int keep : {2, 9}) {  // one coefficient in `keep` nonzero
            Planes32 q = random_coefficients(computed, 3, 13 + keep);
            for (auto& plane : q) {
                for (size_t i = 0; i < plane.size(); ++i) {
                    if (i % keep) plane[i] = 0;
                }
            }
            const PlaneCounts planes = count_planes(computed, views(q));
            const BitplaneOptions options{.shifts = std::vector<int>(computed.bands.size(), 0)};
            const std::vector<uint8_t> a = encode_bitplanes(computed, views(q), planes, options);
            EXPECT_TRUE(a == encode_bitplanes(listed, views(q), planes, options))
                << "the streams differ (one coefficient in " << keep << " nonzero)";
            EXPECT_EQ(decode_bitplanes(computed, planes, a, options).value, q);
        }
    }
}

// Codes q with the options x and with y: each stream round-trips, and each read with the other's
// options decodes to other values. Returns the two streams.
std::pair<std::vector<uint8_t>, std::vector<uint8_t>> expect_two_codings(const CodingLayout& layout,
                                                                         const Planes32& q,
                                                                         const BitplaneOptions& x,
                                                                         const BitplaneOptions& y) {
    const PlaneCounts planes = count_planes(layout, views(q));
    std::vector<uint8_t> a = encode_bitplanes(layout, views(q), planes, x);
    std::vector<uint8_t> b = encode_bitplanes(layout, views(q), planes, y);
    EXPECT_EQ(decode_bitplanes(layout, planes, a, x).value, q);
    EXPECT_EQ(decode_bitplanes(layout, planes, b, y).value, q);
    EXPECT_NE(decode_bitplanes(layout, planes, a, y).value, q);
    EXPECT_NE(decode_bitplanes(layout, planes, b, x).value, q);
    return {std::move(a), std::move(b)};
}

// Version 1 files' streams had models adapting at their settled rates from the start: with
// fast_start false both sides code that way, and the stream is longer than a fast-start one.
TEST(Bitplane, settled_models_round_trip_and_cost_more_than_fast_start) {
    const CodingLayout layout = mesh_test_layout();
    const BitplaneOptions fast{.shifts = std::vector<int>(layout.bands.size(), 0)};
    BitplaneOptions settled = fast;
    settled.fast_start = false;
    const auto [a, b] =
        expect_two_codings(layout, random_coefficients(layout, 3, 5), fast, settled);
    EXPECT_LT(a.size(), b.size());
}

// Streams with zero blocks (.twi from version 4, .twv from version 6) and without them (the
// versions before) each round-trip, on grids and meshes, sparse and dense; they differ, and a
// stream read the other way decodes to other values.
TEST(Bitplane, streams_with_and_without_zero_blocks_round_trip) {
    for (const CodingLayout& layout : {grid_block_layout(), mesh_block_layout()}) {
        for (const bool sparse : {true, false}) {
            SCOPED_TRACE(sparse ? "sparse" : "dense");
            const Planes32 q =
                sparse ? sparse_coefficients(layout, 3, 21) : random_coefficients(layout, 3, 21);
            const BitplaneOptions blocks{.shifts = std::vector<int>(layout.bands.size(), 0)};
            BitplaneOptions runs = blocks;
            runs.blocks = false;
            const auto [a, b] = expect_two_codings(layout, q, blocks, runs);
            EXPECT_NE(a, b);
        }
    }
}

// Without zero blocks the coder writes the bytes of the streams in .twi files before version 4 and
// .twv files before version 6, which it must go on reading: the FNV-1a hashes below are of the
// streams that the build before zero blocks (9922ede) wrote for the same planes.
TEST(Bitplane, streams_without_zero_blocks_are_the_earlier_versions_bytes) {
    const auto fnv1a = [](const std::vector<uint8_t>& bytes) {
        uint64_t h = 1469598103934665603ull;
        for (const uint8_t b : bytes) h = (h ^ b) * 1099511628211ull;
        return h;
    };
    struct Golden {
        size_t size;
        uint64_t hash;
    };
    const Golden golden[] = {{24449, 0xad3d44c3598d472full},
                             {1287, 0xc2c62b31b3e96f38ull},
                             {30200, 0x8f930f1c1ca846beull},
                             {1594, 0x770f5bb44956a7b6ull}};
    int i = 0;
    for (const CodingLayout& layout : {grid_block_layout(), mesh_block_layout()}) {
        for (const bool sparse : {false, true}) {
            const Planes32 q =
                sparse ? sparse_coefficients(layout, 3, 21) : random_coefficients(layout, 3, 21);
            const BitplaneOptions runs{.shifts = std::vector<int>(layout.bands.size(), 0),
                                       .blocks = false};
            const std::vector<uint8_t> stream =
                encode_bitplanes(layout, views(q), count_planes(layout, views(q)), runs);
            EXPECT_EQ(stream.size(), golden[i].size) << i;
            EXPECT_EQ(fnv1a(stream), golden[i].hash) << i;
            ++i;
        }
    }
}

// Any prefix determines the high bits of every coefficient it reaches: the decoded magnitude is
// the true one with the bits below the lowest known plane cleared, and the sign is right.
void expect_prefixes_decode_high_bits(const CodingLayout& layout, const Planes32& q,
                                      bool with_blocks) {
    const PlaneCounts planes = count_planes(layout, views(q));
    const BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0),
                                  .blocks = with_blocks};
    const std::vector<uint8_t> stream = encode_bitplanes(layout, views(q), planes, options);
    size_t previous_known = 0;
    for (size_t n = 0; n <= stream.size(); n += std::max<size_t>(1, stream.size() / 40)) {
        const DecodedPlanes d =
            decode_bitplanes(layout, planes, std::span(stream).first(n), options);
        size_t known = 0;
        for (int32_t i = 0; i < layout.size; ++i) {
            const int k = d.known[0][i];
            const int32_t v = d.value[0][i], truth = q[0][i];
            if (k >= 32) {
                EXPECT_EQ(v, 0) << "coefficient " << i << " at " << n << " bytes";
                continue;
            }
            ++known;
            const int32_t high = (std::abs(truth) >> k) << k;
            EXPECT_EQ(std::abs(v), high) << "coefficient " << i << " at " << n << " bytes";
            if (v != 0) {
                EXPECT_EQ(v < 0, truth < 0) << "coefficient " << i;
            }
        }
        EXPECT_GE(known, previous_known) << "a longer prefix knows less at " << n << " bytes";
        previous_known = known;
    }
}

// Dense planes on a small mesh; sparse ones (zero blocks) on a grid and a mesh with bands of
// 4096 coefficients and more; with and without zero blocks.
TEST(Bitplane, every_prefix_decodes_the_high_bits_it_holds) {
    const CodingLayout small = mesh_test_layout(), grid = grid_block_layout(),
                       mesh = mesh_block_layout();
    for (const bool with_blocks : {true, false}) {
        SCOPED_TRACE(::testing::Message() << "blocks " << with_blocks);
        expect_prefixes_decode_high_bits(small, random_coefficients(small, 1, 11), with_blocks);
        expect_prefixes_decode_high_bits(grid, sparse_coefficients(grid, 1, 11), with_blocks);
        expect_prefixes_decode_high_bits(mesh, sparse_coefficients(mesh, 1, 11), with_blocks);
    }
}

// Cut where a sweep's cleanup pass ends, every coefficient still insignificant knows at least the
// plane of that sweep in its band (the cleanup visits all of them; run mode settles their planes
// once at the end; the decoder may go on past the cut as far as the bytes determine), on grids and
// meshes alike, dense and sparse (zero blocks), with and without plane shifts. Knowing too much
// is every_prefix's check.
TEST(Bitplane, a_cut_after_a_cleanup_pass_knows_that_plane_everywhere) {
    for (const CodingLayout& layout :
         {grid_layout(40, 24, 3, GridWavelet::cdf97, false), mesh_test_layout(),
          grid_block_layout(), mesh_block_layout()}) {
        for (const bool sparse : {false, true}) {
            const Planes32 q =
                sparse ? sparse_coefficients(layout, 2, 5) : random_coefficients(layout, 2, 5);
            const PlaneCounts planes = count_planes(layout, views(q));
            for (const int step : {0, 1}) {
                std::vector<size_t> ends;
                BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0)};
                for (size_t b = 0; b < options.shifts.size(); ++b)
                    options.shifts[b] = step * static_cast<int>(b % 2);
                options.pass_ends = &ends;
                const std::vector<uint8_t> stream =
                    encode_bitplanes(layout, views(q), planes, options);
                options.pass_ends = nullptr;
                for (size_t t = 1; 3 * t + 2 < ends.size(); t += 2) {  // sweeps t = 1, 3, ...
                    const size_t cut = ends[3 * t + 2];
                    const DecodedPlanes d =
                        decode_bitplanes(layout, planes, std::span(stream).first(cut), options);
                    for (size_t c = 0; c < q.size(); ++c) {
                        for (size_t b = 0; b < layout.bands.size(); ++b) {
                            const int p = static_cast<int>(t) - options.shifts[b];
                            // A band's planes run from planes - 1 down: past its last, it is whole.
                            const int expected = p >= planes[c][b] ? 32 : std::max(p, 0);
                            for (int32_t k = layout.bands[b].begin; k < layout.bands[b].end; ++k) {
                                const int32_t id = layout.order[k];
                                if (d.value[c][id] != 0) continue;
                                ASSERT_LE(d.known[c][id], expected)
                                    << "channel " << c << ", band " << b << ", sweep " << t
                                    << ", shifts " << step << ", sparse " << sparse;
                            }
                        }
                    }
                }
            }
        }
    }
}

TEST(Bitplane, the_byte_cap_stops_the_encoder_near_it) {
    const CodingLayout layout = grid_layout(64, 64, 3, GridWavelet::cdf53, false);
    const Planes32 q = random_coefficients(layout, 1, 3);
    const PlaneCounts planes = count_planes(layout, views(q));
    BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0)};
    const size_t whole = encode_bitplanes(layout, views(q), planes, options).size();
    options.max_bytes = whole / 3;
    const size_t capped = encode_bitplanes(layout, views(q), planes, options).size();
    EXPECT_LT(capped, whole);
    EXPECT_LE(capped, options.max_bytes + 16);
}

TEST(Bitplane, planes_that_do_not_match_the_layout_are_refused) {
    const CodingLayout layout = grid_layout(16, 16, 2, GridWavelet::cdf53, false);
    const PlaneCounts wrong(1, std::vector<uint8_t>(layout.bands.size() + 1, 1));
    const BitplaneOptions options{.shifts = std::vector<int>(layout.bands.size(), 0)};
    EXPECT_THROW(decode_bitplanes(layout, wrong, {}, options), Error);
}

TEST(Bitplane, dead_zone_quantization_and_its_reconstruction) {
    const CodingLayout layout = grid_layout(8, 8, 1, GridWavelet::cdf53, false);
    std::vector<float> x(layout.size, 0.0f);
    x[0] = 7.9f;   // step 2: magnitude 3
    x[1] = -0.9f;  // inside the dead zone: 0
    x[2] = -4.0f;  // magnitude 2, negative
    const std::vector<float> steps(layout.bands.size(), 2.0f);
    std::vector<int32_t> q(layout.size);
    quantize(layout, x, steps, q);
    EXPECT_EQ(q[0], 3);
    EXPECT_EQ(q[1], 0);
    EXPECT_EQ(q[2], -2);
    // Known down to plane 0: exact multiples of the step when asked, else 3/8 into the interval.
    const DecodedPlanes d{
        .value = {q}, .known = {std::vector<uint8_t>(layout.size, 0)}, .complete = true};
    std::vector<float> exact(layout.size), mid(layout.size);
    dequantize(layout, d, 0, steps, true, exact);
    dequantize(layout, d, 0, steps, false, mid);
    EXPECT_FLOAT_EQ(exact[0], 6.0f);
    EXPECT_FLOAT_EQ(exact[2], -4.0f);
    EXPECT_FLOAT_EQ(exact[1], 0.0f);
    EXPECT_FLOAT_EQ(mid[0], (3 + 0.375f) * 2.0f);
    EXPECT_FLOAT_EQ(mid[2], -(2 + 0.375f) * 2.0f);
    EXPECT_FLOAT_EQ(mid[1], 0.0f);
}

// requantize gives the floats of quantize then dequantize (every plane known, not exact), on
// random values over many magnitudes, at several steps per band, zeros and the dead zone included.
void expect_requantize_equals_the_two_steps(const CodingLayout& layout) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
    std::vector<float> x(layout.size);
    for (size_t i = 0; i < x.size(); ++i) {
        x[i] = i % 11 == 0 ? 0.0f : unit(rng) * std::ldexp(1.0f, static_cast<int>(i % 13) - 4);
    }
    x[3] = -0.0f;
    x[5] = std::numeric_limits<float>::denorm_min();
    x[7] = -std::numeric_limits<float>::denorm_min();
    for (const float base : {0.01f, 0.3f, 2.0f}) {
        std::vector<float> steps(layout.bands.size());
        for (size_t b = 0; b < steps.size(); ++b) steps[b] = base * (1.0f + 0.37f * b);
        std::vector<int32_t> q(layout.size);
        quantize(layout, x, steps, q);
        const DecodedPlanes d{
            .value = {q}, .known = {std::vector<uint8_t>(layout.size, 0)}, .complete = true};
        std::vector<float> two_steps(layout.size), fused(layout.size, -1.0f);
        dequantize(layout, d, 0, steps, false, two_steps);
        requantize(layout, x, steps, fused);
        for (size_t i = 0; i < x.size(); ++i) {
            ASSERT_EQ(std::bit_cast<uint32_t>(fused[i]), std::bit_cast<uint32_t>(two_steps[i]))
                << i << ": " << x[i] << " at " << base;
        }
    }
}

// dequantize (branch-free, in bit operations) gives the bits of the plain formula: 0 for 0, else
// (v < 0 ? -m : m) * step with m = |v| + 3/8 of 2^known (no 3/8 for an exact coefficient known to
// plane 0), for every known plane, both signs, large magnitudes and steps of either sign.
TEST(Bitplane, dequantize_gives_the_plain_formula) {
    for (const GridRelations relations : {GridRelations::computed, GridRelations::listed}) {
        const CodingLayout layout = grid_layout(37, 29, 3, GridWavelet::cdf97, false, relations);
        std::vector<int32_t> value(layout.size);
        std::vector<uint8_t> known(layout.size);
        const int32_t magnitudes[] = {0, 1, 2, 3, 7, 1000, 65535, (1 << 24) + 1, (1 << 30) - 1};
        for (size_t i = 0; i < value.size(); ++i) {
            const int32_t m = magnitudes[i % 9];
            value[i] = (i / 9) % 2 ? -m : m;
            known[i] = m == 0 && i % 4 == 0 ? 32 : static_cast<uint8_t>((i / 18) % 32);
        }
        const DecodedPlanes d{.value = {value}, .known = {known}, .complete = true};
        for (const float base : {0.01f, 2.5f, -0.7f}) {
            std::vector<float> steps(layout.bands.size());
            for (size_t b = 0; b < steps.size(); ++b) steps[b] = base * (1.0f + 0.37f * b);
            for (const bool exact : {false, true}) {
                std::vector<float> out(layout.size, NAN);
                dequantize(layout, d, 0, steps, exact, out);
                for (size_t b = 0; b < layout.bands.size(); ++b) {
                    for (int32_t k = layout.bands[b].begin; k < layout.bands[b].end; ++k) {
                        const int32_t id = layout.order[k], v = value[id];
                        float expected = 0.0f;
                        if (v != 0) {
                            const int kp = known[id];
                            const float half =
                                (exact && kp == 0) ? 0.0f : 0.375f * static_cast<float>(1u << kp);
                            const float m = static_cast<float>(std::abs(v)) + half;
                            expected = (v < 0 ? -m : m) * steps[b];
                        }
                        ASSERT_EQ(std::bit_cast<uint32_t>(out[id]),
                                  std::bit_cast<uint32_t>(expected))
                            << "v " << v << ", known " << int(known[id]) << ", step " << steps[b]
                            << (exact ? ", exact" : "");
                    }
                }
            }
        }
    }
}

TEST(Bitplane, requantize_equals_quantize_then_dequantize) {
    for (const GridRelations relations : {GridRelations::computed, GridRelations::listed}) {
        SCOPED_TRACE(relations == GridRelations::computed ? "rectangles" : "listed");
        expect_requantize_equals_the_two_steps(
            grid_layout(37, 29, 3, GridWavelet::cdf97, false, relations));
    }
    // A step far too small for the values is refused, as quantize refuses it.
    const CodingLayout layout = grid_layout(8, 8, 1, GridWavelet::cdf53, false);
    std::vector<float> x(layout.size, 1.0f), out(layout.size);
    const std::vector<float> tiny(layout.bands.size(), 1e-12f);
    EXPECT_THROW(requantize(layout, x, tiny, out), Error);
}

}  // namespace
}  // namespace tesswave
