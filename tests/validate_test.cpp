#include "core/math/validate.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "samples/sample_meshes.h"

namespace tesswave {
namespace {

// Every problem of `mesh`, joined, so a test can look for the rule and the element.
std::string problems(const Mesh& mesh) {
    std::string all;
    for (const auto& p : validate(mesh).problems) all += p + "\n";
    return all;
}

#define EXPECT_PROBLEM(mesh, text) \
    EXPECT_NE(problems(mesh).find(text), std::string::npos) << "problems:\n" << problems(mesh)

Mesh make(double w, double h, std::vector<Vec2> vertices, std::vector<std::vector<int32_t>> faces) {
    Mesh m;
    m.width = w;
    m.height = h;
    m.vertices = std::move(vertices);
    for (auto& f : faces) m.add_face(f);
    return m;
}

TEST(Validate, accepts_the_sample_meshes) {
    EXPECT_TRUE(validate(grid_mesh(10, 10, 3, 4)).ok()) << problems(grid_mesh(10, 10, 3, 4));
    EXPECT_TRUE(validate(samples::paper_t0(249, 251)).ok());
    EXPECT_TRUE(validate(samples::paper_t0_with_features(100, 50)).ok());
}

TEST(Validate, non_convex_face) {
    // A 2x1 domain split into a dart and its complement.
    Mesh m = make(2, 1, {{0, 0}, {2, 0}, {2, 1}, {0, 1}, {1, 0.5}},
                  {{0, 1, 4}, {1, 2, 3, 4}, {0, 4, 3}});
    EXPECT_PROBLEM(m, "face 1: not convex at corner 3 (vertex 4");
}

TEST(Validate, degenerate_face) {
    Mesh m = make(2, 1, {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {0, 1}}, {{0, 1, 2}, {0, 2, 3, 4}});
    EXPECT_PROBLEM(m, "face 0: degenerate (zero area)");
}

TEST(Validate, wrong_orientation) {
    Mesh m = make(1, 1, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {{0, 3, 2, 1}});
    EXPECT_PROBLEM(m, "wrong orientation");
}

TEST(Validate, mixed_orientation) {
    Mesh m = grid_mesh(2, 1, 2, 1);  // faces (0,1,4,3) and (1,2,5,4)
    Mesh flipped = make(2, 1, m.vertices, {{0, 1, 4, 3}, {1, 4, 5, 2}});
    EXPECT_PROBLEM(flipped, "face 1: mixed orientation");
}

TEST(Validate, gap) {
    Mesh m = make(2, 1, grid_mesh(2, 1, 2, 1).vertices, {{0, 1, 4, 3}});
    EXPECT_PROBLEM(m, "vertex 2: unused");
    Mesh gap = make(3, 1, {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {2, 0}, {3, 0}, {3, 1}, {2, 1}},
                    {{0, 1, 2, 3}, {4, 5, 6, 7}});
    EXPECT_PROBLEM(gap,
                   "edge (1, 2): gap: a boundary edge (one face) that does not lie on the "
                   "domain border");
}

TEST(Validate, overlap) {
    // Two unit squares stacked on the same cell of a 1x2 domain: areas sum to 2 on paper, but the
    // shared edges run the same way.
    Mesh m =
        make(1, 2, {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {1, 2}, {0, 2}}, {{0, 1, 2, 3}, {0, 1, 2, 3}});
    EXPECT_PROBLEM(m, "overlap");
    Mesh big = make(1, 1, {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0.5}},
                    {{0, 1, 2, 3}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}});
    EXPECT_PROBLEM(big, "edge (0, 1): faces 0 and 1 overlap");
}

TEST(Validate, area_sum_catches_a_double_cover) {
    // Four triangles around the centre plus a fifth covering one of them again through the same
    // outer edges is caught by the edge rule; a cover of the whole domain twice with consistent
    // edges is caught by the area rule.
    Mesh m = make(1, 1, {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0.5}},
                  {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}});
    EXPECT_TRUE(validate(m).ok()) << problems(m);
    m.width = 2;  // same faces, larger domain: faces leave the right half uncovered
    EXPECT_PROBLEM(m, "gap");
}

TEST(Validate, t_node) {
    // Left cell is one quad; the right side of the shared edge has a vertex in its middle.
    Mesh m = make(2, 2, {{0, 0}, {1, 0}, {2, 0}, {0, 2}, {1, 2}, {2, 2}, {1, 1}, {2, 1}},
                  {{0, 1, 4, 3}, {1, 2, 7, 6}, {6, 7, 5, 4}});
    EXPECT_PROBLEM(m, "vertex 6: T-node, lies inside edge (1, 4)");
}

