#include "core/math/triangulate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <vector>

#include "core/math/error.h"
#include "core/math/strings.h"
#include "core/math/validate.h"

namespace tesswave {
namespace {

constexpr size_t kMaxPoints = 50'000'000;
constexpr int kMaxBorderPoints = 1'000'000;
// validate() calls two vertices within 1e-9 of the diagonal duplicates; skip extras a bit wider.
constexpr double kNearRelative = 4e-9;

// Exact predicates. A float evaluation decides when its error bound (Shewchuk 1997, stage A,
// doubled so that compilers contracting a*b+c into an FMA stay covered) proves the sign; else the
// determinant is recomputed exactly as a nonoverlapping expansion, whose sign is that of its
// largest nonzero component. Exact unless a product underflows (coordinates near 1e-150).
using Expansion = std::vector<double>;
constexpr double kEps = 0x1.0p-53;
constexpr double kOrientBound = 2 * (3 + 16 * kEps) * kEps;
constexpr double kIncircleBound = 2 * (10 + 96 * kEps) * kEps;

void two_sum(double a, double b, double& sum, double& err) {
    sum = a + b;
    const double bv = sum - a, av = sum - bv;
    err = (a - av) + (b - bv);
}

Expansion grow(const Expansion& e, double b) {
    Expansion h;
    double q = b, err = 0;
    for (double x : e) {
        two_sum(q, x, q, err);
        if (err != 0) h.push_back(err);
    }
    if (q != 0 || h.empty()) h.push_back(q);
    return h;
}

Expansion add(Expansion e, const Expansion& f) {
    for (double x : f) e = grow(e, x);
    return e;
}

Expansion scale(const Expansion& e, double b) {
    Expansion h;
    double q = 0, err = 0;
    for (double x : e) {
        const double p = x * b, p_err = std::fma(x, b, -p);
        two_sum(q, p_err, q, err);
        if (err != 0) h.push_back(err);
        two_sum(p, q, q, err);
        if (err != 0) h.push_back(err);
    }
    if (q != 0 || h.empty()) h.push_back(q);
    return h;
}

Expansion mul(const Expansion& e, const Expansion& f) {
    Expansion h{0};
    for (double x : f) h = add(h, scale(e, x));
    return h;
}

Expansion sub(const Expansion& e, Expansion f) {
    for (double& x : f) x = -x;
    return add(e, f);
}

Expansion diff(double a, double b) {
    double s, e;
    two_sum(a, -b, s, e);
    return {e, s};
}

int sign(const Expansion& e) {
    for (auto it = e.rbegin(); it != e.rend(); ++it) {
        if (*it != 0) return *it > 0 ? 1 : -1;
    }
    return 0;
}

// > 0 when a, b, c turn counterclockwise in (x, y).
int orient(Vec2 a, Vec2 b, Vec2 c) {
    const double l = (a.x - c.x) * (b.y - c.y), r = (a.y - c.y) * (b.x - c.x);
    const double det = l - r, bound = kOrientBound * (std::abs(l) + std::abs(r));
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return sign(sub(mul(diff(a.x, c.x), diff(b.y, c.y)), mul(diff(a.y, c.y), diff(b.x, c.x))));
}

int incircle_exact(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
    const Expansion adx = diff(a.x, d.x), ady = diff(a.y, d.y), bdx = diff(b.x, d.x),
                    bdy = diff(b.y, d.y), cdx = diff(c.x, d.x), cdy = diff(c.y, d.y);
    const Expansion alift = add(mul(adx, adx), mul(ady, ady));
    const Expansion blift = add(mul(bdx, bdx), mul(bdy, bdy));
    const Expansion clift = add(mul(cdx, cdx), mul(cdy, cdy));
    const Expansion bc = sub(mul(bdx, cdy), mul(bdy, cdx));
    const Expansion ca = sub(mul(cdx, ady), mul(cdy, adx));
    const Expansion ab = sub(mul(adx, bdy), mul(ady, bdx));
    return sign(add(add(mul(alift, bc), mul(blift, ca)), mul(clift, ab)));
}

// > 0 when d lies strictly inside the circle through the counterclockwise triangle a, b, c.
int incircle(Vec2 a, Vec2 b, Vec2 c, Vec2 d) {
    const double adx = a.x - d.x, ady = a.y - d.y, bdx = b.x - d.x, bdy = b.y - d.y;
    const double cdx = c.x - d.x, cdy = c.y - d.y;
    const double bc1 = bdx * cdy, bc2 = cdx * bdy, ca1 = cdx * ady, ca2 = adx * cdy;
    const double ab1 = adx * bdy, ab2 = bdx * ady;
    const double alift = adx * adx + ady * ady, blift = bdx * bdx + bdy * bdy,
                 clift = cdx * cdx + cdy * cdy;
    const double det = alift * (bc1 - bc2) + blift * (ca1 - ca2) + clift * (ab1 - ab2);
    const double permanent = (std::abs(bc1) + std::abs(bc2)) * alift +
                             (std::abs(ca1) + std::abs(ca2)) * blift +
                             (std::abs(ab1) + std::abs(ab2)) * clift;
    const double bound = kIncircleBound * permanent;
    if (det > bound) return 1;
    if (-det > bound) return -1;
    return incircle_exact(a, b, c, d);
}

// Triangles are counterclockwise; nbr[t][k] is the triangle across the edge opposite corner k
// (from corner k + 1 to corner k + 2), or -1 on the domain border.
struct Triangulation {
    std::vector<Vec2> pts;
    std::vector<std::array<int32_t, 3>> tri, nbr;
    std::vector<int32_t> stamp;  // the vertex whose cavity last took the triangle
    std::vector<char> dead;
    std::vector<int32_t> by_start, by_end;  // new triangle (a, b, v) by a and by b, per insertion
    int32_t hint = 0;

