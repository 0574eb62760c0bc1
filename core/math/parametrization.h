// Bilinear parametrization of the T1 quads (the paper's equation 2.2) and its inverse:
//     p(u,v) = (1-u)(1-v) p00 + u(1-v) p10 + (1-u) v p01 + u v p11,
// u from the quadratic (p - p0(u)) x (p1(u) - p0(u)) = 0 with p0 = lerp(p00,p10,u) and
// p1 = lerp(p01,p11,u) (equation 2.3), then v from p = (1-v) p0 + v p1 (equation 2.4).
#pragma once

#include <array>
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
