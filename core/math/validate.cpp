#include "core/math/validate.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

class Collector {
  public:
    explicit Collector(size_t limit) : limit_(limit) {}
    // A problem beyond the limit is not kept: it says there are more, and the checks stop.
    void add(std::string problem) {
        if (report_.problems.size() < limit_) {
            report_.problems.push_back(std::move(problem));
        } else {
            report_.stopped = true;
        }
    }
    bool full() const { return report_.stopped; }
    bool any() const { return !report_.problems.empty(); }
    ValidationReport take() { return std::move(report_); }

  private:
    size_t limit_;
    ValidationReport report_;
};

std::string fmt_point(Vec2 p) { return str("(", p.x, ", ", p.y, ")"); }

bool check_domain_and_vertices(const Mesh& mesh, std::span<const Vec2> P, Collector& out) {
    if (!(std::isfinite(mesh.width) && std::isfinite(mesh.height) && mesh.width > 0 &&
          mesh.height > 0)) {
        out.add(str("domain: width and height must be finite and positive, got ", mesh.width, " x ",
                    mesh.height));
        return false;
    }
    // Pixel units: far outside this range the geometric tolerances below lose their meaning.
    if (mesh.width < kMinDomain || mesh.height < kMinDomain || mesh.width > kMaxDomain ||
        mesh.height > kMaxDomain) {
        out.add(str("domain: ", mesh.width, " x ", mesh.height, " is outside the supported ",
                    kMinDomain, " .. ", kMaxDomain, " pixels a side"));
        return false;
    }
    if (mesh.num_faces() == 0) out.add("mesh: has no faces");
    for (int v = 0; v < static_cast<int>(P.size()) && !out.full(); ++v) {
        Vec2 p = P[v];
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
            out.add(str("vertex ", v, ": non-finite coordinate"));
        } else if (p.x < 0 || p.y < 0 || p.x > mesh.width || p.y > mesh.height) {
            out.add(str("vertex ", v, ": coordinate ", fmt_point(p), " outside the domain [0,",
                        mesh.width, "]x[0,", mesh.height, "]"));
        }
    }
    return !out.any();
}

bool check_face_indices(const Mesh& mesh, std::span<const Vec2> P, Collector& out) {
    bool ok = true;
    std::vector<int32_t> seen_in(P.size(), -1);  // the last face that named a vertex
    for (int f = 0; f < mesh.num_faces() && !out.full(); ++f) {
        auto corners = mesh.face(f);
        if (corners.size() < 3) {
            out.add(str("face ", f, ": has ", corners.size(), " corners, needs at least 3"));
            ok = false;
            continue;
        }
        for (size_t i = 0; i < corners.size(); ++i) {
            if (corners[i] < 0 || corners[i] >= static_cast<int>(P.size())) {
                out.add(str("face ", f, ": corner ", i, " refers to vertex ", corners[i],
                            ", which does not exist"));
                ok = false;
            } else if (seen_in[corners[i]] == f) {
                out.add(str("face ", f, ": vertex ", corners[i], " appears twice"));
                ok = false;
            } else {
                seen_in[corners[i]] = f;
            }
        }
    }
    return ok;
}

bool check_face_shapes(const Mesh& mesh, std::span<const Vec2> P, Collector& out) {
    std::vector<int> negative;
    int positive = 0;
    bool ok = true;
    for (int f = 0; f < mesh.num_faces() && !out.full(); ++f) {
        const int bad = first_bad_corner(mesh, P, f);
        if (bad == kDegenerateFace) {
            out.add(str("face ", f, ": degenerate (zero area)"));
            ok = false;
            continue;
        }
        (face_signed_area(mesh, P, f) > 0 ? ++positive : (negative.push_back(f), 0));
        if (bad >= 0) {
            const int32_t v = mesh.face(f)[bad];
            out.add(str("face ", f, ": not convex at corner ", bad, " (vertex ", v, " at ",
                        fmt_point(P[v]), "): interior angle >= 180 degrees"));
            ok = false;
        }
    }
    if (!negative.empty() && positive == 0) {
        out.add(
            "faces: wrong orientation: every face has negative signed area; list corners "
            "counterclockwise in (x, y), i.e. clockwise on screen with y down");
        ok = false;
    } else {
        for (int f : negative) {
            if (out.full()) break;
            out.add(str("face ", f, ": mixed orientation: negative signed area while ", positive,
                        " other faces are positive"));
            ok = false;
        }
    }
    return ok;
}