    int32_t add(std::array<int32_t, 3> t, std::array<int32_t, 3> n) {
        tri.push_back(t);
        nbr.push_back(n);
        stamp.push_back(-1);
        dead.push_back(0);
        return static_cast<int32_t>(tri.size()) - 1;
    }
    Vec2 at(int32_t t, int k) const { return pts[tri[t][k % 3]]; }
};

// Visibility walk from the last new triangle; it cannot cycle on a Delaunay triangulation
// (Edelsbrunner), the linear scan is only a safety net.
int32_t locate(const Triangulation& T, Vec2 p) {
    int32_t t = T.hint;
    for (size_t step = 0; step <= T.tri.size(); ++step) {
        int k = 0;
        while (k < 3 && orient(T.at(t, k + 1), T.at(t, k + 2), p) >= 0) ++k;
        if (k == 3) return t;
        if (T.nbr[t][k] < 0) break;
        t = T.nbr[t][k];
    }
    for (t = 0; t < static_cast<int32_t>(T.tri.size()); ++t) {
        if (!T.dead[t] && orient(T.at(t, 0), T.at(t, 1), p) >= 0 &&
            orient(T.at(t, 1), T.at(t, 2), p) >= 0 && orient(T.at(t, 2), T.at(t, 0), p) >= 0)
            return t;
    }
    throw Error(str("triangulate_points: internal error: point at (", p.x, ", ", p.y,
                    ") lies in no triangle"));
}

// Bowyer-Watson: removes every triangle whose circumcircle strictly contains vertex v (a
// connected set, star-shaped from v when predicates are exact) and fans v to the hole's boundary.
// A boundary edge through v can only be a border edge containing v; it is split, not fanned.
void insert(Triangulation& T, int32_t v) {
    const Vec2 p = T.pts[v];
    std::vector<int32_t> cavity{locate(T, p)};
    T.stamp[cavity[0]] = v;
    for (size_t c = 0; c < cavity.size(); ++c) {
        for (int32_t n : T.nbr[cavity[c]]) {
            if (n < 0 || T.stamp[n] == v) continue;
            if (incircle(T.at(n, 0), T.at(n, 1), T.at(n, 2), p) > 0) {
                T.stamp[n] = v;
                cavity.push_back(n);
            }
        }
    }
    struct Edge {
        int32_t a, b, outer;
    };
    std::vector<Edge> boundary;
    for (int32_t t : cavity) {
        for (int k = 0; k < 3; ++k) {
            const int32_t n = T.nbr[t][k];
            if (n >= 0 && T.stamp[n] == v) continue;
            const int32_t a = T.tri[t][(k + 1) % 3], b = T.tri[t][(k + 2) % 3];
            const int side = orient(T.pts[a], T.pts[b], p);
            if (side == 0 && n < 0) continue;
            if (side <= 0) {
                throw Error(str("triangulate_points: internal error: the cavity of vertex ", v,
                                " is not star-shaped"));
            }
            boundary.push_back({a, b, n});
        }
        T.dead[t] = 1;
    }
    const int32_t first = static_cast<int32_t>(T.tri.size());
    for (const Edge& e : boundary) {
        const int32_t t = T.add({e.a, e.b, v}, {-1, -1, e.outer});
        T.by_start[e.a] = t;
        T.by_end[e.b] = t;
        if (e.outer < 0) continue;
        for (int k = 0; k < 3; ++k) {
            if (T.tri[e.outer][(k + 1) % 3] == e.b && T.tri[e.outer][(k + 2) % 3] == e.a) {
                T.nbr[e.outer][k] = t;
            }
        }
    }
    for (const Edge& e : boundary) {
        const int32_t t = T.by_start[e.a];
        T.nbr[t][0] = T.by_start[e.b];  // across (b, v)
        T.nbr[t][1] = T.by_end[e.a];    // across (v, a)
    }
    for (const Edge& e : boundary) T.by_start[e.a] = T.by_end[e.b] = -1;
    T.hint = first;
}

void check_points(double width, double height, std::span<const Vec2> points,
                  const std::vector<int32_t>& sorted) {
    for (size_t i = 0; i < points.size(); ++i) {
        const Vec2 p = points[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
            throw Error(
                str("triangulate_points: point ", i, " is not finite: (", p.x, ", ", p.y, ")"));
        }
        if (p.x < 0 || p.y < 0 || p.x > width || p.y > height) {
            throw Error(str("triangulate_points: point ", i, " at (", p.x, ", ", p.y,
                            ") lies outside the domain [0,", width, "]x[0,", height, "]"));
        }
    }
    for (size_t k = 1; k < sorted.size(); ++k) {
        const Vec2 p = points[sorted[k]];
        if (p == points[sorted[k - 1]]) {
            throw Error(str("triangulate_points: points ", std::min(sorted[k - 1], sorted[k]),
                            " and ", std::max(sorted[k - 1], sorted[k]),
                            " are duplicates, both at (", p.x, ", ", p.y, ")"));
        }
    }
}

bool lex_less(Vec2 a, Vec2 b) { return a.x < b.x || (a.x == b.x && a.y < b.y); }

// Whether a point of `sorted` (lexicographic) lies within `tol` of p in both coordinates.
bool near_any(const std::vector<Vec2>& sorted, Vec2 p, double tol) {
    auto it = std::lower_bound(sorted.begin(), sorted.end(), Vec2{p.x - tol, -HUGE_VAL}, lex_less);
    for (; it != sorted.end() && it->x <= p.x + tol; ++it) {
        if (std::abs(it->y - p.y) <= tol) return true;
    }
    return false;
}

// Given points, then the corners not among them, then the border points not near any of them
// (a point a rounding error away, such as W * 2 / 6 beside W * 1 / 3, would make a sliver).
std::vector<Vec2> all_points(double width, double height, std::span<const Vec2> points, int n) {
    std::vector<Vec2> sorted(points.begin(), points.end());
    std::sort(sorted.begin(), sorted.end(), lex_less);
    std::vector<Vec2> out(points.begin(), points.end());
    for (Vec2 c : {Vec2{0, 0}, Vec2{width, 0}, Vec2{width, height}, Vec2{0, height}}) {
        if (!std::binary_search(sorted.begin(), sorted.end(), c, lex_less)) out.push_back(c);
    }
    const double tol = kNearRelative * std::sqrt(width * width + height * height);
    for (int k = 1; k <= n; ++k) {
        const double x = width * k / (n + 1), y = height * k / (n + 1);
        for (Vec2 q : {Vec2{x, 0}, Vec2{width, y}, Vec2{x, height}, Vec2{0, y}}) {
            if (!near_any(sorted, q, tol)) out.push_back(q);
        }
    }
    return out;
}

// Snake order over a grid of about one point per cell keeps successive points close, so the
// walk from the last new triangle is short.
std::vector<int32_t> insertion_order(const std::vector<Vec2>& pts, double width, double height) {
    const int side = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(pts.size()))));
    std::vector<int64_t> key(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) {
        const int cx = std::min(side - 1, static_cast<int>(pts[i].x / width * side));
        const int cy = std::min(side - 1, static_cast<int>(pts[i].y / height * side));
        key[i] = static_cast<int64_t>(cy) * side + (cy % 2 ? side - 1 - cx : cx);
    }
    std::vector<int32_t> order(pts.size());
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(),
                     [&](int32_t a, int32_t b) { return key[a] < key[b]; });
    return order;
}

