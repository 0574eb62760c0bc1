#include "core/math/parametrization.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {

Vec2 bilinear(const Quad& q, double u, double v) {
    return (1 - u) * (1 - v) * q[0] + u * (1 - v) * q[1] + u * v * q[2] + (1 - u) * v * q[3];
}

UV inverse_bilinear(const Quad& q, Vec2 p) { return QuadInverse(q)(p); }

void QuadInverse::row(double x0, double y, int32_t count, double* u, double* v) const {
#if defined(__x86_64__)
    static const bool avx2 = __builtin_cpu_supports("avx2");
    if (avx2 && count >= 4) {
        const int32_t fours = count - count % 4;
        row_avx2(x0, y, 0, fours, u, v);
        // The last four again, overlapping: the same values for the points done twice.
        if (fours < count) row_avx2(x0, y, count - 4, count, u, v);
        return;
    }
    if (avx2 && count > 0) {
        // Four points of the same row, the ones past count discarded.
        double u4[4], v4[4];
        row_avx2(x0, y, 0, 4, u4, v4);
        std::copy_n(u4, count, u);
        std::copy_n(v4, count, v);
        return;
    }
#endif
    for (int32_t i = 0; i < count; ++i) {
        const UV uv = (*this)({x0 + i, y});
        u[i] = uv.u, v[i] = uv.v;
    }
}

#if defined(__x86_64__)
namespace {

#define TESSWAVE_AVX2 [[gnu::target("avx2"), gnu::always_inline]] inline

TESSWAVE_AVX2 __m256d abs4(__m256d x) { return _mm256_andnot_pd(_mm256_set1_pd(-0.0), x); }
TESSWAVE_AVX2 __m256d select4(__m256d mask, __m256d yes, __m256d no) {
    return _mm256_blendv_pd(no, yes, mask);
}
TESSWAVE_AVX2 __m256d less4(__m256d a, __m256d b) { return _mm256_cmp_pd(a, b, _CMP_LT_OQ); }
// std::clamp(x, 0, 1) and QuadInverse::outside(x), NaN passing as the scalar comparisons let it.
TESSWAVE_AVX2 __m256d clamp01_4(__m256d x) {
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    return select4(less4(x, zero), zero, select4(less4(one, x), one, x));
}
TESSWAVE_AVX2 __m256d outside4(__m256d x) {
    const __m256d zero = _mm256_setzero_pd(), one = _mm256_set1_pd(1.0);
    return select4(less4(x, zero), _mm256_xor_pd(x, _mm256_set1_pd(-0.0)),
                   select4(less4(one, x), _mm256_sub_pd(x, one), zero));
}

// QuadInverse::v_for((px, y), u) without a branch: p00 + u (p10 - p00) and p01 + u (p11 - p01).
struct Edges4 {
    __m256d y, p00x, p00y, p01x, p01y, ax, ay, ex, ey;
};
TESSWAVE_AVX2 __m256d v_at4(const Edges4& e, __m256d px, __m256d u) {
    const __m256d p0x = _mm256_add_pd(e.p00x, _mm256_mul_pd(u, e.ax));
    const __m256d p0y = _mm256_add_pd(e.p00y, _mm256_mul_pd(u, e.ay));
    const __m256d p1x = _mm256_add_pd(e.p01x, _mm256_mul_pd(u, e.ex));
    const __m256d p1y = _mm256_add_pd(e.p01y, _mm256_mul_pd(u, e.ey));
    const __m256d dx = _mm256_sub_pd(p1x, p0x), dy = _mm256_sub_pd(p1y, p0y);
    const __m256d along_x = _mm256_cmp_pd(abs4(dx), abs4(dy), _CMP_GT_OQ);
    return _mm256_div_pd(select4(along_x, _mm256_sub_pd(px, p0x), _mm256_sub_pd(e.y, p0y)),
                         select4(along_x, dx, dy));
}

#undef TESSWAVE_AVX2

}  // namespace