void check_vertex_use(const Mesh& mesh, std::span<const Vec2> P, Collector& out) {
    std::vector<char> used(P.size(), 0);
    for (int32_t v : mesh.face_corners) used[v] = 1;
    for (int v = 0; v < static_cast<int>(P.size()) && !out.full(); ++v) {
        if (!used[v]) out.add(str("vertex ", v, ": unused (no face refers to it)"));
    }
    // Duplicates within eps: vertices hashed into eps-sized cells, each compared with the 3x3
    // cells around it, so the check is linear however the vertices are distributed.
    const double eps = 1e-9 * std::hypot(mesh.width, mesh.height);
    auto key = [](int64_t cx, int64_t cy) {
        return static_cast<uint64_t>(cx) * 0x9E3779B97F4A7C15ull ^ static_cast<uint64_t>(cy);
    };
    std::unordered_multimap<uint64_t, int32_t> cells;
    cells.reserve(P.size());
    for (int32_t v = 0; v < static_cast<int>(P.size()) && !out.full(); ++v) {
        const Vec2 p = P[v];
        const int64_t cx = static_cast<int64_t>(std::floor(p.x / eps));
        const int64_t cy = static_cast<int64_t>(std::floor(p.y / eps));
        for (int64_t dy = -1; dy <= 1; ++dy) {
            for (int64_t dx = -1; dx <= 1; ++dx) {
                auto [first, last] = cells.equal_range(key(cx + dx, cy + dy));
                for (auto it = first; it != last; ++it) {
                    const Vec2 q = P[it->second];
                    if (std::abs(q.x - p.x) <= eps && std::abs(q.y - p.y) <= eps) {
                        out.add(str("vertex ", v, ": duplicate of vertex ", it->second, " at ",
                                    fmt_point(q)));
                    }
                }
            }
        }
        cells.emplace(key(cx, cy), v);
    }
}

// A T-node is a vertex inside another edge. Vertices are bucketed on a grid, and each edge visits
// only the cells along it (a walk in steps of a cell, with the neighbouring cells), so long edges
// cost their length in cells, not the area of their bounding box.
void check_t_nodes(const Mesh& mesh, std::span<const Vec2> P, const MeshEdges& edges,
                   Collector& out) {
    const int side = std::max(1, static_cast<int>(std::sqrt(P.size() / 2.0)));
    const double cw = mesh.width / side, ch = mesh.height / side;
    auto cell = [&](double c, double size) {
        return std::clamp(static_cast<int>(c / size), 0, side - 1);
    };
    std::vector<int32_t> start(side * side + 1, 0), items(P.size());
    for (Vec2 p : P) ++start[cell(p.y, ch) * side + cell(p.x, cw) + 1];
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<int32_t> fill(start.begin(), start.end() - 1);
    for (int v = 0; v < static_cast<int>(P.size()); ++v) {
        Vec2 p = P[v];
        items[fill[cell(p.y, ch) * side + cell(p.x, cw)]++] = v;
    }
    const double eps = 1e-9 * std::hypot(mesh.width, mesh.height);
    std::vector<int32_t> stamp(side * side, -1);  // the last edge that visited a cell
    for (size_t e = 0; e < edges.vertices.size() && !out.full(); ++e) {
        const int32_t ia = edges.vertices[e][0], ib = edges.vertices[e][1];
        const Vec2 a = P[ia], b = P[ib];
        const Vec2 d = b - a;
        const double len2 = dot(d, d);
        auto visit = [&](int cx, int cy) {
            const int c = cy * side + cx;
            if (stamp[c] == static_cast<int32_t>(e)) return;
            stamp[c] = static_cast<int32_t>(e);
            for (int32_t k = start[c]; k < start[c + 1]; ++k) {
                const int32_t v = items[k];
                if (v == ia || v == ib) continue;
                const Vec2 p = P[v];
                const double t = dot(p - a, d) / len2;
                if (t <= 0 || t >= 1) continue;
                if (norm(p - lerp(a, b, t)) <= eps) {
                    out.add(str("vertex ", v, ": T-node, lies inside edge (", ia, ", ", ib, ")"));
                }
            }
        };
        const int steps =
            1 + static_cast<int>(std::ceil(std::max(std::abs(d.x) / cw, std::abs(d.y) / ch)));
        for (int k = 0; k <= steps; ++k) {
            const Vec2 p = lerp(a, b, static_cast<double>(k) / steps);
            const int cx = cell(p.x, cw), cy = cell(p.y, ch);
            for (int dy = -1; dy <= 1; ++dy) {
                for (int dx = -1; dx <= 1; ++dx) {
                    const int x = cx + dx, y = cy + dy;
                    if (x >= 0 && y >= 0 && x < side && y < side) visit(x, y);
                }
            }
        }
    }
}

