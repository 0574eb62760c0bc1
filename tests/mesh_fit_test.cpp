#include "core/fit/mesh_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "core/math/hierarchy.h"
#include "core/math/parametrization.h"
#include "core/math/voronoi.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using testing::error_of;
using testing::expect_valid;
using testing::uniform;

// A smooth warp of [0,W]x[0,H] onto itself: no motion across the border, corners fixed.
Vec2 warp(Vec2 p, double width, double height, double amplitude) {
    const double pi = std::numbers::pi;
    return {p.x + amplitude * std::sin(pi * p.x / width) * std::sin(2 * pi * p.y / height),
            p.y + amplitude * std::sin(pi * p.y / height) * std::sin(2 * pi * p.x / width)};
}

std::vector<Vec2> random_points(double width, double height, int count, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::vector<Vec2> points(count);
    for (Vec2& p : points) p = {width * uniform(rng), height * uniform(rng)};
    return points;
}

double rms_distance(std::span<const Vec2> a, std::span<const Vec2> b) {
    double sum = 0;
    for (size_t i = 0; i < a.size(); ++i) sum += dot(a[i] - b[i], a[i] - b[i]);
    return std::sqrt(sum / a.size());
}

Mesh with_vertices(Mesh mesh, std::vector<Vec2> vertices, double width, double height) {
    mesh.vertices = std::move(vertices);
    mesh.width = width, mesh.height = height;
    return mesh;
}

struct WarpCase {
    Mesh mesh;
    std::vector<Vec2> a, b, truth;  // correspondences, and the warped vertices
};

WarpCase warp_case(double width, double height, int cols, int rows, int count, uint64_t seed) {
    WarpCase c{
        grid_mesh(width, height, cols, rows), random_points(width, height, count, seed), {}, {}};
    for (Vec2 p : c.a) c.b.push_back(warp(p, width, height, 4.0));
    for (Vec2 p : c.mesh.vertices) c.truth.push_back(warp(p, width, height, 4.0));
    return c;
}

TEST(MeshFit, pinned_points_round_trip_and_match_the_t1_quads) {
    const Mesh mesh = voronoi_mesh(320, 240, {.sites = 30, .seed = 4});
    expect_valid(mesh);
    std::vector<Vec2> points = random_points(320, 240, 500, 5);
    points.push_back({0, 0});
    points.push_back({320, 240});
    points.push_back({-1, 3});
    points.push_back({NAN, 3});
    const auto pins = pin_points(mesh, points);
    const Hierarchy h = build_hierarchy(mesh, {.levels = 1});
    const std::vector<Quad> quads = t1_quads(h, mesh.vertices);
    for (size_t k = 0; k + 2 < points.size(); ++k) {
        ASSERT_TRUE(pins[k].has_value()) << k;
        const Vec2 p = pinned_position(mesh, mesh.vertices, *pins[k]);
        EXPECT_NEAR(p.x, points[k].x, 1e-9);
        EXPECT_NEAR(p.y, points[k].y, 1e-9);
        // Under other positions too it is the bilinear map of the hierarchy's T1 quad.
        std::vector<Vec2> moved = mesh.vertices;
        for (Vec2& v : moved) v = warp(v, 320, 240, 6.0);
        const Vec2 q = pinned_position(mesh, moved, *pins[k]);
        const Vec2 r = bilinear(t1_quads(h, moved)[pins[k]->quad], pins[k]->u, pins[k]->v);
        EXPECT_NEAR(q.x, r.x, 1e-9);
        EXPECT_NEAR(q.y, r.y, 1e-9);
        EXPECT_EQ(quads.size(), mesh.face_corners.size());
    }
    EXPECT_FALSE(pins[points.size() - 2].has_value());
    EXPECT_FALSE(pins[points.size() - 1].has_value());
    EXPECT_NE(error_of([&] {
                  pinned_position(mesh, mesh.vertices, {0, 999, 0.5, 0.5});
              }),
              "(no error)");
}

TEST(MeshFit, identity_returns_the_mesh) {
    for (const Mesh& mesh : {grid_mesh(320, 240, 8, 6), voronoi_mesh(320, 240, {.sites = 40})}) {
        expect_valid(mesh);
        const std::vector<Vec2> points = random_points(320, 240, 300, 7);
        const MeshFitResult fit = fit_mesh(mesh, points, points, 320, 240);
        ASSERT_EQ(fit.vertices.size(), mesh.vertices.size());
        for (size_t v = 0; v < fit.vertices.size(); ++v) {
            EXPECT_NEAR(fit.vertices[v].x, mesh.vertices[v].x, 1e-6);
            EXPECT_NEAR(fit.vertices[v].y, mesh.vertices[v].y, 1e-6);
        }
        EXPECT_LT(fit.rms, 1e-6);
        EXPECT_EQ(fit.inliers, 300);
        EXPECT_EQ(fit.outliers, 0);
    }
}

