#include "core/math/voronoi.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <unordered_map>
#include <vector>

#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

constexpr int kMaxSites = 10'000'000;
constexpr int kMaxLloyd = 10'000;
// validate() calls two vertices within 1e-9 of the diagonal duplicates; weld a little wider.
constexpr double kWeldRelative = 4e-9;

// Each edge of a cell polygon carries a label: the id of the site across it, or a domain side.
constexpr int32_t kTop = -1;     // y = 0
constexpr int32_t kRight = -2;   // x = W
constexpr int32_t kBottom = -3;  // y = H
constexpr int32_t kLeft = -4;    // x = 0

struct CellCorner {
    Vec2 p;
    int32_t out;  // label of the edge that leaves p
};
using Cell = std::vector<CellCorner>;

// Sites bucketed on a uniform grid of about one site per bucket (CSR: bucket b holds
// ids[start[b], start[b + 1])).
struct SiteGrid {
    double width = 0, height = 0, cw = 0, ch = 0;
    int nx = 1, ny = 1;
    std::vector<int32_t> start, ids;
    int bx(double x) const { return std::clamp(static_cast<int>(x / cw), 0, nx - 1); }
    int by(double y) const { return std::clamp(static_cast<int>(y / ch), 0, ny - 1); }
};

SiteGrid build_grid(double width, double height, const std::vector<Vec2>& sites) {
    SiteGrid g;
    g.width = width;
    g.height = height;
    const double n = static_cast<double>(sites.size());
    const double side = std::sqrt(width * height / n);
    g.nx = static_cast<int>(std::clamp(std::ceil(width / side), 1.0, n));
    g.ny = static_cast<int>(std::clamp(std::ceil(height / side), 1.0, n));
    g.cw = width / g.nx;
    g.ch = height / g.ny;
    g.start.assign(static_cast<size_t>(g.nx) * g.ny + 1, 0);
    for (Vec2 s : sites) ++g.start[g.by(s.y) * g.nx + g.bx(s.x) + 1];
    std::partial_sum(g.start.begin(), g.start.end(), g.start.begin());
    std::vector<int32_t> fill(g.start.begin(), g.start.end() - 1);
    g.ids.resize(sites.size());
    for (size_t i = 0; i < sites.size(); ++i) {
        g.ids[fill[g.by(sites[i].y) * g.nx + g.bx(sites[i].x)]++] = static_cast<int32_t>(i);
    }
    return g;
}

// Keeps the part of `poly` at least as close to si as to sj (Sutherland-Hodgman with labels).
void clip(Cell& poly, Cell& scratch, Vec2 si, Vec2 sj, int32_t j) {
    const Vec2 d = sj - si;
    const Vec2 m = 0.5 * (si + sj);
    auto side = [&](Vec2 p) { return dot(p - m, d); };  // > 0: closer to sj
    if (std::none_of(poly.begin(), poly.end(), [&](const CellCorner& c) { return side(c.p) > 0; }))
        return;
    scratch.clear();
    for (size_t k = 0; k < poly.size(); ++k) {
        const CellCorner& a = poly[k];
        const CellCorner& b = poly[(k + 1) % poly.size()];
        const double sa = side(a.p), sb = side(b.p);
        if (sa <= 0 && sb > 0) {
            if (sa == 0) {
                scratch.push_back({a.p, j});
            } else {
                scratch.push_back(a);
                scratch.push_back({lerp(a.p, b.p, sa / (sa - sb)), j});
            }
        } else if (sa <= 0) {
            scratch.push_back(a);
        } else if (sb < 0) {
            scratch.push_back({lerp(a.p, b.p, sa / (sa - sb)), a.out});
        }
    }
    poly.swap(scratch);
}

double max_dist2(const Cell& poly, Vec2 s) {
    double r2 = 0;
    for (const CellCorner& c : poly) r2 = std::max(r2, dot(c.p - s, c.p - s));
    return r2;
}

