// Robustness of the entry points that take user input (STYLE.md, "Errors and limits"): thousands of
// deterministic mutants of valid mesh files, point lists and Mesh structs go through parse ->
// validate -> hierarchy -> transform. Only tesswave::Error may come out, with a one-line message; a
// mutant that validates must still reconstruct perfectly, and one that does not must be refused by
// require_valid() and build_hierarchy(). Inputs that crashed, hung or threw something else once are
// kept as regular cases in regression_test.cpp; those that can take the process down run in a
// child process.
#include "robustness.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <string_view>
#include <typeinfo>
#include <vector>

#include "core/io/mesh_io.h"
#include "core/math/error.h"
#include "core/math/hierarchy.h"
#include "core/math/lifting.h"
#include "core/math/parametrization.h"
#include "core/math/strings.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"
#include "mutations.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::below;
using testing::expect_error_or_return_in_child;
using testing::faces_of;
using testing::kInf;
using testing::kNaN;
using testing::mutate_mesh;
using testing::mutate_text;
using testing::Outcome;
using testing::outcome_of;
using testing::set_faces;
using testing::uniform;

// Counts of one campaign. A failure keeps its input, for the first few.
struct Tally {
    const char* name;
    int parse_errors = 0, invalid = 0, valid = 0, failures = 0;
    std::string_view original = {};  // the text being mutated: failures show the part that differs

    void fail(std::string_view stage, const std::string& what, std::string_view input) {
        if (++failures > 5) return;
        size_t at = 0;
        while (at < input.size() && at < original.size() && input[at] == original[at]) ++at;
        const size_t from = at > 200 ? at - 200 : 0;
        ADD_FAILURE() << name << ": " << stage << ": " << what << "\n--- input, " << input.size()
                      << " bytes, from byte " << from << " (first change at " << at << ") ---\n"
                      << input.substr(from, 500);
    }
    void check_message(std::string_view stage, const std::string& message, std::string_view input) {
        if (message.empty() || message.find('\n') != std::string::npos) {
            fail(stage, "error message is not one line: \"" + message + "\"", input);
        }
    }
    // Prints the counts and insists that the campaign reached both sides of validate().
    void report() const {
        std::printf("[ robustness ] %s: %d parse errors, %d invalid, %d valid, %d failures\n", name,
                    parse_errors, invalid, valid, failures);
        ::testing::Test::RecordProperty("parse_errors", parse_errors);
        ::testing::Test::RecordProperty("invalid", invalid);
        ::testing::Test::RecordProperty("valid", valid);
        EXPECT_GT(valid, 0) << name << ": no mutant was valid; the campaign tests nothing";
        EXPECT_GT(parse_errors + invalid, 0) << name << ": no mutant was rejected";
        EXPECT_EQ(failures, 0) << name;
    }
};

