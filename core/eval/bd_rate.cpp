#include "core/eval/bd_rate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "core/math/error.h"
#include "core/math/strings.h"

namespace tesswave {
namespace {

// y = sum c[k] t^k with t = (x - centre) / scale, so that t lies in [-1, 1] over the data: the
// least-squares system then stays well conditioned whatever the units of x (PSNR near 40 cubed
// would otherwise mix magnitudes 1 and 64000).
struct Cubic {
    std::array<double, 4> c = {};
    double centre = 0;
    double scale = 1;
    double lo = 0;  // the range of x over the data
    double hi = 0;

    // The mean of y over [a, b] in x: the integral of the polynomial divided by b - a.
    double mean(double a, double b) const {
        const double ta = (a - centre) / scale, tb = (b - centre) / scale;
        double integral = 0;
        double pa = ta, pb = tb;  // t^(k+1) at both ends
        for (int k = 0; k < 4; ++k) {
            integral += c[k] * (pb - pa) / (k + 1);
            pa *= ta;
            pb *= tb;
        }
        return integral / (tb - ta);
    }
};

// Least squares through the normal equations (4x4, Gaussian elimination with partial pivoting).
Cubic fit_cubic(const std::vector<std::pair<double, double>>& xy) {
    Cubic f;
    const auto [min_it, max_it] = std::minmax_element(
        xy.begin(), xy.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    f.lo = min_it->first;
    f.hi = max_it->first;
    f.centre = 0.5 * (f.lo + f.hi);
    f.scale = 0.5 * (f.hi - f.lo);
    std::array<std::array<double, 5>, 4> m = {};  // [A^T A | A^T y]
    for (const auto& [x, y] : xy) {
        const double t = (x - f.centre) / f.scale;
        const std::array<double, 4> row = {1, t, t * t, t * t * t};
        for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) m[i][j] += row[i] * row[j];
            m[i][4] += row[i] * y;
        }
    }
    for (int col = 0; col < 4; ++col) {
        int pivot = col;
        for (int r = col + 1; r < 4; ++r) {
            if (std::abs(m[r][col]) > std::abs(m[pivot][col])) pivot = r;
        }
        std::swap(m[col], m[pivot]);
        for (int r = col + 1; r < 4; ++r) {
            const double factor = m[r][col] / m[col][col];
            for (int j = col; j < 5; ++j) m[r][j] -= factor * m[col][j];
        }
    }
    for (int i = 3; i >= 0; --i) {
        double v = m[i][4];
        for (int j = i + 1; j < 4; ++j) v -= m[i][j] * f.c[j];
        f.c[i] = v / m[i][i];
    }
    return f;
}

// Checks a curve and returns its (x, y) pairs: x = PSNR and y = log(rate) for BD-rate, the
// reverse for BD-PSNR.
std::vector<std::pair<double, double>> curve(std::span<const RatePoint> points, const char* name,
                                             bool x_is_psnr) {
    if (points.size() < 4) {
        throw Error(str("Bjontegaard delta: the ", name, " curve has ", points.size(),
                        " points, at least 4 are needed"));
    }
    std::vector<std::pair<double, double>> xy;
    std::set<double> distinct_x;
    for (size_t i = 0; i < points.size(); ++i) {
        const RatePoint& p = points[i];
        if (!std::isfinite(p.rate) || !std::isfinite(p.psnr)) {
            throw Error(str("Bjontegaard delta: point ", i, " of the ", name,
                            " curve is not finite (rate ", p.rate, ", PSNR ", p.psnr, ")"));
        }
        if (p.rate <= 0) {
            throw Error(str("Bjontegaard delta: point ", i, " of the ", name, " curve has rate ",
                            p.rate, ", rates must be positive"));
        }
        const double log_rate = std::log(p.rate);
        xy.emplace_back(x_is_psnr ? p.psnr : log_rate, x_is_psnr ? log_rate : p.psnr);
        distinct_x.insert(xy.back().first);
    }
    std::sort(xy.begin(), xy.end());  // the sums, and so the result, do not depend on the order
    if (distinct_x.size() < 4) {
        throw Error(str("Bjontegaard delta: the ", name, " curve has ", distinct_x.size(),
                        " distinct ", x_is_psnr ? "PSNR values" : "rates",
                        ", a cubic fit needs at least 4"));
    }
    return xy;
}

// The mean of (test - reference) over the shared x interval of the two fits.
double mean_difference(std::span<const RatePoint> reference, std::span<const RatePoint> test,
                       bool x_is_psnr) {
    const Cubic r = fit_cubic(curve(reference, "reference", x_is_psnr));
    const Cubic t = fit_cubic(curve(test, "test", x_is_psnr));
    const double lo = std::max(r.lo, t.lo), hi = std::min(r.hi, t.hi);
    if (!(hi > lo)) {
        const char* what = x_is_psnr ? "PSNR" : "rate";
        const double scale_lo = x_is_psnr ? r.lo : std::exp(r.lo);
        const double scale_hi = x_is_psnr ? r.hi : std::exp(r.hi);
        const double test_lo = x_is_psnr ? t.lo : std::exp(t.lo);
        const double test_hi = x_is_psnr ? t.hi : std::exp(t.hi);
        throw Error(str("Bjontegaard delta: the ", what, " ranges do not overlap (reference ",
                        scale_lo, " to ", scale_hi, ", test ", test_lo, " to ", test_hi, ")"));
    }
    return t.mean(lo, hi) - r.mean(lo, hi);
}

}  // namespace

double bd_rate(std::span<const RatePoint> reference, std::span<const RatePoint> test) {
    return (std::exp(mean_difference(reference, test, true)) - 1) * 100;
}

double bd_psnr(std::span<const RatePoint> reference, std::span<const RatePoint> test) {
    return mean_difference(reference, test, false);
}

}  // namespace tesswave
