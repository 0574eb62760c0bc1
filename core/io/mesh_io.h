// Mesh files (JSON: {"domain":[W,H], "vertices":[[x,y],...], "faces":[[i,j,k,...],...],
// "features":[[i,j],...]}, features optional, other keys kept) and point lists ("x y" per line,
// '#' comments, or a JSON array of [x,y]). Parse errors name the file and the place.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/math/mesh.h"

namespace tesswave {

struct MeshLimits {
    int64_t max_vertices = 50'000'000;
    int64_t max_face_corners = 200'000'000;
};

// Structural parse only; validity (DESIGN.md 2.1) is validate()'s job. `name` prefixes errors.
Mesh parse_mesh(std::string_view text, const std::string& name, const MeshLimits& limits = {});
Mesh read_mesh(const std::string& path, const MeshLimits& limits = {});
std::string mesh_to_json(const Mesh& mesh);
void write_mesh(const Mesh& mesh, const std::string& path);

std::vector<Vec2> parse_points(std::string_view text, const std::string& name);
std::vector<Vec2> read_points(const std::string& path);

}  // namespace tesswave
