// Tests of the procedural mesh generators: random Voronoi tessellations and Delaunay
// triangulations of point sets.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/math/error.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "core/math/voronoi.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

double unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

void expect_valid(const Mesh& mesh, const std::string& what) {
    ValidationReport report = validate(mesh);
    EXPECT_TRUE(report.ok()) << what << ": " << (report.ok() ? "" : report.problems.front());
}

double total_area(const Mesh& mesh) {
    double sum = 0;
    for (int f = 0; f < mesh.num_faces(); ++f) {
        EXPECT_GT(face_signed_area(mesh, f), 0) << "face " << f;
        sum += face_signed_area(mesh, f);
    }
    return sum;
}

int border_vertices(const Mesh& mesh) {
    int count = 0;
    for (Vec2 p : mesh.vertices) {
        count += p.x == 0 || p.y == 0 || p.x == mesh.width || p.y == mesh.height;
    }
    return count;
}

using tesswave::testing::error_of;

TEST(Voronoi, valid_for_many_seeds_sizes_and_relaxations) {
    const double w = 320, h = 200;
    for (int sites : {1, 2, 3, 10, 100, 1000}) {
        for (int lloyd : {0, 3}) {
            for (uint64_t seed = 1; seed <= 50; ++seed) {
                Mesh mesh =
                    voronoi_mesh(w, h, {.sites = sites, .seed = seed, .lloyd_iterations = lloyd});
                const std::string what = "sites " + std::to_string(sites) + " seed " +
                                         std::to_string(seed) + " lloyd " + std::to_string(lloyd);
                expect_valid(mesh, what);
                EXPECT_EQ(mesh.num_faces(), sites) << what;
                EXPECT_NEAR(total_area(mesh), w * h, 1e-9 * w * h) << what;
            }
        }
    }
}

TEST(Voronoi, valid_for_unusual_domains_and_many_sites) {
    struct Case {
        double w, h;
        int sites, lloyd;
    };
    for (Case c : {Case{1, 1, 500, 0}, Case{1e-3, 2e-3, 300, 2}, Case{4000, 10, 2000, 1},
                   Case{10, 4000, 2000, 0}, Case{1e6, 1e6, 20000, 0}, Case{640, 480, 20000, 1}}) {
        Mesh mesh =
            voronoi_mesh(c.w, c.h, {.sites = c.sites, .seed = 7, .lloyd_iterations = c.lloyd});
        expect_valid(mesh, std::to_string(c.w) + " x " + std::to_string(c.h));
        EXPECT_EQ(mesh.num_faces(), c.sites);
        EXPECT_NEAR(total_area(mesh), c.w * c.h, 1e-9 * c.w * c.h);
    }
}

TEST(Voronoi, same_seed_gives_identical_mesh) {
    const VoronoiOptions options{.sites = 500, .seed = 42, .lloyd_iterations = 2};
    Mesh a = voronoi_mesh(100, 80, options);
    Mesh b = voronoi_mesh(100, 80, options);
    ASSERT_EQ(a.num_vertices(), b.num_vertices());
    for (int v = 0; v < a.num_vertices(); ++v) EXPECT_TRUE(a.vertices[v] == b.vertices[v]);
    EXPECT_EQ(a.face_offsets, b.face_offsets);
    EXPECT_EQ(a.face_corners, b.face_corners);
    Mesh c = voronoi_mesh(100, 80, {.sites = 500, .seed = 43, .lloyd_iterations = 2});
    EXPECT_FALSE(a.vertices.size() == c.vertices.size() && a.face_corners == c.face_corners &&
                 a.vertices[10] == c.vertices[10]);
}

