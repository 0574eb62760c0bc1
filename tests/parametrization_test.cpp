#include "core/math/parametrization.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <random>
#include <vector>

#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::uniform;

void expect_round_trip(const Quad& q, std::mt19937_64& rng) {
    for (int k = 0; k < 200; ++k) {
        double u = uniform(rng), v = uniform(rng);
        if (k < 4) u = k & 1, v = k >> 1;  // the corners themselves
        const UV back = inverse_bilinear(q, bilinear(q, u, v));
        ASSERT_NEAR(back.u, u, 1e-9);
        ASSERT_NEAR(back.v, v, 1e-9);
    }
}

TEST(Parametrization, inverse_round_trip_on_convex_quads) {
    std::mt19937_64 rng(9);
    expect_round_trip({Vec2{0, 0}, {1, 0}, {1, 1}, {0, 1}}, rng);                // square
    expect_round_trip({Vec2{0, 0}, {4, 1}, {5, 3}, {1, 2}}, rng);                // parallelogram
    expect_round_trip({Vec2{0, 0}, {6, 0}, {4, 2}, {1, 2}}, rng);                // p00p10 || p01p11
    expect_round_trip({Vec2{0, 0}, {2, 1}, {2, 3}, {0, 5}}, rng);                // p00p01 || p10p11
    expect_round_trip({Vec2{10, 10}, {10.5, 10}, {10.5, 300}, {10, 300}}, rng);  // thin
    int tested = 0;
    while (tested < 500) {
        // Random quads with one corner in each quadrant around the origin; the non-convex ones
        // (a reflex corner is possible) are outside the inverse's contract and skipped.
        Quad q = {Vec2{-0.2 - uniform(rng), -0.2 - uniform(rng)},
                  Vec2{0.2 + uniform(rng), -0.2 - uniform(rng)},
                  Vec2{0.2 + uniform(rng), 0.2 + uniform(rng)},
                  Vec2{-0.2 - uniform(rng), 0.2 + uniform(rng)}};
        bool convex = true;
        for (int r = 0; r < 4; ++r) {
            convex &= cross(q[(r + 1) % 4] - q[r], q[(r + 2) % 4] - q[(r + 1) % 4]) > 1e-3;
        }
        if (!convex) continue;
        expect_round_trip(q, rng);
        ++tested;
    }
}

// QuadInverse::row (four points at a time with AVX2) gives operator()'s bits for every point of
// a row: convex quads, parallelograms and trapezoids (the linear case), zero-area quads, and rows
// reaching outside the quad, of every length up to 13 (whole fours and the remainder).
TEST(Parametrization, row_gives_the_inverse_of_each_point_to_the_bit) {
    std::mt19937_64 rng(41);
    std::vector<Quad> quads = {
        {Vec2{0, 0}, {4, 0}, {4, 3}, {0, 3}},           // a rectangle
        {Vec2{1, 1}, {5, 2}, {6, 6}, {2, 5}},           // a parallelogram: a x c = 0
        {Vec2{0, 0}, {8, 0}, {6, 4}, {2, 4}},           // a trapezoid
        {Vec2{0, 0}, {0, 0}, {0, 0}, {0, 0}},           // a point
        {Vec2{0, 0}, {4, 0}, {8, 0}, {12, 0}},          // a segment
        {Vec2{0, 0}, {1e-9, 0}, {1e-9, 1e-9}, {0, 1}},  // nearly degenerate
    };
    for (int k = 0; k < 200; ++k) {
        Quad q;
        for (int c = 0; c < 4; ++c) {
            const double x = (c == 1 || c == 2) ? 10 : 0, y = c >= 2 ? 10 : 0;
            q[c] = {x + 4 * (uniform(rng) - 0.5), y + 4 * (uniform(rng) - 0.5)};
        }
        quads.push_back(q);
    }
    for (const Quad& q : quads) {
        const QuadInverse inverse(q);
        for (int count = 1; count <= 13; ++count) {
            const double x0 = -3.5 + 16 * uniform(rng), y = -2.5 + 15 * uniform(rng);
            std::vector<double> u(count), v(count);
            inverse.row(x0, y, count, u.data(), v.data());
            for (int i = 0; i < count; ++i) {
                const UV expected = inverse({x0 + i, y});
                ASSERT_EQ(std::bit_cast<uint64_t>(u[i]), std::bit_cast<uint64_t>(expected.u))
                    << "point " << i << " of " << count;
                ASSERT_EQ(std::bit_cast<uint64_t>(v[i]), std::bit_cast<uint64_t>(expected.v))
                    << "point " << i << " of " << count;
            }
        }
    }
}

TEST(Parametrization, locator_finds_the_quad_and_its_parameters) {
    const Mesh mesh = samples::paper_t0(249, 251);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 1});
    QuadLocator locator(t1_quads(h, mesh.vertices), 249, 251);
    ASSERT_EQ(locator.quads().size(), 53u);
    std::mt19937_64 rng(10);
    for (int k = 0; k < 2000; ++k) {
        const Vec2 p{249 * uniform(rng), 251 * uniform(rng)};
        const auto hit = locator.locate(p);
        ASSERT_TRUE(hit.has_value()) << p.x << "," << p.y;
        const Vec2 back = bilinear(locator.quads()[hit->quad], hit->uv.u, hit->uv.v);
        ASSERT_NEAR(back.x, p.x, 1e-8);
        ASSERT_NEAR(back.y, p.y, 1e-8);
    }
    EXPECT_TRUE(locator.locate({0, 0}).has_value());
    EXPECT_TRUE(locator.locate({249, 251}).has_value());
    EXPECT_FALSE(locator.locate({-1, 5}).has_value());
    EXPECT_FALSE(locator.locate({250, 5}).has_value());
}

}  // namespace
}  // namespace tesswave