TEST(MeshFit, recovers_a_smooth_warp) {
    const WarpCase c = warp_case(320, 240, 8, 6, 300, 11);
    for (Rigidity rigidity : {Rigidity::as_similar, Rigidity::as_rigid}) {
        const MeshFitResult fit = fit_mesh(c.mesh, c.a, c.b, 320, 240, {.rigidity = rigidity});
        expect_valid(with_vertices(c.mesh, fit.vertices, 320, 240));
        EXPECT_LT(rms_distance(fit.vertices, c.truth), 0.5);
        EXPECT_LT(fit.rms, 0.5);
        EXPECT_EQ(fit.outliers, 0);
        EXPECT_GT(fit.iterations, 0);
    }
}

// A step tolerance stops the solver early, with the vertices within a few times that tolerance
// of the full fit's (the steps shrink geometrically); no tolerance leaves the fit as it was.
TEST(MeshFit, a_step_tolerance_stops_early_close_to_the_full_fit) {
    // Every third match 15 px off at most: the Cauchy loss makes the full fit creep.
    WarpCase c = warp_case(320, 240, 16, 12, 600, 14);
    std::mt19937_64 rng(15);
    for (size_t k = 0; k < c.b.size(); k += 3)
        c.b[k] = c.b[k] + Vec2{30 * (uniform(rng) - 0.5), 30 * (uniform(rng) - 0.5)};
    const MeshFitResult full = fit_mesh(c.mesh, c.a, c.b, 320, 240);
    const MeshFitResult same = fit_mesh(c.mesh, c.a, c.b, 320, 240, {.step_tolerance = 0});
    EXPECT_EQ(same.vertices, full.vertices);
    const MeshFitResult early = fit_mesh(c.mesh, c.a, c.b, 320, 240, {.step_tolerance = 0.05});
    ASSERT_TRUE(early.ok()) << early.failure;
    expect_valid(with_vertices(c.mesh, early.vertices, 320, 240));
    EXPECT_LT(early.iterations, full.iterations);
    double largest = 0;
    for (size_t v = 0; v < full.vertices.size(); ++v)
        largest = std::max(largest, norm(early.vertices[v] - full.vertices[v]));
    EXPECT_LT(largest, 0.1);
    EXPECT_NE(error_of([&] {
                  fit_mesh(c.mesh, c.a, c.b, 320, 240, {.step_tolerance = -1});
              }).find("step_tolerance"),
              std::string::npos);
}

TEST(MeshFit, scales_to_another_image_size) {
    const Mesh mesh = voronoi_mesh(320, 240, {.sites = 40, .seed = 3});
    expect_valid(mesh);
    const std::vector<Vec2> a = random_points(320, 240, 300, 8);
    std::vector<Vec2> b;
    for (Vec2 p : a) b.push_back(1.25 * p);
    const MeshFitResult fit = fit_mesh(mesh, a, b, 400, 300);
    expect_valid(with_vertices(mesh, fit.vertices, 400, 300));
    int on_border = 0;
    for (size_t v = 0; v < fit.vertices.size(); ++v) {
        const Vec2 p = mesh.vertices[v], q = fit.vertices[v];
        EXPECT_NEAR(q.x, 1.25 * p.x, 1e-6);
        EXPECT_NEAR(q.y, 1.25 * p.y, 1e-6);
        if (p.x == 0 || p.x == 320) {
            EXPECT_EQ(q.x, p.x == 0 ? 0.0 : 400.0);
        }
        if (p.y == 0 || p.y == 240) {
            EXPECT_EQ(q.y, p.y == 0 ? 0.0 : 300.0);
        }
        on_border += p.x == 0 || p.x == 320 || p.y == 0 || p.y == 240;
    }
    EXPECT_GT(on_border, 4);  // border vertices besides the corners, which slide
}

