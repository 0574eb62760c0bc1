#include "core/io/mesh_io.h"

#include <gtest/gtest.h>

#include "core/math/error.h"
#include "core/math/grid_mesh.h"
#include "samples/sample_meshes.h"
#include "test_meshes.h"

namespace tesswave {
namespace {

using tesswave::testing::error_of;

TEST(MeshIo, json_round_trip_keeps_everything) {
    Mesh mesh = samples::paper_t0_with_features(249.5, 251);
    mesh.vertices[1].x = 0.1 + 0.2;  // a value that needs all 17 digits
    mesh.extra_json = R"({"name":"paper","source":{"by":"test"}})";
    const Mesh back = parse_mesh(mesh_to_json(mesh), "m.json");
    EXPECT_EQ(back.width, mesh.width);
    EXPECT_EQ(back.height, mesh.height);
    EXPECT_EQ(back.vertices, mesh.vertices);
    EXPECT_EQ(back.face_offsets, mesh.face_offsets);
    EXPECT_EQ(back.face_corners, mesh.face_corners);
    EXPECT_EQ(back.features, mesh.features);
    EXPECT_EQ(back.extra_json, mesh.extra_json);
}

TEST(MeshIo, parse_errors_say_what_and_where) {
    EXPECT_EQ(error_of([] { parse_mesh("{\"domain\": [1, 1],\n \"vertices\": [1 2]}", "m.json"); }),
              "m.json: line 2, column 17: not valid JSON");
    EXPECT_EQ(error_of([] { parse_mesh("[]", "m.json"); }),
              "m.json: expected a JSON object with \"domain\", ...");
    EXPECT_EQ(error_of([] { parse_mesh(R"({"vertices": [], "faces": []})", "m.json"); }),
              "m.json: missing \"domain\"");
    EXPECT_EQ(error_of([] { parse_mesh(R"({"domain": [1], "vertices": [], "faces": []})", "m"); }),
              "m: \"domain\" must be [width, height]");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [[0,0],[1]], "faces": []})", "m");
              }),
              "m: vertices[1]: expected [x, y]");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [[0,"a"]], "faces": []})", "m");
              }),
              "m: vertices[0][1]: expected a number");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [], "faces": [[0,1,-2]]})", "m");
              }),
              "m: faces[0][2]: index -2 out of range");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [], "faces": [[0,1.5,2]]})", "m");
              }),
              "m: faces[0][1]: expected a vertex index");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [], "faces": [], "features": [[1]]})",
                             "m");
              }),
              "m: features[0]: expected [i, j]");
    EXPECT_EQ(error_of([] {
                  parse_mesh(R"({"domain": [1,1], "vertices": [[0,0],[1,1]], "faces": []})", "m",
                             {.max_vertices = 1});
              }),
              "m: 2 vertices exceed the limit of 1");
}

// Files saved with a UTF-8 byte-order mark read as without it (they failed at line 1).
TEST(MeshIo, a_utf8_byte_order_mark_is_skipped) {
    const std::vector<Vec2> points = parse_points(
        "\xEF\xBB\xBF"
        "1 2\n3 4\n",
        "bom.txt");
    ASSERT_EQ(points.size(), 2u);
    EXPECT_EQ(points[0].x, 1);
    EXPECT_EQ(parse_points("\xEF\xBB\xBF[[1, 2]]", "bom.json").size(), 1u);
    const std::string mesh = "\xEF\xBB\xBF" + mesh_to_json(grid_mesh(10, 10, 1, 1));
    EXPECT_EQ(parse_mesh(mesh, "bom.json").num_vertices(), 4);
}

TEST(MeshIo, point_lists) {
    const auto points = parse_points("# landmarks\n10 20\n 30.5\t40 # tail comment\n\n5,6\n", "p");
    ASSERT_EQ(points.size(), 3u);
    EXPECT_EQ(points[1], (Vec2{30.5, 40}));
    EXPECT_EQ(points[2], (Vec2{5, 6}));
    EXPECT_EQ(parse_points("[[1, 2], [3, 4]]", "p").size(), 2u);
    EXPECT_EQ(error_of([] { parse_points("1 2\n3\n", "p.txt"); }),
              "p.txt: line 2: expected two numbers \"x y\"");
    EXPECT_EQ(error_of([] { parse_points("1 2 3\n", "p.txt"); }),
              "p.txt: line 1: expected two numbers \"x y\"");
    EXPECT_EQ(error_of([] { parse_points("1 nan\n", "p.txt"); }),
              "p.txt: line 1: expected two numbers \"x y\"");
    EXPECT_EQ(error_of([] { parse_points("[[1, 2], [3]]", "p.json"); }),
              "p.json: point 1: expected [x, y]");
}

TEST(MeshIo, missing_file_names_the_file) {
    EXPECT_EQ(error_of([] { read_mesh("/nonexistent/m.json"); }).rfind("/nonexistent/m.json: ", 0),
              0u);
}

}  // namespace
}  // namespace tesswave
