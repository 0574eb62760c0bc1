// Bilinear parametrization of the T1 quads (the paper's equation 2.2) and its inverse:
//     p(u,v) = (1-u)(1-v) p00 + u(1-v) p10 + (1-u) v p01 + u v p11,
// u from the quadratic (p - p0(u)) x (p1(u) - p0(u)) = 0 with p0 = lerp(p00,p10,u) and
// p1 = lerp(p01,p11,u) (equation 2.3), then v from p = (1-v) p0 + v p1 (equation 2.4).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "core/math/geometry.h"
#include "core/math/hierarchy.h"

namespace tesswave {

// Corners in the order p00, p10, p11, p01 (the cyclic order of a T1 face).
using Quad = std::array<Vec2, 4>;

Vec2 bilinear(const Quad& q, double u, double v);

struct UV {
    double u = 0.0, v = 0.0;
};

// Inverse of bilinear() for a point in (or on) a convex quad. The quadratic degenerates to a
// linear equation when p00p01 is parallel to p10p11, and v falls back to the other axis when
// p0p1 is nearly horizontal; both are handled. Results are clamped to [0,1].
UV inverse_bilinear(const Quad& q, Vec2 p);

// inverse_bilinear() for many points of one quad (a render plan's pixels): the quad's own terms
// are computed once, and the rest inlines. The results are inverse_bilinear()'s to the bit.
class QuadInverse {
  public:
    explicit QuadInverse(const Quad& q)
        : p00_(q[0]),
          p10_(q[1]),
          p11_(q[2]),
          p01_(q[3]),
          a_(p10_ - p00_),
          b_(p01_ - p00_),
          c_((p11_ - p01_) - a_),
          A_(-cross(a_, c_)),
          ab_(cross(a_, b_)) {}

    UV operator()(Vec2 p) const {
        // p0(u) = p00 + u a, p1(u) - p0(u) = b + u c with a = p10 - p00, b = p01 - p00,
        // c = (p11 - p01) - (p10 - p00). (p - p0) x (p1 - p0) = (w - u a) x (b + u c), w = p - p00:
        //   -(a x c) u^2 + (w x c - a x b) u + w x b = 0.
        const Vec2 w = p - p00_;
        const double B = cross(w, c_) - ab_, C = cross(w, b_);
        const double scale = std::max({std::abs(ab_), std::abs(B), 1e-300});
        double roots[2];
        int count = 0;
        if (std::abs(A_) <= 1e-12 * scale) {
            roots[count++] = -C / B;  // parallel sides: the quadratic is linear
        } else {
            // Both roots, computed stably. The line through p0(u), p1(u) can pass through p for a
            // second u in [0,1] with v outside [0,1]; the root whose (u, v) lies in the quad wins.
            const double disc = std::sqrt(std::max(0.0, B * B - 4 * A_ * C));
            const double qv = -0.5 * (B + std::copysign(disc, B));
            roots[count++] = qv / A_;
            if (qv != 0) roots[count++] = C / qv;
        }
        double best_u = roots[0], best_v = 0, best_score = INFINITY;
        for (int r = 0; r < count; ++r) {
            const double u = std::clamp(roots[r], 0.0, 1.0);
            const double v = v_for(p, u);
            const double score = outside(roots[r]) + outside(v);
            if (score < best_score) best_u = u, best_v = v, best_score = score;
        }
        // A degenerate quad (zero area) has no unique inverse; the result stays a point of the
        // unit square rather than NaN.
        const double u = std::isfinite(best_u) ? best_u : 0.0;
        const double v = std::isfinite(best_v) ? best_v : 0.0;
        return {u, std::clamp(v, 0.0, 1.0)};
    }

    // operator() for the points (x0 + i, y), 0 <= i < count, into u[i] and v[i], to the bit:
    // four points at a time with AVX2 where the processor has it (the same operations in the
    // same order, both roots always and selects instead of branches), a row's last four
    // overlapping the four before when count is not a multiple of four.
    void row(double x0, double y, int32_t count, double* u, double* v) const;

  private:
    // Points i in [from, to) in fours (to - from a multiple of four).
    void row_avx2(double x0, double y, int32_t from, int32_t to, double* u, double* v) const;
    double v_for(Vec2 p, double u) const {
        const Vec2 p0 = lerp(p00_, p10_, u), p1 = lerp(p01_, p11_, u), d = p1 - p0;
        return std::abs(d.x) > std::abs(d.y) ? (p.x - p0.x) / d.x : (p.y - p0.y) / d.y;
    }
    static double outside(double t) { return t < 0 ? -t : (t > 1 ? t - 1 : 0.0); }

    Vec2 p00_, p10_, p11_, p01_, a_, b_, c_;
    double A_, ab_;  // -(a x c), a x b
};

// The T1 quads of a hierarchy for one set of T0 positions.
std::vector<Quad> t1_quads(const Hierarchy& hierarchy, std::span<const Vec2> mesh_vertices);

struct Location {
    int32_t quad = -1;
    UV uv;
};

// Point location over the T1 quads: quads are binned by bounding box on a uniform grid, so a
// query tests only the few quads of one cell.
class QuadLocator {
  public:
    QuadLocator(std::vector<Quad> quads, double width, double height);
    std::optional<Location> locate(Vec2 p) const;
    const std::vector<Quad>& quads() const { return quads_; }

  private:
    std::vector<Quad> quads_;
    double width_, height_;
    int cols_ = 1, rows_ = 1;
    double cell_w_ = 1.0, cell_h_ = 1.0;
    std::vector<int32_t> cell_start_, cell_items_;
};

}  // namespace tesswave