void check_edges(const Mesh& mesh, const MeshEdges& edges, Collector& out) {
    for (int32_t e : edges.extra_uses) {
        if (out.full()) return;
        out.add(str("edge (", edges.vertices[e][0], ", ", edges.vertices[e][1],
                    "): used by more than two faces"));
    }
    // Two faces of one orientation traverse a shared edge in opposite directions; the same
    // direction means they overlap. One pass over the corners: the first face per direction.
    std::vector<std::array<int32_t, 2>> first(edges.vertices.size(), {-1, -1});
    for (int f = 0; f < mesh.num_faces() && !out.full(); ++f) {
        auto corners = mesh.face(f);
        for (size_t i = 0; i < corners.size(); ++i) {
            const int32_t e = edges.face_edges[mesh.face_offsets[f] + i];
            const int dir = edges.vertices[e][0] == corners[i] ? 0 : 1;
            if (first[e][dir] == -1) {
                first[e][dir] = f;
            } else if (first[e][dir] != f) {
                out.add(str("edge (", corners[i], ", ", corners[(i + 1) % corners.size()],
                            "): faces ", first[e][dir], " and ", f,
                            " overlap (both run along it in the same direction)"));
            }
        }
    }
}

void check_boundary_and_valence(const Mesh& mesh, std::span<const Vec2> P, const MeshEdges& edges,
                                Collector& out) {
    auto side_mask = [&](Vec2 p) {
        return (p.x == 0 ? 1 : 0) | (p.x == mesh.width ? 2 : 0) | (p.y == 0 ? 4 : 0) |
               (p.y == mesh.height ? 8 : 0);
    };
    std::vector<int> degree(P.size(), 0), boundary_degree(P.size(), 0);
    for (size_t e = 0; e < edges.vertices.size(); ++e) {
        auto [a, b] = edges.vertices[e];
        ++degree[a];
        ++degree[b];
        if (edges.faces[e][1] != -1) continue;
        ++boundary_degree[a];
        ++boundary_degree[b];
        if ((side_mask(P[a]) & side_mask(P[b])) == 0 && !out.full()) {
            out.add(
                str("edge (", a, ", ", b,
                    "): gap: a boundary edge (one face) that does not lie on the domain border"));
        }
    }
    for (int v = 0; v < static_cast<int>(P.size()) && !out.full(); ++v) {
        if (degree[v] == 0) continue;
        if (boundary_degree[v] == 0 && degree[v] < 3) {
            out.add(str("vertex ", v, ": interior vertex of valence ", degree[v],
                        " (needs at least 3)"));
        } else if (boundary_degree[v] != 0 && boundary_degree[v] != 2) {
            out.add(str("vertex ", v, ": the boundary is not one simple loop here (",
                        boundary_degree[v], " boundary edges meet)"));
        }
    }
}

void check_area(const Mesh& mesh, std::span<const Vec2> P, Collector& out) {
    double sum = 0.0;
    for (int f = 0; f < mesh.num_faces(); ++f) sum += std::abs(face_signed_area(mesh, P, f));
    const double domain = mesh.width * mesh.height;
    if (std::abs(sum - domain) > 1e-9 * domain) {
        out.add(str("faces: ", sum < domain ? "gap" : "overlap", ": face areas sum to ", sum,
                    " but the domain has area ", domain));
    }
}