// Exact predicates leave only near-degeneracies in the input for validate() to find: points a
// rounding error apart, or a triangle too flat to count as one. Names the flattest triangle.
std::string describe_failure(const Mesh& mesh, size_t given, const std::string& problem) {
    auto name = [&](int32_t v) {
        const Vec2 p = mesh.vertices[v];
        return static_cast<size_t>(v) < given ? str("point ", v)
                                              : str("added point (", p.x, ", ", p.y, ")");
    };
    int worst = 0;
    double worst_ratio = HUGE_VAL;
    for (int f = 0; f < mesh.num_faces(); ++f) {
        auto t = mesh.face(f);
        double longest = 0;
        for (int k = 0; k < 3; ++k) {
            longest = std::max(longest, norm(mesh.vertices[t[k]] - mesh.vertices[t[(k + 1) % 3]]));
        }
        const double ratio = 2 * face_signed_area(mesh, f) / (longest * longest);
        if (ratio < worst_ratio) worst_ratio = ratio, worst = f;
    }
    std::string out = "triangulate_points: the points do not give a valid tessellation";
    if (worst_ratio < 1e-9) {
        auto t = mesh.face(worst);
        out += str(": ", name(t[0]), ", ", name(t[1]), " and ", name(t[2]),
                   " are nearly collinear (or nearly coincide); move or remove one");
    }
    return out + str(" (", problem, "; vertex i is point i)");
}

}  // namespace