// Clips the domain by the bisectors of ever farther rings of buckets, until every site not yet
// seen is more than twice as far from site i as the cell's farthest corner.
void compute_cell(const SiteGrid& g, const std::vector<Vec2>& sites, int32_t i, Cell& poly,
                  Cell& scratch) {
    const double w = g.width, h = g.height;
    poly = {{{0, 0}, kTop}, {{w, 0}, kRight}, {{w, h}, kBottom}, {{0, h}, kLeft}};
    const Vec2 s = sites[i];
    const int bx = g.bx(s.x), by = g.by(s.y);
    const double inf = std::numeric_limits<double>::infinity();
    const double slack = 1e-9 * (g.cw + g.ch);  // sites may sit a rounding error off their bucket
    double r2 = max_dist2(poly, s);
    for (int r = 0; r <= std::max(g.nx, g.ny); ++r) {
        if (r > 0) {
            double free = std::min({bx - r + 1 <= 0 ? inf : s.x - (bx - r + 1) * g.cw,
                                    bx + r >= g.nx ? inf : (bx + r) * g.cw - s.x,
                                    by - r + 1 <= 0 ? inf : s.y - (by - r + 1) * g.ch,
                                    by + r >= g.ny ? inf : (by + r) * g.ch - s.y});
            free -= slack;
            if (free > 0 && free * free >= 4 * r2) break;
        }
        for (int y = std::max(by - r, 0); y <= std::min(by + r, g.ny - 1); ++y) {
            const bool full_row = std::abs(y - by) == r;
            for (int x = std::max(bx - r, 0); x <= std::min(bx + r, g.nx - 1); ++x) {
                if (!full_row && std::abs(x - bx) != r) continue;
                const int b = y * g.nx + x;
                for (int32_t k = g.start[b]; k < g.start[b + 1]; ++k) {
                    const int32_t j = g.ids[k];
                    if (j == i || dot(sites[j] - s, sites[j] - s) >= 4 * r2) continue;
                    clip(poly, scratch, s, sites[j], j);
                    r2 = max_dist2(poly, s);
                }
            }
        }
    }
}

Vec2 centroid(const Cell& poly, Vec2 origin) {
    double area2 = 0;
    Vec2 sum;
    for (size_t k = 0; k < poly.size(); ++k) {
        Vec2 a = poly[k].p - origin, b = poly[(k + 1) % poly.size()].p - origin;
        double c = cross(a, b);
        area2 += c;
        sum = sum + c * (a + b);
    }
    return origin + (1.0 / (3.0 * area2)) * sum;
}

std::vector<Vec2> random_sites(double width, double height, int count, uint64_t seed) {
    std::mt19937_64 rng(seed);
    auto unit = [&] { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
    std::vector<Vec2> sites(count);
    for (Vec2& s : sites) s = {width * unit(), height * unit()};
    // Redraw coincident sites (never seen in practice) until all are distinct; a bounded number
    // of rounds, in case the domain holds too few representable points.
    for (int round = 0, again = 1; again; ++round) {
        if (round == 64) throw Error("voronoi_mesh: cannot place distinct sites in this domain");
        std::vector<int32_t> order(count);
        std::iota(order.begin(), order.end(), 0);
        auto less = [&](int32_t a, int32_t b) {
            return sites[a].x < sites[b].x || (sites[a].x == sites[b].x && sites[a].y < sites[b].y);
        };
        std::sort(order.begin(), order.end(), less);
        again = 0;
        for (size_t k = 1; k < order.size(); ++k) {
            if (!(sites[order[k]] == sites[order[k - 1]])) continue;
            sites[std::max(order[k], order[k - 1])] = {width * unit(), height * unit()};
            again = 1;
        }
    }
    return sites;
}

struct KeyHash {
    size_t operator()(const std::array<int32_t, 3>& k) const {
        uint64_t h = static_cast<uint32_t>(k[0]);
        h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k[1]);
        h = h * 0x9E3779B97F4A7C15ull ^ static_cast<uint32_t>(k[2]);
        return static_cast<size_t>(h ^ (h >> 29));
    }
};