// Forward and inverse transforms at levels 0..max_level on random data: float to within rounding,
// int bit-exact (also with the reference kernel going forward), counts as predicted, and point
// location in the T1 quads consistent with the bilinear map. Returns the first problem, or "".
std::string round_trip_problem(const Mesh& mesh, int max_level, uint64_t seed) {
    std::mt19937_64 rng(seed);
    for (int J = 0; J <= max_level; ++J) {
        const Hierarchy h = build_hierarchy(mesh, {.levels = J});
        const size_t n = h.num_samples(J);
        if (static_cast<int64_t>(n) != sample_count(mesh, J)) {
            return str("level ", J, ": ", n, " samples, sample_count says ", sample_count(mesh, J));
        }
        std::vector<float> r(n), g(n), b(n);
        std::vector<int32_t> a(n), c(n);
        for (size_t i = 0; i < n; ++i) {
            r[i] = static_cast<float>(255 * uniform(rng));
            g[i] = static_cast<float>(255 * uniform(rng));
            b[i] = static_cast<float>(255 * uniform(rng));
            a[i] = static_cast<int32_t>(below(rng, 1 << 21)) - (1 << 20);
            c[i] = static_cast<int32_t>(below(rng, 256));
        }
        const auto r0 = r, g0 = g, b0 = b;
        const auto a0 = a, c0 = c;
        std::span<float> planes[] = {r, g, b};
        forward_transform(h, planes);
        inverse_transform(h, planes);
        for (size_t i = 0; i < n; ++i) {
            const float worst =
                std::max({std::abs(r[i] - r0[i]), std::abs(g[i] - g0[i]), std::abs(b[i] - b0[i])});
            if (!(worst <= 255 * 4e-6f))
                return str("level ", J, ": float sample ", i, " off by ", worst);
        }
        std::span<int32_t> ints[] = {a, c};
        forward_transform_int(h, ints, {.kernel = LiftingKernel::reference});
        inverse_transform_int(h, ints);
        if (a != a0 || c != c0) return str("level ", J, ": int round trip is not exact");
        if (J != 1) continue;
        const std::vector<Quad> quads = t1_quads(h, mesh.vertices);
        const QuadLocator locator(quads, mesh.width, mesh.height);
        const double diag = std::hypot(mesh.width, mesh.height);
        for (int k = 0; k < 16; ++k) {
            const Vec2 p{mesh.width * uniform(rng), mesh.height * uniform(rng)};
            const auto at = locator.locate(p);
            if (!at) continue;
            const UV uv = at->uv;
            if (!(uv.u >= 0 && uv.u <= 1 && uv.v >= 0 && uv.v <= 1)) {
                return str("locate(", p.x, ", ", p.y, "): uv (", uv.u, ", ", uv.v,
                           ") outside [0,1]");
            }
            if (!(norm(bilinear(quads[at->quad], uv.u, uv.v) - p) <= 1e-7 * diag)) {
                return str("locate(", p.x, ", ", p.y, "): the bilinear map does not return there");
            }
        }
    }
    return {};
}

// The pipeline for a Mesh, whether parsed or built: validate, then either the round trips or
// insist that every consumer refuses it.
void check_mesh(const Mesh& mesh, std::string_view input, Tally& tally, int max_level = 3) {
    ValidationReport report;
    const Outcome v = outcome_of([&] { report = validate(mesh); });
    if (v.kind != Outcome::returned) return tally.fail("validate threw", v.what, input);
    if (!report.ok()) {
        ++tally.invalid;
        for (const std::string& problem : report.problems) {
            tally.check_message("validate", problem, input);
        }
        const Outcome rv = outcome_of([&] { require_valid(mesh, "m.json"); });
        if (rv.kind != Outcome::error)
            return tally.fail("require_valid did not throw Error", rv.what, input);
        tally.check_message("require_valid", rv.what, input);
        const Outcome bh = outcome_of([&] { build_hierarchy(mesh, {.levels = 1}); });
        if (bh.kind != Outcome::error)
            return tally.fail("build_hierarchy did not throw Error", bh.what, input);
        const Outcome lc = outcome_of([&] { level_counts(mesh, 3); });
        if (lc.kind == Outcome::other) return tally.fail("level_counts", lc.what, input);
        return;
    }
    ++tally.valid;
    std::string problem;
    const Outcome rt = outcome_of([&] {
        problem = round_trip_problem(mesh, max_level, static_cast<uint64_t>(tally.valid));
        Mesh again = parse_mesh(mesh_to_json(mesh), "again.json");
        if (problem.empty() && !validate(again).ok()) problem = "mesh_to_json lost validity";
    });
    if (rt.kind != Outcome::returned) return tally.fail("valid mesh threw", rt.what, input);
    if (!problem.empty()) tally.fail("valid mesh", problem, input);
}

void check_mesh_text(std::string_view text, Tally& tally, int max_level = 3) {
    Mesh mesh;
    const Outcome p = outcome_of([&] { mesh = parse_mesh(text, "m.json"); });
    if (p.kind == Outcome::other) return tally.fail("parse_mesh", p.what, text);
    if (p.kind == Outcome::error) {
        ++tally.parse_errors;
        tally.check_message("parse_mesh", p.what, text);
        if (p.what.rfind("m.json", 0) != 0) tally.fail("parse_mesh", "message names no file", text);
        return;
    }
    check_mesh(mesh, text, tally, max_level);
}

