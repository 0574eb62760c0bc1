#include "core/fit/fit_start.h"

#include <algorithm>
#include <optional>

#include "core/math/validate.h"

namespace tesswave::fit_detail {
namespace {

struct Affine {
    double m[2][2] = {{1, 0}, {0, 1}};
    Vec2 t;
    Vec2 operator()(Vec2 p) const {
        return {m[0][0] * p.x + m[0][1] * p.y + t.x, m[1][0] * p.x + m[1][1] * p.y + t.y};
    }
};

// b ~ M s + t by iteratively reweighted least squares with Cauchy weights; nullopt when the
// points are (nearly) collinear.
std::optional<Affine> robust_affine(std::span<const Vec2> s, std::span<const Vec2> b, double c) {
    std::vector<double> w(s.size(), 1.0);
    Affine f;
    for (int round = 0; round < 10; ++round) {
        double sw = 0;
        Vec2 ms{}, mb{};
        for (size_t k = 0; k < s.size(); ++k)
            sw += w[k], ms = ms + w[k] * s[k], mb = mb + w[k] * b[k];
        ms = (1 / sw) * ms, mb = (1 / sw) * mb;
        double C[2][2] = {}, D[2][2] = {};
        for (size_t k = 0; k < s.size(); ++k) {
            const Vec2 ds = s[k] - ms, db = b[k] - mb;
            C[0][0] += w[k] * ds.x * ds.x, C[0][1] += w[k] * ds.x * ds.y;
            C[1][1] += w[k] * ds.y * ds.y;
            D[0][0] += w[k] * db.x * ds.x, D[0][1] += w[k] * db.x * ds.y;
            D[1][0] += w[k] * db.y * ds.x, D[1][1] += w[k] * db.y * ds.y;
        }
        C[1][0] = C[0][1];
        const double det = C[0][0] * C[1][1] - C[0][1] * C[1][0];
        const double trace = C[0][0] + C[1][1];
        if (!(det > 1e-9 * trace * trace)) return std::nullopt;
        const double inv[2][2] = {{C[1][1] / det, -C[0][1] / det}, {-C[1][0] / det, C[0][0] / det}};
        for (int i = 0; i < 2; ++i)
            for (int j = 0; j < 2; ++j) f.m[i][j] = D[i][0] * inv[0][j] + D[i][1] * inv[1][j];
        f.t = {};
        f.t = mb - f(ms);  // the weighted means correspond
        for (size_t k = 0; k < s.size(); ++k) {
            const Vec2 r = f(s[k]) - b[k];
            w[k] = 1 / (1 + dot(r, r) / (c * c));
        }
    }
    return f;
}

}  // namespace

Vec2 Frame::snap(int v, Vec2 p) const {
    p = {std::clamp(p.x, 0.0, width), std::clamp(p.y, 0.0, height)};
    if (sides[v] & kLeft) p.x = 0;
    if (sides[v] & kRight) p.x = width;
    if (sides[v] & kTop) p.y = 0;
    if (sides[v] & kBottom) p.y = height;
    return p;
}

Frame make_frame(const Mesh& a, double width_b, double height_b) {
    Frame frame{width_b, height_b, width_b / a.width, height_b / a.height, {}, {}};
    for (int v = 0; v < a.num_vertices(); ++v) {
        const Vec2 p = a.vertices[v];
        frame.sides.push_back((p.x == 0 ? kLeft : 0) | (p.x == a.width ? kRight : 0) |
                              (p.y == 0 ? kTop : 0) | (p.y == a.height ? kBottom : 0));
        frame.reference.push_back(frame.snap(v, frame.scale(p)));
    }
    return frame;
}

std::vector<Vec2> initial_vertices(const Mesh& a, const Frame& frame,
                                   std::span<const Vec2> points_a, std::span<const Vec2> points_b,
                                   const MeshFitOptions& options) {
    Mesh candidate = a;
    candidate.width = frame.width, candidate.height = frame.height;
    auto valid_start = [&](auto&& position) {
        for (int v = 0; v < a.num_vertices(); ++v) {
            candidate.vertices[v] = frame.snap(v, position(v));
        }
        return validate(candidate, {.max_problems = 1}).ok();
    };
    if (!options.previous.empty() && valid_start([&](int v) { return options.previous[v]; })) {
        return candidate.vertices;
    }
    std::vector<Vec2> s(points_a.size());
    for (size_t k = 0; k < s.size(); ++k) s[k] = frame.scale(points_a[k]);
    const auto f = robust_affine(s, points_b, options.robust_scale);
    if (f && valid_start([&](int v) { return (*f)(frame.reference[v]); })) {
        return candidate.vertices;
    }
    return frame.reference;
}

std::vector<double> initial_transforms(const Mesh& a, const Frame& frame,
                                       const std::vector<Vec2>& x, Rigidity rigidity) {
    std::vector<double> s(2 * a.num_faces());
    for (int f = 0; f < a.num_faces(); ++f) {
        auto c = a.face(f);
        double d = 0, k = 0, n2 = 0;
        for (size_t i = 0; i < c.size(); ++i) {
            const int32_t p = c[i], q = c[(i + 1) % c.size()];
            const Vec2 er = frame.reference[q] - frame.reference[p], ex = x[q] - x[p];
            d += dot(er, ex), k += cross(er, ex), n2 += dot(er, er);
        }
        if (rigidity == Rigidity::as_rigid) {
            s[2 * f] = std::atan2(k, d);
        } else {
            s[2 * f] = d / n2, s[2 * f + 1] = k / n2;
        }
    }
    return s;
}

}  // namespace tesswave::fit_detail