// Sites follow the documented formula, so the test can rebuild them: every corner of cell f is
// no farther from site f than from any other site, and site f lies inside cell f.
TEST(Voronoi, faces_are_the_voronoi_cells_of_the_documented_sites) {
    const double w = 50, h = 30;
    const int count = 200;
    std::mt19937_64 rng(9);
    std::vector<Vec2> sites(count);
    for (Vec2& s : sites) s = {w * unit(rng), h * unit(rng)};
    Mesh mesh = voronoi_mesh(w, h, {.sites = count, .seed = 9});
    ASSERT_EQ(mesh.num_faces(), count);
    for (int f = 0; f < count; ++f) {
        auto corners = mesh.face(f);
        for (size_t i = 0; i < corners.size(); ++i) {
            const Vec2 p = mesh.vertices[corners[i]];
            const Vec2 q = mesh.vertices[corners[(i + 1) % corners.size()]];
            EXPECT_GT(cross(q - p, sites[f] - p), 0) << "site " << f << " outside its cell";
            for (int g = 0; g < count; ++g) {
                EXPECT_LE(norm(p - sites[f]), norm(p - sites[g]) + 1e-9) << "cell " << f;
            }
        }
    }
}

TEST(Voronoi, lloyd_relaxation_evens_out_cell_areas) {
    auto area_spread = [](const Mesh& mesh) {
        double sum = 0, sum2 = 0;
        for (int f = 0; f < mesh.num_faces(); ++f) {
            sum += face_signed_area(mesh, f);
            sum2 += face_signed_area(mesh, f) * face_signed_area(mesh, f);
        }
        const double mean = sum / mesh.num_faces();
        return std::sqrt(sum2 / mesh.num_faces() - mean * mean) / mean;
    };
    const double raw = area_spread(voronoi_mesh(100, 100, {.sites = 400, .seed = 3}));
    const double relaxed =
        area_spread(voronoi_mesh(100, 100, {.sites = 400, .seed = 3, .lloyd_iterations = 20}));
    EXPECT_GT(raw, 0.3);  // Poisson-Voronoi cells: coefficient of variation about 0.53
    EXPECT_LT(relaxed, 0.5 * raw);
}

TEST(Voronoi, rejects_bad_arguments) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    EXPECT_THROW(voronoi_mesh(100, 100, {.sites = 0}), Error);
    EXPECT_THROW(voronoi_mesh(100, 100, {.sites = -5}), Error);
    EXPECT_THROW(voronoi_mesh(100, 100, {.sites = 10'000'001}), Error);
    EXPECT_THROW(voronoi_mesh(100, 100, {.lloyd_iterations = -1}), Error);
    EXPECT_THROW(voronoi_mesh(0, 100), Error);
    EXPECT_THROW(voronoi_mesh(100, nan), Error);
    EXPECT_NE(error_of([] { voronoi_mesh(100, 100, {.sites = 0}); }).find("sites"),
              std::string::npos);
}

void expect_triangulation(const Mesh& mesh, std::span<const Vec2> points, const std::string& what) {
    expect_valid(mesh, what);
    EXPECT_NEAR(total_area(mesh), mesh.width * mesh.height, 1e-9 * mesh.width * mesh.height);
    // Euler's formula for a triangulated disk: F = 2V - B - 2 with B vertices on the border.
    EXPECT_EQ(mesh.num_faces(), 2 * mesh.num_vertices() - border_vertices(mesh) - 2) << what;
    for (int f = 0; f < mesh.num_faces(); ++f) EXPECT_EQ(mesh.face(f).size(), 3u);
    for (size_t i = 0; i < points.size(); ++i) EXPECT_TRUE(mesh.vertices[i] == points[i]) << what;
}

// No vertex strictly inside a circumcircle, up to rounding of the circumcentre.
void expect_empty_circumcircles(const Mesh& mesh) {
    for (int f = 0; f < mesh.num_faces(); ++f) {
        auto t = mesh.face(f);
        const Vec2 a = mesh.vertices[t[0]], b = mesh.vertices[t[1]] - a,
                   c = mesh.vertices[t[2]] - a;
        const double d = 2 * cross(b, c);
        const Vec2 centre = a + (1 / d) * Vec2{c.y * dot(b, b) - b.y * dot(c, c),
                                               b.x * dot(c, c) - c.x * dot(b, b)};
        const double r = norm(a - centre);
        for (const Vec2& p : mesh.vertices) EXPECT_GE(norm(p - centre), r * (1 - 1e-9));
    }
}

TEST(Triangulate, no_points_gives_two_triangles) {
    Mesh mesh = triangulate_points(640, 480, {});
    expect_triangulation(mesh, {}, "empty");
    EXPECT_EQ(mesh.num_faces(), 2);
    EXPECT_EQ(mesh.num_vertices(), 4);
}

