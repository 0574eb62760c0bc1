#include "pair.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/fit/mesh_fit.h"
#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/triangulate.h"
#include "core/math/validate.h"
#include "geometry.h"

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

namespace {

// Which sides of the [0,W]x[0,H] rectangle p lies on: bits left, right, top, bottom.
int sides(Vec2 p, double W, double H) {
    return (p.x == 0) | (p.x == W) << 1 | (p.y == 0) << 2 | (p.y == H) << 3;
}

// "(4, 31)" with 1-based point numbers, at most 12 of them.
std::string point_list(const std::vector<int>& points) {
    std::string s;
    for (size_t k = 0; k < points.size() && k < 12; ++k) s += str(k ? ", " : "", points[k] + 1);
    if (points.size() > 12) s += str(" and ", points.size() - 12, " more");
    return "(" + s + ")";
}

}  // namespace

PairMeshes triangulated_pair(const Correspondences& c, double wa, double ha, double wb, double hb,
                             int border_points) {
    const size_t n = c.a.size();
    std::vector<Vec2> mean(n);
    std::vector<char> keep(n, 1);
    std::vector<int> off_border, folded, merged;
    for (size_t i = 0; i < n; ++i) {
        mean[i] = 0.5 * (c.a[i] + Vec2{c.b[i].x * wa / wb, c.b[i].y * ha / hb});
        const int side = sides(c.a[i], wa, ha);
        if (side != sides(c.b[i], wb, hb)) {  // the border must map to the border
            keep[i] = 0;
            off_border.push_back(static_cast<int>(i));
        } else {
            // Exactly on the sides it lies on in both images.
            if (side & 1) mean[i].x = 0;
            if (side & 2) mean[i].x = wa;
            if (side & 4) mean[i].y = 0;
            if (side & 8) mean[i].y = ha;
        }
    }
    // Points a side, evenly spaced, as in triangulate_points, but only off the stretch of the side
    // that landmarks on it span in A or B: there a fixed point could swap order with a landmark.
    std::vector<Vec2> extra;
    const Vec2 corner[4] = {{0, 0}, {wa, 0}, {wa, ha}, {0, ha}};
    for (int side = 0; side < 4; ++side) {
        const Vec2 from = corner[side], to = corner[(side + 1) % 4];
        const int bit = side == 0 ? 4 : side == 1 ? 2 : side == 2 ? 8 : 1;
        double lo = 2, hi = -1;  // span of the landmarks along the side, as fractions
        for (size_t i = 0; i < n; ++i) {
            if (!keep[i] || !(sides(c.a[i], wa, ha) & bit)) continue;
            for (Vec2 p : {c.a[i], Vec2{c.b[i].x * wa / wb, c.b[i].y * ha / hb}}) {
                const double f = dot(p - from, to - from) / dot(to - from, to - from);
                lo = std::min(lo, f);
                hi = std::max(hi, f);
            }
        }
        for (int k = 1; k <= border_points; ++k) {
            const double f = static_cast<double>(k) / (border_points + 1);
            if (f > lo - 0.05 && f < hi + 0.05) continue;
            Vec2 p = from + f * (to - from);
            if (side == 0 || side == 2) p.y = side == 0 ? 0 : ha;
            if (side == 1 || side == 3) p.x = side == 1 ? wa : 0;
            extra.push_back(p);
        }
    }
    for (;;) {
        std::vector<int> index;
        std::vector<Vec2> shape;
        for (size_t i = 0; i < n; ++i) {
            if (keep[i]) {
                index.push_back(static_cast<int>(i));
                shape.push_back(mean[i]);
            }
        }
        if (index.size() < 3) {
            throw Error(str("only ", index.size(), " of ", n,
                            " points remain once those whose triangles fold are left out; the "
                            "correspondences cross almost everywhere"));
        }
        for (Vec2 p : extra) {
            if (std::find(shape.begin(), shape.end(), p) == shape.end()) shape.push_back(p);
        }
        Mesh topology;
        try {
            topology = triangulate_points(wa, ha, shape);
        } catch (const Error&) {
            // Two points (nearly) on one another in the mean shape: merge them (keep the first).
            // The closest pair among neighbours in x order; anything else is not ours to mend.
            std::vector<size_t> order(shape.size());
            for (size_t k = 0; k < order.size(); ++k) order[k] = k;
            std::sort(order.begin(), order.end(), [&](size_t i, size_t j) {
                return shape[i].x != shape[j].x ? shape[i].x < shape[j].x : shape[i].y < shape[j].y;
            });
            size_t worst = 1;
            for (size_t k = 1; k < order.size(); ++k) {
                if (norm(shape[order[k]] - shape[order[k - 1]]) <
                    norm(shape[order[worst]] - shape[order[worst - 1]])) {
                    worst = k;
                }
            }
            const size_t p = order[worst - 1], q = order[worst];
            const size_t drop = q < index.size() && (p >= index.size() || q > p) ? q : p;
            if (norm(shape[p] - shape[q]) > 1e-3 || drop >= index.size()) throw;
            keep[index[drop]] = 0;
            merged.push_back(index[drop]);
            continue;
        }
        std::vector<Vec2> va = topology.vertices, vb = topology.vertices;
        for (size_t k = 0; k < va.size(); ++k) {
            if (k < index.size()) {
                va[k] = c.a[index[k]];
                vb[k] = c.b[index[k]];
            } else {  // corners and border points: scaled to B's border
                const Vec2 p = topology.vertices[k];
                vb[k] = {p.x == wa ? wb : p.x * wb / wa, p.y == ha ? hb : p.y * hb / ha};
            }
        }
        std::vector<int> bad = folded_faces(topology, va);
        for (int f : folded_faces(topology, vb)) bad.push_back(f);
        if (bad.empty()) {
            PairMeshes pair{with_vertices(topology, std::move(va), wa, ha),
                            with_vertices(topology, std::move(vb), wb, hb),
                            str("triangulation of ", index.size(), " points (mean shape)")};
            require_valid_in(pair.a, "A", kCrossing);
            require_valid_in(pair.b, "B", kCrossing);
            for (auto* list : {&off_border, &folded, &merged}) {
                pair.dropped.insert(pair.dropped.end(), list->begin(), list->end());
            }
            std::sort(pair.dropped.begin(), pair.dropped.end());
            std::vector<std::string> why;
            if (!folded.empty()) {
                std::sort(folded.begin(), folded.end());
                why.push_back(str(point_list(folded), " whose triangles fold in A or B"));
            }
            if (!off_border.empty()) {
                why.push_back(str(point_list(off_border), " on the border in one image only"));
            }
            if (!merged.empty()) {
                std::sort(merged.begin(), merged.end());
                why.push_back(str(point_list(merged), " on another point in the mean shape"));
            }
            if (!why.empty()) {
                pair.repair = str("left out ", pair.dropped.size(), " of ", n, " points: ", why[0]);
                for (size_t k = 1; k < why.size(); ++k) pair.repair += "; " + why[k];
            }
            return pair;
        }
        // Each folded face loses its landmark that lies in the most folded faces (ties: the one
        // that moves farthest), once per face a round.
        std::vector<int> count(index.size(), 0);
        for (int f : bad) {
            for (int32_t v : topology.face(f)) {
                if (v < static_cast<int32_t>(index.size())) ++count[v];
            }
        }
        auto motion = [&](int32_t v) {
            const int i = index[v];
            return norm(Vec2{c.b[i].x * wa / wb, c.b[i].y * ha / hb} - c.a[i]);
        };
        std::vector<char> gone(index.size(), 0);
        for (int f : bad) {
            int32_t pick = -1;
            for (int32_t v : topology.face(f)) {
                if (v >= static_cast<int32_t>(index.size())) continue;
                if (gone[v]) {
                    pick = -2;  // this face already loses a corner
                    break;
                }
                if (pick < 0 || count[v] > count[pick] ||
                    (count[v] == count[pick] && motion(v) > motion(pick))) {
                    pick = v;
                }
            }
            if (pick >= 0) {
                gone[pick] = 1;
                keep[index[pick]] = 0;
                folded.push_back(index[pick]);
            }
        }
        if (std::find(gone.begin(), gone.end(), 1) == gone.end()) {
            // Only the mesh's own corners and border points are left in the folded triangles.
            throw Error(str("the triangulation of the points folds (face ", bad.front(),
                            ") where no point can be left out"));
        }
    }
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

PairMeshes rest_pair(const Mesh& mesh_a, double wb, double hb) {
    std::vector<Vec2> vb = mesh_a.vertices;
    for (Vec2& v : vb) v = {v.x * wb / mesh_a.width, v.y * hb / mesh_a.height};
    return {mesh_a, with_vertices(mesh_a, std::move(vb), wb, hb),
            str(mesh_a.num_faces(), "-face mesh at rest")};
}

}  // namespace tesswave::morph