// parse_points, triangulate_points in a 100 x 100 domain, then the mesh pipeline.
void check_points_text(std::string_view text, int border_points, Tally& tally) {
    std::vector<Vec2> points;
    const Outcome p = outcome_of([&] { points = parse_points(text, "p.txt"); });
    if (p.kind == Outcome::other) return tally.fail("parse_points", p.what, text);
    if (p.kind == Outcome::error) {
        ++tally.parse_errors;
        return tally.check_message("parse_points", p.what, text);
    }
    Mesh mesh;
    const Outcome t = outcome_of([&] {
        mesh = triangulate_points(100, 100, points, {.border_points_per_side = border_points});
    });
    if (t.kind == Outcome::other) return tally.fail("triangulate_points", t.what, text);
    if (t.kind == Outcome::error) {
        ++tally.invalid;
        return tally.check_message("triangulate_points", t.what, text);
    }
    const int before = tally.invalid;
    check_mesh(mesh, text, tally, 2);
    if (tally.invalid != before) tally.fail("triangulate_points", "returned an invalid mesh", text);
}

std::vector<Mesh> seed_meshes() {
    std::mt19937_64 rng(3);
    std::vector<Vec2> points;
    for (int i = 0; i < 9; ++i) points.push_back({5 + 90 * uniform(rng), 5 + 70 * uniform(rng)});
    return {samples::paper_t0(120, 90),
            samples::paper_t0_with_features(100, 80),
            grid_mesh(30, 20, 3, 2),
            testing::deformed_grid(50, 40, 4, 3, 0.2, 11),
            voronoi_mesh(100, 80, {.sites = 8, .seed = 7}),
            triangulate_points(100, 80, points, {.border_points_per_side = 1})};
}

// ---- Campaigns ----

TEST(Robustness, mutated_mesh_files_give_errors_or_valid_meshes) {
    Tally tally{"mesh files"};
    std::mt19937_64 rng(20240611);
    for (const Mesh& seed : seed_meshes()) {
        testing::expect_valid(seed);
        const std::string text = mesh_to_json(seed);
        tally.original = text;
        check_mesh_text(text, tally);
        for (int i = 0; i < 700; ++i) {
            std::string t = text;
            for (uint64_t k = 1 + below(rng, 3); k > 0; --k) t = mutate_text(std::move(t), rng);
            check_mesh_text(t, tally);
        }
        for (int i = 0; i < 500; ++i) {
            Mesh mesh = seed;
            for (uint64_t k = 1 + below(rng, 2); k > 0; --k) mutate_mesh(mesh, rng);
            std::string t = mesh_to_json(mesh);
            if (below(rng, 4) == 0) t = mutate_text(std::move(t), rng);
            check_mesh_text(t, tally);
        }
    }
    tally.report();
}

TEST(Robustness, every_truncation_of_a_mesh_file_is_a_parse_error) {
    Tally tally{"truncated mesh files"};
    for (const Mesh& seed : seed_meshes()) {
        const std::string text = mesh_to_json(seed);
        const size_t closing = text.rfind('}');
        for (size_t k = 0; k < closing; k += 3) {
            const int before = tally.parse_errors;
            check_mesh_text(std::string_view(text).substr(0, k), tally);
            if (tally.parse_errors == before)
                tally.fail("truncation", str("prefix of ", k, " bytes was accepted"), text);
        }
    }
    EXPECT_EQ(tally.failures, 0);
}

TEST(Robustness, corners_pushed_towards_a_straight_angle) {
    Tally tally{"near-degenerate corners"};
    const double offsets[] = {-1e-3, -1e-9, -1e-12, -1e-15, 0, 1e-15, 1e-12, 1e-9, 1e-6, 1e-3};
    for (const Mesh& seed : seed_meshes()) {
        const double diag = std::hypot(seed.width, seed.height);
        for (int f = 0; f < seed.num_faces(); ++f) {
            const auto face = seed.face(f);
            const size_t n = face.size();
            for (size_t i = 0; i < n; ++i) {
                const Vec2 prev = seed.vertices[face[(i + n - 1) % n]];
                const Vec2 next = seed.vertices[face[(i + 1) % n]];
                const Vec2 here = seed.vertices[face[i]];
                const Vec2 d = next - prev;
                const Vec2 foot = lerp(prev, next, dot(here - prev, d) / dot(d, d));
                const Vec2 out = (1 / norm(here - foot)) * (here - foot);  // towards the original
                for (double offset : offsets) {
                    Mesh mesh = seed;
                    mesh.vertices[face[i]] = foot + offset * diag * out;
                    check_mesh(mesh, str("face ", f, " corner ", i, " offset ", offset), tally, 2);
                }
            }
        }
    }
    tally.report();
}

