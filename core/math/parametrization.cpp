#include "core/math/parametrization.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {

Vec2 bilinear(const Quad& q, double u, double v) {
    return (1 - u) * (1 - v) * q[0] + u * (1 - v) * q[1] + u * v * q[2] + (1 - u) * v * q[3];
}

UV inverse_bilinear(const Quad& q, Vec2 p) { return QuadInverse(q)(p); }

std::vector<Quad> t1_quads(const Hierarchy& hierarchy, std::span<const Vec2> mesh_vertices) {
    const LevelTopology& t1 = hierarchy.levels.at(1);
    const std::vector<Vec2> p = refine_positions(hierarchy, mesh_vertices, 1);
    std::vector<Quad> quads(t1.num_faces());
    for (int32_t k = 0; k < t1.num_faces(); ++k) {
        for (int r = 0; r < 4; ++r) quads[k][r] = p[t1.face_v[4 * k + r]];
    }
    return quads;
}

namespace {

bool inside_convex(const Quad& q, Vec2 p, double eps) {
    for (int r = 0; r < 4; ++r) {
        const Vec2 e = q[(r + 1) % 4] - q[r];
        if (cross(e, p - q[r]) < -eps * norm(e)) return false;
    }
    return true;
}

}  // namespace

QuadLocator::QuadLocator(std::vector<Quad> quads, double width, double height)
    : quads_(std::move(quads)), width_(width), height_(height) {
    if (!(std::isfinite(width) && std::isfinite(height) && width > 0 && height > 0)) {
        throw Error(str("quad locator: domain ", width, " x ", height, " must be positive"));
    }
    for (size_t k = 0; k < quads_.size(); ++k) {
        for (const Vec2& c : quads_[k]) {
            if (!std::isfinite(c.x) || !std::isfinite(c.y)) {
                throw Error(str("quad locator: quad ", k, " has a non-finite corner"));
            }
        }
    }
    const int side = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(quads_.size()))));
    cols_ = rows_ = side;
    cell_w_ = width / cols_;
    cell_h_ = height / rows_;
    auto span_of = [&](const Quad& q) {
        double x0 = q[0].x, x1 = q[0].x, y0 = q[0].y, y1 = q[0].y;
        for (Vec2 c : q)
            x0 = std::min(x0, c.x), x1 = std::max(x1, c.x), y0 = std::min(y0, c.y),
            y1 = std::max(y1, c.y);
        // Clamped as doubles first: a corner far outside the domain must not overflow an int.
        auto cx = [&](double x) {
            return static_cast<int>(std::clamp(x / cell_w_, 0.0, cols_ - 1.0));
        };
        auto cy = [&](double y) {
            return static_cast<int>(std::clamp(y / cell_h_, 0.0, rows_ - 1.0));
        };
        return std::array<int, 4>{cx(x0), cx(x1), cy(y0), cy(y1)};
    };
    cell_start_.assign(cols_ * rows_ + 1, 0);
    for (const Quad& q : quads_) {
        auto [a, b, c, d] = span_of(q);
        for (int y = c; y <= d; ++y)
            for (int x = a; x <= b; ++x) ++cell_start_[y * cols_ + x + 1];
    }
    std::partial_sum(cell_start_.begin(), cell_start_.end(), cell_start_.begin());
    cell_items_.resize(cell_start_.back());
    std::vector<int32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
    for (size_t k = 0; k < quads_.size(); ++k) {
        auto [a, b, c, d] = span_of(quads_[k]);
        for (int y = c; y <= d; ++y)
            for (int x = a; x <= b; ++x)
                cell_items_[fill[y * cols_ + x]++] = static_cast<int32_t>(k);
    }
}

std::optional<Location> QuadLocator::locate(Vec2 p) const {
    if (!(p.x >= 0 && p.y >= 0 && p.x <= width_ && p.y <= height_)) {
        return std::nullopt;
    }
    const int x = std::min(static_cast<int>(p.x / cell_w_), cols_ - 1);
    const int y = std::min(static_cast<int>(p.y / cell_h_), rows_ - 1);
    const double eps = 1e-9 * (cell_w_ + cell_h_);
    for (int32_t s = cell_start_[y * cols_ + x]; s < cell_start_[y * cols_ + x + 1]; ++s) {
        const Quad& q = quads_[cell_items_[s]];
        if (inside_convex(q, p, eps)) return Location{cell_items_[s], inverse_bilinear(q, p)};
    }
    return std::nullopt;
}

}  // namespace tesswave