void check_features(const Mesh& mesh, std::span<const Vec2> P, const MeshEdges& edges,
                    Collector& out) {
    auto key = [](int32_t a, int32_t b) {
        return (static_cast<uint64_t>(std::min(a, b)) << 32) |
               static_cast<uint32_t>(std::max(a, b));
    };
    std::unordered_map<uint64_t, int32_t> edge_of;
    for (size_t e = 0; e < edges.vertices.size(); ++e) {
        edge_of.emplace(key(edges.vertices[e][0], edges.vertices[e][1]), static_cast<int32_t>(e));
    }
    std::unordered_map<uint64_t, size_t> seen;
    for (size_t i = 0; i < mesh.features.size() && !out.full(); ++i) {
        auto [a, b] = mesh.features[i];
        if (a < 0 || b < 0 || a >= static_cast<int>(P.size()) || b >= static_cast<int>(P.size()) ||
            a == b) {
            out.add(str("feature ", i, ": (", a, ", ", b, ") does not name two distinct vertices"));
            continue;
        }
        auto it = edge_of.find(key(a, b));
        if (it == edge_of.end()) {
            out.add(str("feature ", i, ": (", a, ", ", b, ") is not an edge of the mesh"));
        } else if (edges.faces[it->second][1] == -1) {
            out.add(str("feature ", i, ": (", a, ", ", b,
                        ") is a boundary edge, not an interior edge"));
        }
        auto [first, inserted] = seen.emplace(key(a, b), i);
        if (!inserted) {
            out.add(str("feature ", i, ": (", a, ", ", b, ") repeats feature ", first->second));
        }
    }
}

}  // namespace

// Convexity with a scale-aware tolerance: a corner whose turn is below ~1e-10 radians counts as
// a straight angle, which DESIGN.md 2.1 forbids (every interior angle strictly below 180).
int first_bad_corner(const Mesh& mesh, std::span<const Vec2> P, int f) {
    const double diag = std::hypot(mesh.width, mesh.height);
    const double area = face_signed_area(mesh, P, f);
    if (std::abs(area) <= 1e-12 * diag * diag) return kDegenerateFace;
    const double sign = area > 0 ? 1.0 : -1.0;
    const auto corners = mesh.face(f);
    const size_t n = corners.size();
    for (size_t i = 0; i < n; ++i) {
        const Vec2 a = P[corners[i]] - P[corners[(i + n - 1) % n]];
        const Vec2 b = P[corners[(i + 1) % n]] - P[corners[i]];
        if (sign * cross(a, b) <= 1e-10 * norm(a) * norm(b)) return static_cast<int>(i);
    }
    return -1;
}

ValidationReport validate(const Mesh& mesh, const ValidateOptions& options) {
    return validate(mesh, mesh.vertices, options);
}

ValidationReport validate(const Mesh& mesh, std::span<const Vec2> P,
                          const ValidateOptions& options) {
    Collector out(std::max<size_t>(1, options.max_problems));
    if (!check_domain_and_vertices(mesh, P, out)) return out.take();
    if (!check_face_indices(mesh, P, out)) return out.take();
    const bool shapes_ok = check_face_shapes(mesh, P, out);
    check_vertex_use(mesh, P, out);
    const MeshEdges edges = build_edges(mesh);
    check_t_nodes(mesh, P, edges, out);
    check_edges(mesh, edges, out);
    check_boundary_and_valence(mesh, P, edges, out);
    if (!out.any() && shapes_ok) check_area(mesh, P, out);
    check_features(mesh, P, edges, out);
    return out.take();
}

void require_valid(const Mesh& mesh, const std::string& what) {
    require_valid(mesh, mesh.vertices, what);
}

void require_valid(const Mesh& mesh, std::span<const Vec2> positions, const std::string& what) {
    ValidationReport report = validate(mesh, positions, {.max_problems = 1});
    if (!report.ok()) throw Error(what + ": " + report.problems.front());
}

}  // namespace tesswave