TEST(Robustness, t_nodes_and_nearly_coincident_vertices) {
    Tally tally{"T-nodes and near duplicates"};
    std::mt19937_64 rng(77);
    const double params[] = {0.5, 1e-9, 1 - 1e-12, 0.25};
    const double offsets[] = {0, 1e-15, -1e-12, 1e-10, -1e-6, 1e-3};
    for (const Mesh& seed : seed_meshes()) {
        const double diag = std::hypot(seed.width, seed.height);
        const MeshEdges edges = build_edges(seed);
        for (int k = 0; k < 60; ++k) {
            const auto [a, b] = edges.vertices[below(rng, edges.vertices.size())];
            const int32_t v = static_cast<int32_t>(below(rng, seed.num_vertices()));
            const Vec2 pa = seed.vertices[a], pb = seed.vertices[b];
            const Vec2 normal = (1 / norm(pb - pa)) * Vec2{pa.y - pb.y, pb.x - pa.x};
            Mesh mesh = seed;
            Vec2& p = mesh.vertices[v];
            if (k % 2 == 0) {
                const double t = params[below(rng, 4)];  // one draw per statement: a fixed order
                p = lerp(pa, pb, t) + offsets[below(rng, 6)] * diag * normal;
            } else {
                p = pa + offsets[below(rng, 6)] * diag * normal;
            }
            check_mesh(mesh, str("vertex ", v, " near edge (", a, ", ", b, ") case ", k), tally, 2);
        }
    }
    // The textbook T-node: two squares on the left, one tall rectangle on the right.
    Mesh t;
    t.width = 2;
    t.height = 2;
    t.vertices = {{0, 0}, {1, 0}, {2, 0}, {0, 1}, {1, 1}, {0, 2}, {1, 2}, {2, 2}};
    t.add_face(std::vector<int32_t>{0, 3, 4, 1});
    t.add_face(std::vector<int32_t>{3, 5, 6, 4});
    t.add_face(std::vector<int32_t>{1, 6, 7, 2});
    EXPECT_FALSE(validate(t).ok());
    check_mesh(t, "textbook T-node", tally);
    t.face_corners = {0, 1, 4, 3, 3, 4, 6, 5, 1, 2, 7, 6, 4};  // the right face lists the T vertex
    t.face_offsets = {0, 4, 8, 13};
    check_mesh(t, "T vertex as a straight corner", tally);
    tally.report();
}

TEST(Robustness, extreme_and_non_finite_coordinates) {
    Tally tally{"extreme coordinates"};
    const double sizes[] = {1e-310, 1e-300, 1e-150, 1e-6, 1, 1e6, 1e150, 1e200, 1e300, 1.7e308};
    for (double s : sizes) {
        for (const Mesh& mesh : {samples::paper_t0(s, 0.75 * s), grid_mesh(s, s, 3, 2)}) {
            check_mesh(mesh, str("domain ", s), tally, 2);
            check_mesh_text(mesh_to_json(mesh), tally, 2);
        }
    }
    const double specials[] = {kNaN, kInf, -kInf, -0.0, -1e-300, 5e-324, 1e308, -1};
    for (double x : specials) {
        Mesh mesh = samples::paper_t0(120, 90);
        mesh.vertices[6].x = x;  // an interior vertex
        check_mesh(mesh, str("vertex 6 x = ", x), tally);
        mesh = samples::paper_t0(120, 90);
        mesh.vertices[0].y = x;  // a domain corner
        check_mesh(mesh, str("vertex 0 y = ", x), tally);
        mesh = samples::paper_t0(120, 90);
        mesh.width = x;
        check_mesh(mesh, str("width = ", x), tally);
    }
    tally.report();
}

TEST(Robustness, random_feature_sets) {
    Tally tally{"feature sets"};
    std::mt19937_64 rng(5);
    for (const Mesh& seed : seed_meshes()) {
        const MeshEdges edges = build_edges(seed);
        for (int k = 0; k < 80; ++k) {
            Mesh mesh = seed;
            mesh.features.clear();
            for (uint64_t m = 1 + below(rng, 6); m > 0; --m) {
                auto e = edges.vertices[below(rng, edges.vertices.size())];
                if (below(rng, 3) == 0) std::swap(e[0], e[1]);
                mesh.features.push_back(e);
            }
            check_mesh(mesh, str("features case ", k), tally, 2);
        }
    }
    tally.report();
}

