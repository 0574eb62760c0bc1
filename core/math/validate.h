// Validation of a tessellation T0 against every rule of DESIGN.md 2.1. Each problem names the
// element (vertex, face, edge, feature) and the rule it breaks; nothing is ever repaired.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "core/math/mesh.h"

namespace tesswave {

// The supported domain size, in pixels a side.
constexpr double kMinDomain = 1e-3;
constexpr double kMaxDomain = 1e8;

struct ValidationReport {
    std::vector<std::string> problems;  // one line each, e.g. "face 3: not convex at corner 2 ..."
    bool stopped = false;  // more than max_problems were found; the checks stopped at the next
    bool ok() const { return problems.empty(); }
};

struct ValidateOptions {
    size_t max_problems = 20;  // stop collecting after this many
};

ValidationReport validate(const Mesh& mesh, const ValidateOptions& options = {});
// The same for mesh's topology (domain, faces, features) at other vertex positions, one per
// vertex; mesh.vertices is not read. A moving mesh is checked without copying its topology.
ValidationReport validate(const Mesh& mesh, std::span<const Vec2> positions,
                          const ValidateOptions& options = {});

// The shape rule of DESIGN.md 2.1 for face f at positions P (corner ids in range), with
// validate()'s tolerances: kDegenerateFace when its area is (nearly) zero, else the first corner
// that does not turn strictly the way of the face's orientation (a straight or reflex angle), or -1
// when the face is convex. validate() applies it to every face; round_mesh_vertices to the faces it
// moves.
constexpr int kDegenerateFace = -2;
int first_bad_corner(const Mesh& mesh, std::span<const Vec2> P, int f);

// Throws Error("<what>: <first problem>") unless the mesh is valid.
void require_valid(const Mesh& mesh, const std::string& what);
void require_valid(const Mesh& mesh, std::span<const Vec2> positions, const std::string& what);

}  // namespace tesswave
