// Reproducers of the defects the robustness campaigns and the fuzzers found: each input once
// crashed, hung, overflowed or threw something other than tesswave::Error.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <string_view>
#include <vector>

#include "core/io/mesh_io.h"
#include "core/math/hierarchy.h"
#include "core/math/parametrization.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"
#include "robustness.h"
#include "samples/sample_meshes.h"

namespace tesswave {
namespace {

using testing::expect_error_or_return_in_child;
using testing::kNaN;
using testing::Outcome;
using testing::outcome_of;

// nlohmann::json reports a float literal beyond double range as json::out_of_range (406), not as
// json::parse_error, and parse_mesh/parse_points only translate the latter.
TEST(Robustness, number_overflow_in_json_is_an_error) {
    for (std::string_view text :
         {R"({"domain": [1e400, 1], "vertices": [], "faces": []})",
          R"({"domain": [1, 1], "vertices": [[0, -1e999]], "faces": []})",
          R"({"domain": [1, 1], "vertices": [], "faces": [], "extra": 1e309})"}) {
        const Outcome o = outcome_of([&] { parse_mesh(text, "m.json"); });
        EXPECT_EQ(o.kind, Outcome::error) << text << "\n" << o.what;
    }
    for (std::string_view text : {"[[1e400, 1]]", "[[1, -1e400]]", "1e400 1\n"}) {
        const Outcome o = outcome_of([&] { parse_points(text, "p.txt"); });
        EXPECT_EQ(o.kind, Outcome::error) << text << "\n" << o.what;
    }
}

// Unknown keys are kept by copying the document and dumping it, both recursive in nlohmann::json:
// deep nesting under an unknown key overflows the stack.
TEST(Robustness, deeply_nested_unknown_key_does_not_overflow_the_stack) {
    const int depth = 100'000;
    const std::string text = R"({"domain": [1, 1], "vertices": [], "faces": [], "x": )" +
                             std::string(depth, '[') + std::string(depth, ']') + "}";
    expect_error_or_return_in_child([&] { parse_mesh(text, "m.json"); });
}

// The count recurrence multiplies by 4 per level in int64 without a bound: `tesswave mesh info
// --levels 30` (the CLI's maximum) overflows on the paper mesh. In a child, because a sanitizer
// build stops at the overflow. Exit code 3: counts that are not increasing.
TEST(Robustness, level_counts_do_not_overflow) {
    const Mesh mesh = samples::paper_t0(120, 90);
    for (int levels : {30, 31, 40, 64, 1 << 20}) {
        SCOPED_TRACE(levels);
        expect_error_or_return_in_child([&] {
            const std::vector<LevelCounts> counts = level_counts(mesh, levels);
            bool increasing = counts.size() == static_cast<size_t>(levels) + 1;
            for (size_t j = 1; j < counts.size(); ++j) {
                increasing = increasing && counts[j].vertices > counts[j - 1].vertices &&
                             counts[j].edges > counts[j - 1].edges;
            }
            if (!increasing || sample_count(mesh, levels) < counts.back().vertices) std::_Exit(3);
        });
    }
}

// random_sites() redraws coincident sites until all are distinct, which never happens when the
// domain holds fewer representable points than sites.
TEST(Robustness, voronoi_on_a_subnormal_domain_terminates) {
    expect_error_or_return_in_child([] { voronoi_mesh(5e-324, 5e-324, {.sites = 5}); });
}

// Lloyd on extreme domains: a cell area underflows (or overflows), the centroid and then the site
// become NaN and SiteGrid::bx() casts NaN to int (clang's -fsanitize=float-cast-overflow), e.g.
// voronoi_mesh(1e-300, 5e-301, {.sites = 1, .lloyd_iterations = 1}).
TEST(Robustness, voronoi_lloyd_on_extreme_domains_has_no_undefined_behaviour) {
    for (double s : {1e-300, 1e-200, 1e150, 1e300}) {
        for (int sites : {1, 2, 5, 40}) {
            SCOPED_TRACE(str(s, ", ", sites, " sites"));
            expect_error_or_return_in_child(
                [&] { voronoi_mesh(s, 0.5 * s, {.sites = sites, .lloyd_iterations = 1}); });
        }
    }
}

// check_t_nodes() buckets vertices into cells of W / side; on a subnormal domain that is 0 and
// the cell index is a NaN cast to int (caught by clang's -fsanitize=float-cast-overflow).
TEST(Robustness, validate_on_a_subnormal_domain_has_no_undefined_behaviour) {
    expect_error_or_return_in_child([] { validate(samples::paper_t0(5e-324, 5e-324)); });
}

// A fan of n triangles from (1, 1/2) to n + 1 vertices on the left border (x = 0): check_t_nodes
// scanned every vertex in the bounding box of each long edge and check_vertex_use compared every
// pair of vertices with the same x, both O(n^2): 110 s at -O3 for n = 200'000 (a 5 MB file). The
// limit is generous because walking long edges cell by cell still costs O(n^1.5) here.
TEST(Robustness, validate_is_not_quadratic_in_long_edges_or_equal_x) {
    const int n = 200'000;
    Mesh mesh;
    mesh.width = mesh.height = 1;
    mesh.vertices.push_back({1, 0.5});
    for (int i = 0; i <= n; ++i) mesh.vertices.push_back({0, static_cast<double>(i) / n});
    for (int32_t i = 1; i <= n; ++i) mesh.add_face(std::vector<int32_t>{0, i + 1, i});
    expect_error_or_return_in_child([&] { validate(mesh); });
}

// A convex n-gon in the middle of [0,100]^2, and optionally its outside fanned to the domain
// corners, which makes a valid mesh.
Mesh polygon_mesh(int n, bool fill_outside) {
    Mesh mesh;
    mesh.width = mesh.height = 100;
    std::vector<int32_t> polygon(n);
    for (int32_t i = 0; i < n; ++i) {
        const double angle = 2 * std::numbers::pi * i / n;
        mesh.vertices.push_back({50 + 40 * std::cos(angle), 50 + 40 * std::sin(angle)});
        polygon[i] = i;
    }
    mesh.add_face(polygon);
    if (!fill_outside) return mesh;
    mesh.vertices.insert(mesh.vertices.end(), {{0, 0}, {100, 0}, {100, 100}, {0, 100}});
    const int32_t corner[4] = {n + 2, n + 3, n, n + 1};  // per quadrant of the angle
    for (int32_t i = 0; i < n; ++i) {  // n divisible by 4: the quadrant changes fall on vertices
        const int q = 4 * i / n;
        mesh.add_face(std::vector<int32_t>{(i + 1) % n, i, corner[q]});
        if (4 * i % n == 0) mesh.add_face(std::vector<int32_t>{i, corner[(q + 3) % 4], corner[q]});
    }
    return mesh;
}

// check_face_indices() looked for each corner among the corners before it (std::find), and
// cut_mesh()'s incidence_of() scanned a whole face per edge end: both O(d^2) in the corner count d
// of one face. At -O3 the first took 20 s for d = 600'000 (an n-gon naming its first vertex again
// at the end, so that validate() stops after the index check) and the second 25 s for 300'000.
TEST(Robustness, big_faces_are_not_quadratic) {
    Mesh twice = polygon_mesh(600'000, false);
    twice.face_corners.push_back(0);
    ++twice.face_offsets.back();
    expect_error_or_return_in_child([&] { validate(twice); });
    ASSERT_TRUE(validate(polygon_mesh(1000, true)).ok());  // the construction is valid
    const Mesh filled = polygon_mesh(300'000, true);
    expect_error_or_return_in_child([&] { sample_count(filled, 1); });
}

// QuadLocator divides by the domain size and casts to int without checking either.
TEST(Robustness, quad_locator_refuses_a_degenerate_domain) {
    const Quad unit{Vec2{0, 0}, Vec2{1, 0}, Vec2{1, 1}, Vec2{0, 1}};
    expect_error_or_return_in_child([&] {
        QuadLocator({unit, unit, unit, unit}, 0, 0).locate({0, 0});
    });
    expect_error_or_return_in_child([&] {
        QuadLocator({unit, unit, unit, unit}, kNaN, 1).locate({0, 0});
    });
    const Quad huge{Vec2{-1e300, 0}, Vec2{1e300, 0}, Vec2{1, 1e300}, Vec2{0, 1}};
    const Quad nan{Vec2{kNaN, 0}, Vec2{1, 0}, Vec2{1, 1}, Vec2{0, 1}};
    expect_error_or_return_in_child([&] {
        QuadLocator({huge, nan, unit, unit}, 1, 1).locate({0.5, 0.5});
    });
}

// The header promises results clamped to [0,1]; degenerate quads give NaN.
TEST(Robustness, inverse_bilinear_of_a_degenerate_quad_stays_in_the_unit_square) {
    const Quad point{Vec2{1, 1}, Vec2{1, 1}, Vec2{1, 1}, Vec2{1, 1}};
    const Quad segment{Vec2{0, 0}, Vec2{1, 0}, Vec2{2, 0}, Vec2{3, 0}};
    for (const Quad& q : {point, segment}) {
        for (Vec2 p : {Vec2{1, 1}, Vec2{0.5, 0}, Vec2{7, -3}}) {
            const UV uv = inverse_bilinear(q, p);
            EXPECT_TRUE(uv.u >= 0 && uv.u <= 1 && uv.v >= 0 && uv.v <= 1)
                << "(" << p.x << ", " << p.y << ") -> " << uv.u << ", " << uv.v;
        }
    }
}

}  // namespace
}  // namespace tesswave