// The position of the vertex named by a sorted label triple, computed the same way in every cell:
// the circumcentre of three sites, or where the bisector of two sites meets a domain side.
Vec2 vertex_position(const std::array<int32_t, 3>& key, const std::vector<Vec2>& sites, double w,
                     double h) {
    if (key[0] >= 0) {
        const Vec2 a = sites[key[0]], b = sites[key[1]] - a, c = sites[key[2]] - a;
        const double bb = dot(b, b), cc = dot(c, c);
        return a + (0.5 / cross(b, c)) * Vec2{c.y * bb - b.y * cc, b.x * cc - c.x * bb};
    }
    const Vec2 a = sites[key[1]], b = sites[key[2]];
    const Vec2 d = b - a, m = 0.5 * (a + b);
    switch (key[0]) {
        case kTop:
            return {m.x + d.y * m.y / d.x, 0};
        case kBottom:
            return {m.x - d.y * (h - m.y) / d.x, h};
        case kLeft:
            return {0, m.y + d.x * m.x / d.y};
        default:
            return {w, m.y - d.x * (w - m.x) / d.y};
    }
}

// Domain corners are vertices 0..3: (0,0), (W,0), (W,H), (0,H).
int32_t corner_id(int32_t in, int32_t out, int32_t cell) {
    if (in == kLeft && out == kTop) return 0;
    if (in == kTop && out == kRight) return 1;
    if (in == kRight && out == kBottom) return 2;
    if (in == kBottom && out == kLeft) return 3;
    throw Error(str("voronoi_mesh: internal error: cell ", cell, " turns from domain side ", in,
                    " straight to side ", out));
}

// Merges vertices within `tol` of each other in both coordinates (union-find over a sweep in x),
// rewrites `pos` to the merged vertices and returns each old vertex's new id. The smallest id of
// a group names it, so a domain corner always survives; a member on a domain side keeps the
// merged vertex on that side.
std::vector<int32_t> weld(std::vector<Vec2>& pos, double w, double h, double tol) {
    const size_t n = pos.size();
    std::vector<int32_t> parent(n), order(n), remap(n);
    std::iota(parent.begin(), parent.end(), 0);
    std::iota(order.begin(), order.end(), 0);
    auto find = [&](int32_t v) {
        while (parent[v] != v) v = parent[v] = parent[parent[v]];
        return v;
    };
    std::sort(order.begin(), order.end(), [&](int32_t a, int32_t b) {
        return pos[a].x < pos[b].x || (pos[a].x == pos[b].x && a < b);
    });
    for (size_t a = 0; a < n; ++a) {
        for (size_t b = a + 1; b < n && pos[order[b]].x - pos[order[a]].x <= tol; ++b) {
            if (std::abs(pos[order[b]].y - pos[order[a]].y) > tol) continue;
            const int32_t ra = find(order[a]), rb = find(order[b]);
            parent[std::max(ra, rb)] = std::min(ra, rb);
        }
    }
    std::vector<Vec2> merged;
    for (size_t v = 0; v < n; ++v) {
        const int32_t root = find(static_cast<int32_t>(v));
        if (root == static_cast<int32_t>(v)) {
            remap[v] = static_cast<int32_t>(merged.size());
            merged.push_back(pos[v]);
            continue;
        }
        remap[v] = remap[root];
        if (root < 4) continue;
        Vec2& p = merged[remap[v]];
        if (pos[v].x == 0 || pos[v].x == w) p.x = pos[v].x;
        if (pos[v].y == 0 || pos[v].y == h) p.y = pos[v].y;
    }
    pos.swap(merged);
    return remap;
}

