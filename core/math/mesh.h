// The tessellation T0 (DESIGN.md 2.1): vertices, convex faces and optional feature edges over the
// domain [0,W]x[0,H]. Faces are stored as one CSR table (offsets plus corner ids).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/math/geometry.h"

namespace tesswave {

struct Mesh {
    double width = 0.0;
    double height = 0.0;
    std::vector<Vec2> vertices;
    std::vector<int32_t> face_offsets{
        0};  // face f: face_corners[face_offsets[f], face_offsets[f+1])
    std::vector<int32_t> face_corners;
    std::vector<std::array<int32_t, 2>> features;  // interior edges the image is discontinuous on
    std::string extra_json;  // keys of the mesh file this library does not use, kept as JSON text

    int num_vertices() const { return static_cast<int>(vertices.size()); }
    int num_faces() const { return static_cast<int>(face_offsets.size()) - 1; }
    std::span<const int32_t> face(int f) const {
        return {face_corners.data() + face_offsets[f],
                static_cast<size_t>(face_offsets[f + 1] - face_offsets[f])};
    }
    void add_face(std::span<const int32_t> corners);

    bool operator==(const Mesh&) const = default;
};

// Signed area of a polygon by the shoelace formula; positive for the orientation every face of a
// valid mesh has (counterclockwise in (x, y), which is clockwise on screen where y points down).
double signed_area(std::span<const Vec2> polygon);
double face_signed_area(const Mesh& mesh, int f);
// The same with the vertices at `positions` (one per vertex of the mesh's topology).
double face_signed_area(const Mesh& mesh, std::span<const Vec2> positions, int f);

// The undirected edges of a mesh, each with its one or two faces (the second is -1 on the
// border), found once and numbered in order of first appearance along the faces.
struct MeshEdges {
    std::vector<std::array<int32_t, 2>> vertices;  // endpoints, as first met along a face
    std::vector<std::array<int32_t, 2>> faces;     // faces[e][1] == -1 for a single-face edge
    std::vector<int32_t> face_edges;  // parallel to Mesh::face_corners: edge from corner i to i+1
    std::vector<int32_t> extra_uses;  // edges met a third time or more (invalid meshes only)
};
MeshEdges build_edges(const Mesh& mesh);

}  // namespace tesswave
