// Temporal lifting along the mesh (video/temporal.h) and the group's rate allocation
// (video/allocation.h).
#include "video/temporal.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numeric>
#include <random>

#include "video/allocation.h"
#include "video/twv_domain.h"

namespace tesswave::video {
namespace {

std::vector<Planes> random_group(int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1, 1);
    std::vector<Planes> x(static_cast<size_t>(n), Planes(2, std::vector<float>(7)));
    for (Planes& f : x) {
        for (auto& plane : f) {
            for (float& v : plane) v = u(rng);
        }
    }
    return x;
}

constexpr TemporalTree kTrees[] = {TemporalTree::dyadic, TemporalTree::bisection};

TEST(Temporal, LevelsLeaveOneLowBand) {
    for (TemporalTree tree : kTrees) {
        EXPECT_EQ(temporal_levels(1, tree), 0);
        EXPECT_EQ(temporal_levels(2, tree), 1);
        EXPECT_EQ(temporal_levels(5, tree), 3);
        EXPECT_EQ(temporal_levels(33, tree), 6);
    }
    EXPECT_EQ(temporal_levels(32, TemporalTree::dyadic), 5);
    EXPECT_EQ(temporal_levels(32, TemporalTree::bisection), 6);
    EXPECT_EQ(temporal_levels(16, TemporalTree::bisection), 5);
}

TEST(Temporal, InverseUndoesForwardForEveryGroupLength) {
    for (TemporalTree tree : kTrees) {
        for (int n = 1; n <= 33; ++n) {
            SCOPED_TRACE(::testing::Message() << "tree " << static_cast<int>(tree) << ", " << n);
            const std::vector<Planes> x = random_group(n, static_cast<uint32_t>(n));
            std::vector<Planes> y = x;
            temporal_forward(y, temporal_levels(n, tree), tree);
            if (n > 1) {
                EXPECT_NE(y, x);
            }
            temporal_inverse(y, temporal_levels(n, tree), tree);
            for (size_t t = 0; t < x.size(); ++t) {
                for (size_t c = 0; c < x[t].size(); ++c) {
                    for (size_t i = 0; i < x[t][c].size(); ++i) {
                        ASSERT_NEAR(y[t][c][i], x[t][c][i], 1e-5);
                    }
                }
            }
        }
    }
}

// At 2^k + 1 frames the bisection tree is the dyadic one, bit for bit (the .twv version 3 groups
// of 33 frames); at other lengths it is not.
TEST(Temporal, BisectionIsDyadicAtPowersOfTwoPlusOne) {
    for (int n : {2, 3, 5, 9, 17, 33}) {
        SCOPED_TRACE(n);
        std::vector<Planes> dyadic = random_group(n, 7), bisection = dyadic;
        temporal_forward(dyadic, temporal_levels(n, TemporalTree::dyadic), TemporalTree::dyadic);
        temporal_forward(bisection, temporal_levels(n, TemporalTree::bisection));
        EXPECT_EQ(dyadic, bisection);
        // and the inverse, which the decoder of a version 3 file runs
        temporal_inverse(dyadic, temporal_levels(n, TemporalTree::dyadic), TemporalTree::dyadic);
        temporal_inverse(bisection, temporal_levels(n, TemporalTree::bisection));
        EXPECT_EQ(dyadic, bisection);
    }
    std::vector<Planes> dyadic = random_group(16, 7), bisection = dyadic;
    temporal_forward(dyadic, temporal_levels(16, TemporalTree::dyadic), TemporalTree::dyadic);
    temporal_forward(bisection, temporal_levels(16, TemporalTree::bisection));
    EXPECT_NE(dyadic, bisection);
}

// What the mesh's motion compensation buys: material that stays the same coefficient has no high
// band, and a linear change in time (a fade) has none either where a frame lies between two
// others (the 5/3 predicts it exactly). On the bisection tree that is every frame but the last
// (predicted from the first) at every group length; on the dyadic tree the frames past the last
// power of two are extrapolated from one side.
TEST(Temporal, ConstantAndLinearSequencesHaveNoHighBands) {
    for (TemporalTree tree : kTrees) {
        for (int n : {2, 5, 8, 16, 13, 33}) {
            SCOPED_TRACE(::testing::Message() << "tree " << static_cast<int>(tree) << ", " << n);
            std::vector<Planes> still(static_cast<size_t>(n), Planes{{0.25f, -0.5f}});
            temporal_forward(still, temporal_levels(n, tree), tree);
            for (size_t t = 1; t < still.size(); ++t) {
                EXPECT_EQ(still[t][0][0], 0.0f);
                EXPECT_EQ(still[t][0][1], 0.0f);
            }
            EXPECT_NEAR(still[0][0][0], 0.25f, 1e-6);  // the low band keeps the mean
            std::vector<Planes> fade;
            for (int t = 0; t < n; ++t) fade.push_back(Planes{{0.125f * static_cast<float>(t)}});
            temporal_forward(fade, temporal_levels(n, tree), tree);
            int nonzero = 0;
            for (size_t t = 1; t < fade.size(); ++t) nonzero += std::abs(fade[t][0][0]) > 1e-5;
            const bool power_plus_one = n == 2 || n == 5 || n == 33;
            if (tree == TemporalTree::bisection || power_plus_one) {
                EXPECT_EQ(nonzero, 1);  // the last frame's
                EXPECT_NEAR(fade.back()[0][0], 0.125f * static_cast<float>(n - 1), 1e-5);
            } else {
                EXPECT_GT(nonzero, 1);
            }
        }
    }
}

TEST(Temporal, NormsMatchTheEnergyOfEachSlotsSynthesis) {
    for (TemporalTree tree : kTrees) {
        SCOPED_TRACE(static_cast<int>(tree));
        const int n = 8, levels = temporal_levels(n, tree);
        const std::vector<double> norms = temporal_norms(n, levels, tree);
        ASSERT_EQ(norms.size(), 8u);
        // The low band spreads over all 8 frames (norm near sqrt 8); the finest high bands are
        // mostly their own frame.
        EXPECT_NEAR(norms[0], std::sqrt(8.0), 0.6);
        for (int t : {1, 3, 5}) EXPECT_NEAR(norms[static_cast<size_t>(t)], 1.0, 0.25);
        // Reconstruction error in slot t costs its norm squared: checked with a perturbation.
        for (size_t slot : {size_t{4}, size_t{7}}) {
            std::vector<Planes> x(8, Planes{{0.0f}});
            x[slot][0][0] = 1.0f;
            temporal_inverse(x, levels, tree);
            double energy = 0;
            for (const Planes& f : x) energy += double{f[0][0]} * f[0][0];
            EXPECT_NEAR(std::sqrt(energy), norms[slot], 1e-6);
        }
    }
}

// Files before version 4 were lifted on the dyadic tree, and are read on it.
TEST(Temporal, AFilesVersionNamesItsTree) {
    EXPECT_EQ(temporal_tree(TwvHeader{.version = 2}), TemporalTree::dyadic);
    EXPECT_EQ(temporal_tree(TwvHeader{.version = 3}), TemporalTree::dyadic);
    EXPECT_EQ(temporal_tree(TwvHeader{.version = 4}), TemporalTree::bisection);
    EXPECT_EQ(temporal_tree(TwvHeader{}), TemporalTree::bisection);  // what the encoder writes
}

TEST(Temporal, BadShapesThrow) {
    std::vector<Planes> x = random_group(4, 1);
    EXPECT_THROW(temporal_forward(x, 3, TemporalTree::dyadic), std::exception);
    EXPECT_THROW(temporal_forward(x, 4), std::exception);
    x[2][1].pop_back();
    EXPECT_THROW(temporal_forward(x, 2), std::exception);
}

// Truncation points of a stream coded over `sweeps` sweeps, `bytes` per pass from the top.
EmbeddedStream stream(int sweeps, size_t per_pass) {
    EmbeddedStream s;
    s.pass_ends.assign(3 * static_cast<size_t>(sweeps), 0);
    size_t bytes = 0;
    for (int t = sweeps - 1; t >= 0; --t) {
        for (int pass = 0; pass < 3; ++pass) {
            bytes += per_pass;
            s.pass_ends[3 * static_cast<size_t>(t) + pass] = bytes;
        }
    }
    s.size = bytes;
    return s;
}

TEST(Allocation, CutsAddUpToTheBudgetAtOneSlope) {
    const std::vector<EmbeddedStream> streams = {stream(8, 100), stream(5, 40), stream(2, 10)};
    const size_t whole = 2400 + 600 + 60;
    // Everything fits: whole streams.
    CutPoint all = allocate_cuts(streams, whole + 10);
    EXPECT_EQ(all.bytes, (std::vector<size_t>{2400, 600, 60}));
    for (size_t budget : {size_t{0}, size_t{150}, size_t{1000}, size_t{1777}, size_t{3000}}) {
        SCOPED_TRACE(budget);
        const CutPoint cut = allocate_cuts(streams, budget);
        const size_t sum = std::accumulate(cut.bytes.begin(), cut.bytes.end(), size_t{0});
        EXPECT_LE(sum, budget);
        EXPECT_GE(sum + 3, budget);  // the remainder is spread, not wasted
        for (size_t k = 0; k < streams.size(); ++k) EXPECT_LE(cut.bytes[k], streams[k].size);
    }
    // 1000 bytes: the top 3 sweeps of stream 0 (900 bytes) come before any of stream 1's
    // (its top sweep is sweep 4, the 4th from stream 0's top): stream 1 gets only the rest.
    const CutPoint cut = allocate_cuts(streams, 1000);
    EXPECT_EQ(cut.bytes[2], 0u);
    EXPECT_GE(cut.bytes[0], 900u);
    EXPECT_EQ(cut.sweep, 4);
}

TEST(Allocation, AStreamStoppedAtItsCapIsNotCountedPastIt) {
    EmbeddedStream capped = stream(4, 100);
    for (size_t i = 0; i < 6; ++i) capped.pass_ends[i] = SIZE_MAX;  // sweeps 0 and 1 not reached
    capped.size = 610;
    const CutPoint cut = allocate_cuts({capped, stream(4, 10)}, 5000);
    // Stream 0's points end at sweep 2; the cut takes both streams to there, and the next point
    // (sweep 1, pass 0) only as far as stream 0 reached it.
    EXPECT_EQ(cut.bytes[0], 610u);
    EXPECT_EQ(cut.bytes[1], 70u);
}

}  // namespace
}  // namespace tesswave::video
