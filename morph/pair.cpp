#include "pair.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/fit/mesh_fit.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"

namespace tesswave::morph {
namespace {

void check_points(const std::vector<Vec2>& p, double W, double H, const std::string& name) {
    if (p.size() < 3) throw Error(str(name, ": ", p.size(), " points; a morph needs at least 3"));
    for (size_t i = 0; i < p.size(); ++i) {
        if (!std::isfinite(p[i].x) || !std::isfinite(p[i].y)) {
            throw Error(str(name, ": point ", i + 1, " is not a finite number"));
        }
        if (p[i].x < 0 || p[i].x > W || p[i].y < 0 || p[i].y > H) {
            throw Error(str(name, ": point ", i + 1, " (", p[i].x, ", ", p[i].y,
                            ") is outside the ", W, "x", H, " image"));
        }
    }
    std::vector<size_t> order(p.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t i, size_t j) {
        return p[i].x != p[j].x ? p[i].x < p[j].x : p[i].y < p[j].y;
    });
    for (size_t k = 1; k < order.size(); ++k) {
        if (p[order[k]] == p[order[k - 1]]) {
            throw Error(str(name, ": points ", std::min(order[k], order[k - 1]) + 1, " and ",
                            std::max(order[k], order[k - 1]) + 1, " are the same point"));
        }
    }
}

Mesh with_vertices(const Mesh& topology, std::vector<Vec2> vertices, double W, double H) {
    Mesh m = topology;
    m.vertices = std::move(vertices);
    m.width = W;
    m.height = H;
    return m;
}

void require_valid_in(const Mesh& m, const char* image, const char* hint) {
    const ValidationReport r = validate(m);
    if (!r.ok()) {
        throw Error(
            str("the mesh is not valid in image ", image, " (", r.problems.front(), "): ", hint));
    }
}

constexpr const char* kCrossing =
    "the correspondences cross or fold there; try --triangles or a fitted --mesh grid";
constexpr const char* kTiling =
    "the triangles must tile the image without overlaps or holes, over points on its corners "
    "and border";

}  // namespace

void check_correspondences(const Correspondences& c, double wa, double ha, double wb, double hb,
                           const std::string& name_a, const std::string& name_b) {
    if (c.a.size() != c.b.size()) {
        throw Error(str(name_a, " has ", c.a.size(), " points but ", name_b, " has ", c.b.size(),
                        "; correspondences need the same count in the same order"));
    }
    check_points(c.a, wa, ha, name_a);
    check_points(c.b, wb, hb, name_b);
}

int snap_to_border(std::vector<Vec2>& points, double W, double H) {
    int moved = 0;
    for (Vec2& p : points) {
        const Vec2 q{p.x >= W - 1 && p.x < W ? W : p.x, p.y >= H - 1 && p.y < H ? H : p.y};
        moved += !(q == p);
        p = q;
    }
    return moved;
}

std::vector<std::array<int32_t, 3>> parse_triangles(const std::string& text, int points,
                                                    const std::string& name) {
    std::vector<std::array<int32_t, 3>> out;
    std::istringstream in{std::string(without_bom(text))};
    std::string line;
    for (int number = 1; std::getline(in, line); ++number) {
        const size_t hash = line.find('#');
        if (hash != std::string::npos) line.resize(hash);
        std::istringstream fields(line);
        long long i = 0, j = 0, k = 0;
        std::string extra;
        if (!(fields >> i)) continue;  // blank or comment
        if (!(fields >> j >> k) || (fields >> extra)) {
            throw Error(str(name, ":", number, ": expected three point indices 'i j k'"));
        }
        for (long long v : {i, j, k}) {
            if (v < 0 || v >= points) {
                throw Error(str(name, ":", number, ": index ", v, " is outside 0..", points - 1));
            }
        }
        if (i == j || j == k || i == k) throw Error(str(name, ":", number, ": repeated index"));
        out.push_back({static_cast<int32_t>(i), static_cast<int32_t>(j), static_cast<int32_t>(k)});
        if (out.size() > 10'000'000) throw Error(str(name, ": too many triangles"));
    }
    if (out.empty()) throw Error(str(name, ": no triangles"));
    return out;
}

PairMeshes triangulated_pair(const Correspondences& c, double wa, double ha, double wb, double hb,
                             int border_points) {
    const Mesh ma = triangulate_points(wa, ha, c.a, {.border_points_per_side = border_points});
    std::vector<Vec2> vb = c.b;
    for (size_t i = c.a.size(); i < ma.vertices.size(); ++i) {
        const Vec2 p = ma.vertices[i];  // corners and border points: scaled to B's border
        vb.push_back({p.x == wa ? wb : p.x * wb / wa, p.y == ha ? hb : p.y * hb / ha});
    }
    PairMeshes pair{ma, with_vertices(ma, std::move(vb), wb, hb),
                    str("triangulation of ", c.a.size(), " points")};
    require_valid_in(pair.a, "A", kCrossing);
    require_valid_in(pair.b, "B", kCrossing);
    return pair;
}

PairMeshes triangles_pair(const Correspondences& c, const std::vector<std::array<int32_t, 3>>& t,
                          double wa, double ha, double wb, double hb) {
    Mesh topology;
    int dropped = 0;
    for (const auto& tri : t) {
        // Counterclockwise in A, as every face of a valid mesh.
        const Vec2 p = c.a[tri[0]], q = c.a[tri[1]], r = c.a[tri[2]];
        if (cross(q - p, r - p) == 0) {
            ++dropped;
            continue;
        }
        const std::array<int32_t, 3> ccw =
            cross(q - p, r - p) >= 0 ? tri : std::array<int32_t, 3>{tri[0], tri[2], tri[1]};
        topology.add_face(ccw);
    }
    PairMeshes pair{with_vertices(topology, c.a, wa, ha), with_vertices(topology, c.b, wb, hb),
                    str(t.size() - dropped, " given triangles",
                        dropped ? str(" (", dropped, " of zero area dropped)") : std::string())};
    require_valid_in(pair.a, "A", kTiling);
    require_valid_in(pair.b, "B", kCrossing);
    return pair;
}

PairMeshes fitted_pair(const Mesh& mesh_a, const Correspondences& c, double wb, double hb) {
    const MeshFitResult fit = fit_mesh(mesh_a, c.a, c.b, wb, hb);
    if (!fit.ok()) throw Error(fit.failure);  // no pair without a mesh on B
    PairMeshes pair{mesh_a, with_vertices(mesh_a, fit.vertices, wb, hb),
                    str("fitted ", mesh_a.num_faces(), "-face mesh, residual rms ", fit.rms,
                        " px, ", fit.outliers, " outliers")};
    require_valid_in(pair.b, "B", kCrossing);
    return pair;
}

}  // namespace tesswave::morph