TEST(Validate, interior_vertex_of_valence_two) {
    // Vertex 4 sits inside the domain with only two edges.
    Mesh m = make(2, 1, {{0, 0}, {2, 0}, {2, 1}, {0, 1}, {1, 0.5}}, {{0, 1, 2, 4}, {0, 4, 2, 3}});
    EXPECT_PROBLEM(m, "vertex 4: interior vertex of valence 2");
}

TEST(Validate, edge_used_by_more_than_two_faces) {
    Mesh m = make(2, 1, {{0, 0}, {1, 0}, {2, 0}, {2, 1}, {1, 1}, {0, 1}},
                  {{0, 1, 4, 5}, {1, 2, 3, 4}, {1, 3, 4}});
    EXPECT_PROBLEM(m, "edge (1, 4): used by more than two faces");
}

TEST(Validate, duplicate_and_unused_vertices) {
    Mesh m = grid_mesh(2, 1, 2, 1);
    m.vertices.push_back({1, 1});
    EXPECT_PROBLEM(m, "vertex 6: duplicate of vertex 4 at (1, 1)");
    EXPECT_PROBLEM(m, "vertex 6: unused");
}

TEST(Validate, non_finite_and_out_of_domain_coordinates) {
    Mesh m = grid_mesh(2, 1, 2, 1);
    m.vertices[4].x = std::numeric_limits<double>::quiet_NaN();
    EXPECT_PROBLEM(m, "vertex 4: non-finite coordinate");
    m.vertices[4] = {1, 1.5};
    EXPECT_PROBLEM(m, "vertex 4: coordinate (1, 1.5) outside the domain [0,2]x[0,1]");
    m.width = -1;
    EXPECT_PROBLEM(m, "domain: width and height must be finite and positive");
}

TEST(Validate, face_index_errors) {
    Mesh m = grid_mesh(2, 1, 2, 1);
    m.face_corners[2] = 17;
    EXPECT_PROBLEM(m, "face 0: corner 2 refers to vertex 17, which does not exist");
    Mesh twice = make(1, 1, {{0, 0}, {1, 0}, {1, 1}, {0, 1}}, {{0, 1, 2, 1}});
    EXPECT_PROBLEM(twice, "face 0: vertex 1 appears twice");
    Mesh small = make(1, 1, {{0, 0}, {1, 0}}, {{0, 1}});
    EXPECT_PROBLEM(small, "face 0: has 2 corners, needs at least 3");
}

TEST(Validate, features_must_be_interior_edges) {
    Mesh m = grid_mesh(2, 1, 2, 1);
    m.features = {{1, 4}};
    EXPECT_TRUE(validate(m).ok());
    m.features = {{0, 1}};
    EXPECT_PROBLEM(m, "feature 0: (0, 1) is a boundary edge, not an interior edge");
    m.features = {{0, 4}};
    EXPECT_PROBLEM(m, "feature 0: (0, 4) is not an edge of the mesh");
    m.features = {{1, 4}, {4, 1}};
    EXPECT_PROBLEM(m, "feature 1: (4, 1) repeats feature 0");
    m.features = {{1, 9}};
    EXPECT_PROBLEM(m, "feature 0: (1, 9) does not name two distinct vertices");
}

TEST(Validate, require_valid_names_the_file_and_first_problem) {
    Mesh m = grid_mesh(2, 1, 2, 1);
    m.vertices[4] = {1, 3};
    try {
        require_valid(m, "M.json");
        FAIL();
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("M.json: vertex 4:", 0), 0u) << e.what();
    }
}

// The report keeps max_problems problems and says whether there are more: exactly 20 bad
// features are 20 problems "in all"; a 21st makes the report stop and say there are more.
TEST(Validate, stops_only_when_there_are_more_problems_than_it_keeps) {
    for (const int bad : {19, 20, 21, 40}) {
        Mesh mesh = grid_mesh(400, 300, 20, 15);
        for (int k = 0; k < bad; ++k) mesh.features.push_back({k, k + 42});  // not edges
        const ValidationReport report = validate(mesh);
        EXPECT_EQ(report.problems.size(), static_cast<size_t>(std::min(bad, 20))) << bad;
        EXPECT_EQ(report.stopped, bad > 20) << bad;
    }
}

}  // namespace
}  // namespace tesswave