TEST(MeshFit, robust_to_outliers) {
    WarpCase c = warp_case(320, 240, 8, 6, 300, 12);
    std::mt19937_64 rng(13);
    std::vector<size_t> far;  // replaced by a point well away from the true match
    for (size_t k = 0; k < c.b.size(); k += 10) {
        const Vec2 wrong{320 * uniform(rng), 240 * uniform(rng)};
        if (norm(wrong - c.b[k]) > 20) far.push_back(k);
        c.b[k] = wrong;
    }
    ASSERT_GT(far.size(), 25u);
    const MeshFitResult fit = fit_mesh(c.mesh, c.a, c.b, 320, 240);
    expect_valid(with_vertices(c.mesh, fit.vertices, 320, 240));
    EXPECT_LT(rms_distance(fit.vertices, c.truth), 0.5);
    EXPECT_LT(fit.rms, 0.5);
    EXPECT_LE(fit.outliers, 30);
    for (size_t k : far) EXPECT_GT(fit.residuals[k], 9.0) << k;  // outlier_factor x robust_scale
    EXPECT_EQ(fit.inliers + fit.outliers, 300);
}

// Whatever the matches ask for, the result is a valid mesh or says "no valid mesh fits".
void expect_valid_or_refused(const Mesh& mesh, std::span<const Vec2> a, std::span<const Vec2> b,
                             double width, double height, const MeshFitOptions& options) {
    const MeshFitResult fit = fit_mesh(mesh, a, b, width, height, options);
    if (fit.ok()) {
        expect_valid(with_vertices(mesh, fit.vertices, width, height));
    } else {
        EXPECT_EQ(fit.failure.rfind("no valid mesh fits", 0), 0u) << fit.failure;
        EXPECT_TRUE(fit.vertices.empty());
    }
}