TEST(Robustness, mutated_point_lists) {
    Tally tally{"point lists"};
    std::mt19937_64 rng(9);
    std::vector<std::string> seeds;
    for (int n : {3, 8, 20}) {
        std::string lines = "# x y\n", json = "[";
        for (int i = 0; i < n; ++i) {
            const double x = 100 * uniform(rng), y = 100 * uniform(rng);
            lines += str(x, " ", y, i % 3 ? "\n" : "  # a comment\n");
            json += str(i ? ", [" : "[", x, ", ", y, "]");
        }
        seeds.push_back(lines);
        seeds.push_back(json + "]");
    }
    seeds.push_back("10 10\n10 20\n10 30\n10 40\n");          // collinear
    seeds.push_back("25 25\n75 25\n75 75\n25 75\n50 50\n");   // co-circular, and its centre
    seeds.push_back("0 0\n100 100\n0 50\n50 0\n100 37.5\n");  // on corners and sides
    for (const std::string& seed : seeds) {
        tally.original = seed;
        check_points_text(seed, 0, tally);
        for (int i = 0; i < 250; ++i) {
            std::string t = seed;
            for (uint64_t k = 1 + below(rng, 2); k > 0; --k) t = mutate_text(std::move(t), rng);
            check_points_text(t, static_cast<int>(below(rng, 3)), tally);
        }
    }
    tally.report();
}

TEST(Robustness, degenerate_point_sets) {
    Tally tally{"degenerate point sets"};
    std::vector<std::vector<Vec2>> sets = {
        {},
        {{50, 50}, {50, 50}},
        {{50, 50}, {50, 50 + 1e-13}},
        {{50, 50}, {50 + 1e-7, 50}},
        {{0, 0}, {100, 0}, {100, 100}, {0, 100}},
        {{-1, 50}},
        {{50, 100.0000001}},
        {{kNaN, 1}},
        {{1, kInf}},
        {{1e-300, 1e-300}, {2e-300, 1e-300}},
        {{50, 1e-12}, {50, 100 - 1e-12}, {1e-12, 50}},
    };
    std::vector<Vec2> grid, circle, line;
    for (int i = 0; i < 49; ++i) grid.push_back({10.0 + 10 * (i % 7), 10.0 + 10 * (i / 7)});
    for (int i = 0; i < 24; ++i) {
        circle.push_back({50 + 40 * std::cos(i * std::numbers::pi / 12),
                          50 + 40 * std::sin(i * std::numbers::pi / 12)});
    }
    for (int i = 1; i < 40; ++i) line.push_back({2.5 * i, 2.5 * i});
    sets.push_back(grid);
    sets.push_back(circle);
    sets.push_back(line);
    for (const auto& points : sets) {
        for (int border : {0, 1, 3}) {
            std::string text;
            for (Vec2 p : points) text += str(p.x, " ", p.y, "\n");
            Mesh mesh;
            const Outcome t = outcome_of([&] {
                mesh = triangulate_points(100, 100, points, {.border_points_per_side = border});
            });
            if (t.kind == Outcome::other) tally.fail("triangulate_points", t.what, text);
            if (t.kind == Outcome::error) ++tally.invalid;
            if (t.kind == Outcome::returned) check_mesh(mesh, text, tally, 2);
        }
    }
    for (int border : {-1, 1 << 30}) {
        const Outcome t = outcome_of(
            [&] { triangulate_points(100, 100, {}, {.border_points_per_side = border}); });
        if (t.kind != Outcome::error)
            tally.fail("border_points_per_side", str(border, " accepted"), "");
    }
    for (double size : {0.0, -1.0, kNaN, kInf}) {
        const Outcome t = outcome_of([&] { triangulate_points(size, 100, {}); });
        if (t.kind != Outcome::error)
            tally.fail("triangulate_points domain", str(size, " accepted"), "");
    }
    tally.report();
}

