#include "core/math/mesh.h"

#include <unordered_map>

namespace tesswave {

void Mesh::add_face(std::span<const int32_t> corners) {
    face_corners.insert(face_corners.end(), corners.begin(), corners.end());
    face_offsets.push_back(static_cast<int32_t>(face_corners.size()));
}

double signed_area(std::span<const Vec2> polygon) {
    double twice = 0.0;
    for (size_t i = 0; i < polygon.size(); ++i) {
        twice += cross(polygon[i], polygon[(i + 1) % polygon.size()]);
    }
    return 0.5 * twice;
}

double face_signed_area(const Mesh& mesh, int f) {
    return face_signed_area(mesh, mesh.vertices, f);
}

double face_signed_area(const Mesh& mesh, std::span<const Vec2> positions, int f) {
    auto corners = mesh.face(f);
    double twice = 0.0;
    for (size_t i = 0; i < corners.size(); ++i) {
        twice += cross(positions[corners[i]], positions[corners[(i + 1) % corners.size()]]);
    }
    return 0.5 * twice;
}

MeshEdges build_edges(const Mesh& mesh) {
    MeshEdges out;
    out.face_edges.resize(mesh.face_corners.size(), -1);
    std::unordered_map<uint64_t, int32_t> index;
    index.reserve(mesh.face_corners.size());
    for (int f = 0; f < mesh.num_faces(); ++f) {
        auto corners = mesh.face(f);
        for (size_t i = 0; i < corners.size(); ++i) {
            int32_t a = corners[i];
            int32_t b = corners[(i + 1) % corners.size()];
            uint64_t key = (static_cast<uint64_t>(std::min(a, b)) << 32) |
                           static_cast<uint32_t>(std::max(a, b));
            auto [it, inserted] = index.try_emplace(key, static_cast<int32_t>(out.vertices.size()));
            int32_t e = it->second;
            if (inserted) {
                out.vertices.push_back({a, b});
                out.faces.push_back({f, -1});
            } else if (out.faces[e][1] == -1) {
                out.faces[e][1] = f;
            } else {
                out.extra_uses.push_back(e);
            }
            out.face_edges[mesh.face_offsets[f] + i] = e;
        }
    }
    return out;
}

}  // namespace tesswave