TEST(MeshFit, never_returns_a_folded_mesh) {
    // Vertices 6 and 7 of a 4x3 grid (neighbours in the middle row) asked to trade places, by
    // matches near them that outnumber the others and, with a huge robust scale, are never
    // discounted as outliers.
    const Mesh mesh = grid_mesh(320, 240, 4, 3);
    const Vec2 p6 = mesh.vertices[6], p7 = mesh.vertices[7];
    std::vector<Vec2> a, b;
    for (Vec2 p : random_points(320, 240, 20, 14)) a.push_back(p), b.push_back(p);
    for (int k = 0; k < 20; ++k) {
        const Vec2 d{(k % 5 - 2) * 0.5, (k / 5 - 2) * 0.5};
        a.push_back(p6 + d), b.push_back(p7 + d);
        a.push_back(p7 + d), b.push_back(p6 + d);
    }
    ::testing::internal::CaptureStderr();  // rejected steps must not be logged either
    for (Rigidity rigidity : {Rigidity::as_similar, Rigidity::as_rigid}) {
        for (double weight : {0.0, 0.1}) {
            for (double scale : {3.0, 1000.0}) {
                expect_valid_or_refused(mesh, a, b, 320, 240,
                                        {.rigidity = rigidity,
                                         .rigidity_weight = weight,
                                         .smoothness_weight = weight,
                                         .robust_scale = scale});
            }
        }
    }
    // Demands no mesh can meet: random matches, mirror images, large rotations, wild warps.
    for (uint64_t trial = 0; trial < 24; ++trial) {
        std::mt19937_64 rng(100 + trial);
        const Mesh m = trial % 2
                           ? grid_mesh(320, 240, 2 + trial % 5, 2 + trial % 3)
                           : voronoi_mesh(320, 240, {.sites = 10 + int(trial), .seed = trial});
        const double angle = (uniform(rng) - 0.5) * 3;
        std::vector<Vec2> pa = random_points(320, 240, 60, trial), pb;
        for (Vec2 p : pa) {
            const Vec2 d = p - Vec2{160, 120};
            switch (trial % 4) {
                case 0:
                    pb.push_back({320 * uniform(rng), 240 * uniform(rng)});
                    break;
                case 1:
                    pb.push_back({320 - p.x, p.y});
                    break;
                case 2:
                    pb.push_back({160 + std::cos(angle) * d.x - std::sin(angle) * d.y,
                                  120 + std::sin(angle) * d.x + std::cos(angle) * d.y});
                    break;
                default:
                    pb.push_back({p.x + 60 * std::sin(p.y / 20), p.y + 60 * std::cos(p.x / 25)});
            }
        }
        expect_valid_or_refused(
            m, pa, pb, 320, 240,
            {.rigidity_weight = 0.05 * (trial % 3), .robust_scale = 20, .max_iterations = 50});
    }
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(MeshFit, rejects_bad_input) {
    const Mesh mesh = grid_mesh(320, 240, 4, 3);
    const std::vector<Vec2> two{{10, 10}, {20, 30}}, three{{10, 10}, {20, 30}, {200, 100}};
    auto expect_error = [&](auto&& call, const std::string& part) {
        const std::string message = error_of(call);
        EXPECT_NE(message.find(part), std::string::npos) << message;
    };
    expect_error([&] { fit_mesh(mesh, two, two, 320, 240); }, "at least 3");
    expect_error([&] { fit_mesh(mesh, three, two, 320, 240); }, "in pairs");
    std::vector<Vec2> nan = three;
    nan[1].y = NAN;
    expect_error([&] { fit_mesh(mesh, three, nan, 320, 240); }, "correspondence 1");
    expect_error([&] { fit_mesh(mesh, nan, three, 320, 240); }, "correspondence 1");
    std::vector<Vec2> outside = three;
    outside[2] = {330, 10};
    expect_error([&] { fit_mesh(mesh, outside, three, 320, 240); }, "point 2");
    expect_error([&] { fit_mesh(mesh, three, three, 0, 240); }, "domain");
    expect_error([&] { fit_mesh(mesh, three, three, 320, 240, {.robust_scale = 0}); },
                 "robust_scale");
    expect_error([&] { fit_mesh(mesh, three, three, 320, 240, {.temporal_weight = 1}); },
                 "previous");
    Mesh broken = mesh;
    broken.vertices[6].x = 200;  // folds faces
    expect_error([&] { fit_mesh(broken, three, three, 320, 240); }, "mesh A");
    // Three matches that no mesh can follow: all three end up outliers.
    const std::vector<Vec2> far{{300, 200}, {10, 220}, {300, 10}};
    const MeshFitResult refused = fit_mesh(mesh, three, far, 320, 240, {.robust_scale = 0.5});
    EXPECT_EQ(refused.failure.rfind("no valid mesh fits", 0), 0u) << refused.failure;
}

TEST(MeshFit, temporal_term_holds_unconstrained_vertices) {
    const Mesh mesh = grid_mesh(320, 240, 8, 6);
    std::vector<Vec2> previous;
    for (Vec2 p : mesh.vertices) previous.push_back(warp(p, 320, 240, 4.0));
    // Matches only in the left half; the right half follows the previous frame.
    std::vector<Vec2> a = random_points(160, 240, 100, 15), b = a;
    const MeshFitResult fit =
        fit_mesh(mesh, a, b, 320, 240, {.previous = previous, .temporal_weight = 100});
    for (size_t v = 0; v < previous.size(); ++v) {
        if (mesh.vertices[v].x > 200) {
            EXPECT_LT(norm(fit.vertices[v] - previous[v]), 0.1) << v;
        }
    }
}

TEST(MeshFit, previous_vertices_only_move_the_start) {
    const WarpCase c = warp_case(320, 240, 8, 6, 300, 18);
    const MeshFitResult cold = fit_mesh(c.mesh, c.a, c.b, 320, 240);
    const MeshFitResult warm = fit_mesh(c.mesh, c.a, c.b, 320, 240, {.previous = c.truth});
    EXPECT_LT(rms_distance(cold.vertices, warm.vertices), 1e-4);
}

TEST(MeshFit, is_silent_and_reports_progress) {
    const WarpCase c = warp_case(320, 240, 8, 6, 100, 16);
    double last = -1;
    int calls = 0;
    ::testing::internal::CaptureStderr();
    ::testing::internal::CaptureStdout();
    fit_mesh(c.mesh, c.a, c.b, 320, 240, {.progress = [&](double done, const char*) {
                 EXPECT_GE(done, last);
                 last = done, ++calls;
             }});
    EXPECT_EQ(::testing::internal::GetCapturedStdout(), "");
    EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
    EXPECT_GT(calls, 2);
    EXPECT_EQ(last, 1.0);
}

// The size of a video frame or morph pair: 16x12 cells, 2000 tracks (about 10 ms here).
TEST(MeshFit, fits_a_vga_pair) {
    const WarpCase c = warp_case(640, 480, 16, 12, 2000, 17);
    const MeshFitResult fit = fit_mesh(c.mesh, c.a, c.b, 640, 480);
    expect_valid(with_vertices(c.mesh, fit.vertices, 640, 480));
    EXPECT_LT(rms_distance(fit.vertices, c.truth), 0.5);
}

}  // namespace
}  // namespace tesswave