TEST(Robustness, generator_and_transform_options) {
    Tally tally{"options"};
    auto expect_error = [&](const char* what, auto&& call) {
        const Outcome o = outcome_of(call);
        if (o.kind != Outcome::error) return tally.fail(what, "no Error: " + o.what, what);
        ++tally.invalid;
        tally.check_message(what, o.what, what);
    };
    for (double s : {0.0, -1.0, kNaN, kInf}) {
        expect_error("voronoi domain", [&] { voronoi_mesh(s, 10); });
        expect_error("grid domain", [&] { grid_mesh(10, s, 2, 2); });
    }
    expect_error("voronoi sites 0", [] { voronoi_mesh(10, 10, {.sites = 0}); });
    expect_error("voronoi sites -5", [] { voronoi_mesh(10, 10, {.sites = -5}); });
    expect_error("voronoi lloyd -1", [] { voronoi_mesh(10, 10, {.lloyd_iterations = -1}); });
    expect_error("grid cells 0", [] { grid_mesh(10, 10, 0, 3); });
    expect_error("grid cells huge", [] { grid_mesh(10, 10, 1 << 30, 1 << 30); });
    for (double s : {1e-6, 1e6}) {
        for (int sites : {1, 2, 5, 40}) {
            Mesh mesh;
            const Outcome o = outcome_of(
                [&] { mesh = voronoi_mesh(s, 0.5 * s, {.sites = sites, .lloyd_iterations = 1}); });
            if (o.kind == Outcome::other) tally.fail("voronoi_mesh", o.what, str(s, " ", sites));
            if (o.kind == Outcome::error) ++tally.invalid;
            if (o.kind == Outcome::returned)
                check_mesh(mesh, str("voronoi ", s, " ", sites), tally, 2);
        }
    }
    const Mesh mesh = samples::paper_t0_with_features(100, 80);
    for (int levels : {-1, 17, 1000, std::numeric_limits<int>::min()}) {
        expect_error("levels", [&] { build_hierarchy(mesh, {.levels = levels}); });
    }
    expect_error("max_samples", [&] { build_hierarchy(mesh, {.levels = 2, .max_samples = 10}); });
    expect_error("levels 16", [&] { build_hierarchy(mesh, {.levels = 16}); });
    const Hierarchy h = build_hierarchy(mesh, {.levels = 2});
    std::vector<float> short_plane(h.num_samples(2) - 1), plane(h.num_samples(2));
    std::vector<int32_t> long_plane(h.num_samples(2) + 1);
    std::span<float> bad[] = {plane, short_plane};
    std::span<float> good[] = {plane};
    std::span<int32_t> bad_int[] = {long_plane};
    expect_error("short plane", [&] { forward_transform(h, bad); });
    expect_error("short plane inverse", [&] { inverse_transform(h, bad); });
    expect_error("long int plane", [&] { forward_transform_int(h, bad_int); });
    expect_error("steps", [&] { forward_transform(h, good, {.steps = 3}); });
    expect_error("steps inverse", [&] { inverse_transform(h, good, {.steps = 3}); });
    ++tally.valid;  // the well-formed calls above returned
    tally.report();
}

TEST(Robustness, quad_location_in_convex_quads) {
    std::mt19937_64 rng(4);
    const Mesh mesh = testing::deformed_grid(60, 40, 6, 4, 0.24, 8);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 1});
    const std::vector<Quad> quads = t1_quads(h, mesh.vertices);
    const QuadLocator locator(quads, 60, 40);
    for (int k = 0; k < 2000; ++k) {
        const Vec2 p{60 * uniform(rng), 40 * uniform(rng)};
        const auto at = locator.locate(p);
        ASSERT_TRUE(at) << p.x << ", " << p.y;
        EXPECT_LE(norm(bilinear(quads[at->quad], at->uv.u, at->uv.v) - p), 1e-9);
        // Any point, inside or far outside, maps into the unit square of any convex quad.
        const Vec2 far{1e4 * (uniform(rng) - 0.5), 1e4 * (uniform(rng) - 0.5)};
        const UV uv = inverse_bilinear(quads[below(rng, quads.size())], far);
        ASSERT_TRUE(uv.u >= 0 && uv.u <= 1 && uv.v >= 0 && uv.v <= 1) << uv.u << ", " << uv.v;
    }
    for (Vec2 p : {Vec2{kNaN, 1}, Vec2{1, kInf}, Vec2{-1, 1}, Vec2{61, 1}, Vec2{1e300, 1e300}}) {
        EXPECT_FALSE(locator.locate(p)) << p.x << ", " << p.y;
    }
}

}  // namespace
}  // namespace tesswave