// The points in fours: operator() lane by lane, the same operations in the same order.
[[gnu::target("avx2")]] void QuadInverse::row_avx2(double x0, double y, int32_t from, int32_t to,
                                                   double* u, double* v) const {
    const __m256d zero = _mm256_setzero_pd(), sign = _mm256_set1_pd(-0.0);
    const __m256d inf = _mm256_set1_pd(INFINITY);
    const double wy = y - p00_.y;
    const __m256d wy_cx = _mm256_set1_pd(wy * c_.x), wy_bx = _mm256_set1_pd(wy * b_.x);
    const __m256d cy = _mm256_set1_pd(c_.y), by = _mm256_set1_pd(b_.y);
    const __m256d ab = _mm256_set1_pd(ab_), abs_ab = _mm256_set1_pd(std::abs(ab_));
    const __m256d A = _mm256_set1_pd(A_), abs_a = _mm256_set1_pd(std::abs(A_));
    const __m256d four_a = _mm256_set1_pd(4 * A_), tiny = _mm256_set1_pd(1e-300);
    const __m256d eps = _mm256_set1_pd(1e-12), minus_half = _mm256_set1_pd(-0.5);
    const __m256d largest = _mm256_set1_pd(std::numeric_limits<double>::max());
    const Edges4 edges = {_mm256_set1_pd(y),
                          _mm256_set1_pd(p00_.x),
                          _mm256_set1_pd(p00_.y),
                          _mm256_set1_pd(p01_.x),
                          _mm256_set1_pd(p01_.y),
                          _mm256_set1_pd(p10_.x - p00_.x),
                          _mm256_set1_pd(p10_.y - p00_.y),
                          _mm256_set1_pd(p11_.x - p01_.x),
                          _mm256_set1_pd(p11_.y - p01_.y)};
    for (int32_t i = from; i + 4 <= to; i += 4) {
        const __m256d px =
            _mm256_add_pd(_mm256_set1_pd(x0), _mm256_setr_pd(i, i + 1.0, i + 2.0, i + 3.0));
        const __m256d wx = _mm256_sub_pd(px, edges.p00x);
        const __m256d B = _mm256_sub_pd(_mm256_sub_pd(_mm256_mul_pd(wx, cy), wy_cx), ab);
        const __m256d C = _mm256_sub_pd(_mm256_mul_pd(wx, by), wy_bx);
        // std::max({|ab|, |B|, 1e-300}), as it compares.
        const __m256d abs_b = abs4(B);
        const __m256d m1 = select4(less4(abs_ab, abs_b), abs_b, abs_ab);
        const __m256d scale = select4(less4(m1, tiny), tiny, m1);
        const __m256d linear = _mm256_cmp_pd(abs_a, _mm256_mul_pd(eps, scale), _CMP_LE_OQ);
        const __m256d d2 = _mm256_sub_pd(_mm256_mul_pd(B, B), _mm256_mul_pd(four_a, C));
        const __m256d disc = _mm256_sqrt_pd(select4(less4(zero, d2), d2, zero));
        const __m256d signed_disc =
            _mm256_or_pd(_mm256_andnot_pd(sign, disc), _mm256_and_pd(sign, B));
        const __m256d qv = _mm256_mul_pd(minus_half, _mm256_add_pd(B, signed_disc));
        // -C / B where linear, else qv / A: one division of the selected operands.
        const __m256d r0 =
            _mm256_div_pd(select4(linear, _mm256_xor_pd(C, sign), qv), select4(linear, B, A));
        const __m256d r1 = _mm256_div_pd(C, qv);
        const __m256d two = _mm256_andnot_pd(linear, _mm256_cmp_pd(qv, zero, _CMP_NEQ_UQ));
        const __m256d u0 = clamp01_4(r0), u1 = clamp01_4(r1);
        const __m256d v0 = v_at4(edges, px, u0), v1 = v_at4(edges, px, u1);
        const __m256d s0 = _mm256_add_pd(outside4(r0), outside4(v0));
        const __m256d s1 = _mm256_add_pd(outside4(r1), outside4(v1));
        const __m256d take0 = less4(s0, inf);
        __m256d bu = select4(take0, u0, r0), bv = select4(take0, v0, zero);
        const __m256d bs = select4(take0, s0, inf);
        const __m256d take1 = _mm256_and_pd(two, less4(s1, bs));
        bu = select4(take1, u1, bu);
        bv = select4(take1, v1, bv);
        // std::isfinite: false for NaN and the infinities.
        bu = select4(_mm256_cmp_pd(abs4(bu), largest, _CMP_LE_OQ), bu, zero);
        bv = select4(_mm256_cmp_pd(abs4(bv), largest, _CMP_LE_OQ), bv, zero);
        _mm256_storeu_pd(u + i, bu);
        _mm256_storeu_pd(v + i, clamp01_4(bv));
    }
}
#endif

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