TEST(Triangulate, random_points) {
    for (int count : {1, 2, 10, 100, 2000}) {
        for (uint64_t seed = 1; seed <= 10; ++seed) {
            std::mt19937_64 rng(seed);
            std::vector<Vec2> points(count);
            for (Vec2& p : points) p = {640 * unit(rng), 480 * unit(rng)};
            Mesh mesh =
                triangulate_points(640, 480, points, {.border_points_per_side = int(seed % 4)});
            expect_triangulation(mesh, points, "random " + std::to_string(count));
            if (count <= 100) expect_empty_circumcircles(mesh);
        }
    }
}

TEST(Triangulate, regular_grids_with_cocircular_points) {
    std::vector<Vec2> inner, full;
    for (int j = 0; j < 5; ++j) {
        for (int i = 0; i < 5; ++i) {
            inner.push_back({20.0 * i + 10, 20.0 * j + 10});
            full.push_back({25.0 * i, 25.0 * j});  // includes the corners and border points
        }
    }
    Mesh a = triangulate_points(100, 100, inner, {.border_points_per_side = 4});
    expect_triangulation(a, inner, "inner grid");
    expect_empty_circumcircles(a);
    Mesh b = triangulate_points(100, 100, full, {.border_points_per_side = 3});
    expect_triangulation(b, full, "full grid");
    EXPECT_EQ(b.num_vertices(), 25);  // every extra border point coincides with a grid point
    EXPECT_EQ(b.num_faces(), 32);
    std::vector<Vec2> fine;  // a pixel-centre grid whose coordinates are not all exact in binary
    for (int j = 0; j < 30; ++j) {
        for (int i = 0; i < 30; ++i) fine.push_back({0.1 * i + 0.05, 0.1 * j + 0.05});
    }
    expect_triangulation(triangulate_points(3, 3, fine, {.border_points_per_side = 29}), fine,
                         "fine grid");
}

TEST(Triangulate, points_on_the_border_and_collinear) {
    std::vector<Vec2> points = {{0, 50}, {100, 20}, {30, 0},  {70, 100}, {50, 50},
                                {0, 10}, {25, 50},  {75, 50}, {50, 0},   {100, 100}};
    Mesh mesh = triangulate_points(100, 100, points, {.border_points_per_side = 1});
    expect_triangulation(mesh, points, "border");
    expect_empty_circumcircles(mesh);
    std::vector<Vec2> circle;  // many co-circular points
    for (int k = 0; k < 64; ++k) {
        circle.push_back({50 + 40 * std::cos(k * std::numbers::pi / 32),
                          50 + 40 * std::sin(k * std::numbers::pi / 32)});
    }
    expect_triangulation(triangulate_points(100, 100, circle), circle, "circle");
}

TEST(Triangulate, rejects_bad_points_naming_the_index) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    std::vector<Vec2> duplicate = {{1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}, {2, 2}};
    EXPECT_NE(error_of([&] { triangulate_points(10, 10, duplicate); }).find("points 1 and 5"),
              std::string::npos);
    std::vector<Vec2> outside = {{1, 1}, {2, 2}, {3, 3}, {10.5, 3}};
    EXPECT_NE(error_of([&] { triangulate_points(10, 10, outside); }).find("point 3"),
              std::string::npos);
    std::vector<Vec2> negative = {{1, 1}, {2, -1e-9}};
    EXPECT_NE(error_of([&] { triangulate_points(10, 10, negative); }).find("point 1"),
              std::string::npos);
    std::vector<Vec2> not_finite = {{1, 1}, {nan, 2}, {3, inf}};
    EXPECT_NE(error_of([&] { triangulate_points(10, 10, not_finite); }).find("point 1"),
              std::string::npos);
    std::vector<Vec2> near_border = {{5, 10 - 1e-13}};  // a sliver against the bottom side
    EXPECT_NE(error_of([&] { triangulate_points(10, 10, near_border); }).find("point 0"),
              std::string::npos);
    EXPECT_THROW(triangulate_points(0, 10, {}), Error);
    EXPECT_THROW(triangulate_points(10, 10, {}, {.border_points_per_side = -1}), Error);
}

}  // namespace
}  // namespace tesswave