// Builds every cell, names its corners by label triples so that neighbouring cells share them
// exactly, then welds near-coincident vertices.
Mesh assemble(double w, double h, const std::vector<Vec2>& sites) {
    const SiteGrid g = build_grid(w, h, sites);
    const double diag = std::sqrt(w * w + h * h);
    std::vector<Vec2> pos = {{0, 0}, {w, 0}, {w, h}, {0, h}};
    std::unordered_map<std::array<int32_t, 3>, int32_t, KeyHash> ids;
    ids.reserve(2 * sites.size() + 8);
    std::vector<int32_t> offsets{0}, corners;
    Cell poly, scratch;
    std::vector<int32_t> slot(sites.size());  // cell i has corners[offsets[slot[i]] ...]
    for (int32_t i : g.ids) {  // bucket order keeps the work and the vertex ids local
        compute_cell(g, sites, i, poly, scratch);
        slot[i] = static_cast<int32_t>(offsets.size()) - 1;
        for (size_t k = 0; k < poly.size(); ++k) {
            const int32_t in = poly[(k + poly.size() - 1) % poly.size()].out, out = poly[k].out;
            if (in < 0 && out < 0) {
                corners.push_back(corner_id(in, out, i));
                continue;
            }
            std::array<int32_t, 3> key{i, in, out};
            std::sort(key.begin(), key.end());
            auto [it, inserted] = ids.try_emplace(key, static_cast<int32_t>(pos.size()));
            if (inserted) {
                Vec2 p = vertex_position(key, sites, w, h);
                if (!(norm(p - poly[k].p) <= 1e-6 * diag)) p = poly[k].p;  // also catches NaN
                pos.push_back({std::clamp(p.x, 0.0, w), std::clamp(p.y, 0.0, h)});
            }
            corners.push_back(it->second);
        }
        offsets.push_back(static_cast<int32_t>(corners.size()));
    }
    const std::vector<int32_t> remap = weld(pos, w, h, kWeldRelative * diag);
    Mesh mesh;
    mesh.width = w;
    mesh.height = h;
    mesh.vertices = std::move(pos);
    std::vector<int32_t> face;
    for (size_t f = 0; f < sites.size(); ++f) {
        face.clear();
        for (int32_t k = offsets[slot[f]]; k < offsets[slot[f] + 1]; ++k) {
            if (face.empty() || face.back() != remap[corners[k]]) face.push_back(remap[corners[k]]);
        }
        while (face.size() > 1 && face.back() == face.front()) face.pop_back();
        if (face.size() < 3) {
            throw Error(str("voronoi_mesh: cell ", f, " collapsed to ", face.size(),
                            " vertices when welding near-coincident vertices"));
        }
        mesh.add_face(face);
    }
    return mesh;
}

}  // namespace

Mesh voronoi_mesh(double width, double height, const VoronoiOptions& options) {
    if (!(std::isfinite(width) && std::isfinite(height) && width >= kMinDomain &&
          height >= kMinDomain && width <= kMaxDomain && height <= kMaxDomain)) {
        throw Error(str("voronoi_mesh: domain ", width, " x ", height, " is outside the supported ",
                        kMinDomain, " .. ", kMaxDomain, " pixels a side"));
    }
    if (options.sites < 1 || options.sites > kMaxSites) {
        throw Error(str("voronoi_mesh: sites must be in 1..", kMaxSites, ", got ", options.sites));
    }
    if (options.lloyd_iterations < 0 || options.lloyd_iterations > kMaxLloyd) {
        throw Error(str("voronoi_mesh: lloyd_iterations must be in 0..", kMaxLloyd, ", got ",
                        options.lloyd_iterations));
    }
    std::vector<Vec2> sites = random_sites(width, height, options.sites, options.seed);
    Cell poly, scratch;
    for (int it = 0; it < options.lloyd_iterations; ++it) {
        const SiteGrid g = build_grid(width, height, sites);
        std::vector<Vec2> moved(sites.size());
        for (int32_t i : g.ids) {
            compute_cell(g, sites, i, poly, scratch);
            const Vec2 c = centroid(poly, sites[i]);
            moved[i] = {std::clamp(c.x, 0.0, width), std::clamp(c.y, 0.0, height)};
        }
        sites.swap(moved);
    }
    Mesh mesh = assemble(width, height, sites);
    const ValidationReport report = validate(mesh, {.max_problems = 1});
    if (!report.ok()) {
        throw Error(str("voronoi_mesh: ", options.sites, " sites, seed ", options.seed, ", ",
                        options.lloyd_iterations,
                        " Lloyd iterations: floating point could not resolve a degenerate site "
                        "configuration into a valid tessellation (",
                        report.problems.front(), ")"));
    }
    return mesh;
}

}  // namespace tesswave