Mesh triangulate_points(double width, double height, std::span<const Vec2> points,
                        const TriangulateOptions& options) {
    if (!(std::isfinite(width) && std::isfinite(height) && width >= kMinDomain &&
          height >= kMinDomain && width <= kMaxDomain && height <= kMaxDomain)) {
        throw Error(str("triangulate_points: domain ", width, " x ", height,
                        " is outside the supported ", kMinDomain, " .. ", kMaxDomain,
                        " pixels a side"));
    }
    const int n = options.border_points_per_side;
    if (n < 0 || n > kMaxBorderPoints || points.size() > kMaxPoints) {
        throw Error(str("triangulate_points: needs at most ", kMaxPoints,
                        " points and border_points_per_side in 0..", kMaxBorderPoints, ", got ",
                        points.size(), " and ", n));
    }
    std::vector<int32_t> sorted(points.size());
    std::iota(sorted.begin(), sorted.end(), 0);
    std::sort(sorted.begin(), sorted.end(), [&](int32_t a, int32_t b) {
        return lex_less(points[a], points[b]) || (points[a] == points[b] && a < b);
    });
    check_points(width, height, points, sorted);

    Triangulation T;
    T.pts = all_points(width, height, points, n);
    T.by_start.assign(T.pts.size(), -1);
    T.by_end.assign(T.pts.size(), -1);
    std::array<int32_t, 4> c;
    const std::array<Vec2, 4> corners{Vec2{0, 0}, Vec2{width, 0}, Vec2{width, height},
                                      Vec2{0, height}};
    for (int k = 0; k < 4; ++k) {
        c[k] =
            static_cast<int32_t>(std::find(T.pts.begin(), T.pts.end(), corners[k]) - T.pts.begin());
    }
    T.add({c[0], c[1], c[2]}, {-1, 1, -1});
    T.add({c[0], c[2], c[3]}, {-1, -1, 0});
    for (int32_t v : insertion_order(T.pts, width, height)) {
        if (std::find(c.begin(), c.end(), v) == c.end()) insert(T, v);
    }

    Mesh mesh;
    mesh.width = width;
    mesh.height = height;
    mesh.vertices = std::move(T.pts);
    for (size_t t = 0; t < T.tri.size(); ++t) {
        if (!T.dead[t]) mesh.add_face(T.tri[t]);
    }
    const ValidationReport report = validate(mesh, {.max_problems = 1});
    if (!report.ok()) throw Error(describe_failure(mesh, points.size(), report.problems.front()));
    return mesh;
}

}  // namespace tesswave
