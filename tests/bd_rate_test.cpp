#include "core/eval/bd_rate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/math/error.h"

namespace tesswave {
namespace {

using Curve = std::vector<RatePoint>;

// Four points of a typical codec curve (the bjontegaard Python package's example data).
const Curve kAnchor = {{9487.76, 40.037}, {4593.60, 38.615}, {2486.44, 37.181}, {1358.24, 35.734}};
const Curve kTest = {{9787.80, 40.121}, {4469.00, 38.532}, {2451.52, 37.164}, {1356.24, 35.868}};

std::string error_of(const Curve& reference, const Curve& test) {
    try {
        bd_rate(reference, test);
    } catch (const Error& e) {
        return e.what();
    }
    return "no error";
}

TEST(BdRate, identical_curves_differ_by_nothing) {
    EXPECT_NEAR(bd_rate(kAnchor, kAnchor), 0.0, 1e-12);
    EXPECT_NEAR(bd_psnr(kAnchor, kAnchor), 0.0, 1e-12);
}

TEST(BdRate, half_the_rate_everywhere_is_minus_50_percent) {
    Curve half = kAnchor;
    for (RatePoint& p : half) p.rate /= 2;
    EXPECT_NEAR(bd_rate(kAnchor, half), -50.0, 1e-9);
    EXPECT_NEAR(bd_rate(half, kAnchor), 100.0, 1e-9);  // and the reference needs twice as much
    EXPECT_GT(bd_psnr(kAnchor, half), 0.0);
}

TEST(BdRate, exact_on_a_log_linear_curve) {
    // log R = a + b PSNR is a cubic, so both fits are exact. The test curve has 0.5 dB more at
    // every rate: BD-PSNR is 0.5 and BD-rate is exp(-0.5 b) - 1, whatever the overlap.
    const double a = -3.0, b = 0.25;
    Curve reference, test;
    for (double psnr : {30.0, 31.5, 33.0, 34.0, 36.0}) {
        reference.push_back({std::exp(a + b * psnr), psnr});
        test.push_back({std::exp(a + b * psnr), psnr + 0.5});
    }
    EXPECT_NEAR(bd_psnr(reference, test), 0.5, 1e-9);
    EXPECT_NEAR(bd_rate(reference, test), (std::exp(-0.5 * b) - 1) * 100, 1e-9);
}

TEST(BdRate, matches_an_independent_exact_computation) {
    // Reference values from exact rational arithmetic (Python's fractions): the cubic through
    // the four points by Lagrange's formula, integrated in closed form over the overlap, with
    // only the logarithms and the final exp in floating point.
    EXPECT_NEAR(bd_rate(kAnchor, kTest), -0.7316271135228813, 1e-9);
    EXPECT_NEAR(bd_psnr(kAnchor, kTest), 0.016668468877422224, 1e-9);
    // Five points: a least-squares cubic, from the exact normal equations in the same way.
    const Curve five_ref = {{120, 28.1}, {250, 31.0}, {480, 33.6}, {1000, 36.9}, {2100, 39.2}};
    const Curve five_test = {{100, 28.4}, {230, 31.9}, {400, 33.5}, {950, 37.4}, {1800, 39.0}};
    EXPECT_NEAR(bd_rate(five_ref, five_test), -19.036552426067644, 1e-8);
    EXPECT_NEAR(bd_psnr(five_ref, five_test), 0.7997174654338784, 1e-9);
}

TEST(BdRate, point_order_does_not_matter) {
    const Curve shuffled = {kTest[2], kTest[0], kTest[3], kTest[1]};
    EXPECT_DOUBLE_EQ(bd_rate(kAnchor, shuffled), bd_rate(kAnchor, kTest));
    EXPECT_DOUBLE_EQ(bd_psnr(kAnchor, shuffled), bd_psnr(kAnchor, kTest));
}

TEST(BdRate, bad_curves_throw) {
    const Curve three(kAnchor.begin(), kAnchor.begin() + 3);
    EXPECT_NE(error_of(three, kTest).find("reference curve has 3 points"), std::string::npos);
    EXPECT_NE(error_of(kAnchor, three).find("test curve has 3 points"), std::string::npos);
    Curve bad = kTest;
    bad[1].rate = 0;
    EXPECT_NE(error_of(kAnchor, bad).find("rates must be positive"), std::string::npos);
    bad[1].rate = -5;
    EXPECT_NE(error_of(kAnchor, bad).find("rates must be positive"), std::string::npos);
    bad = kTest;
    bad[2].psnr = std::numeric_limits<double>::infinity();  // PSNR of a lossless point
    EXPECT_NE(error_of(kAnchor, bad).find("not finite"), std::string::npos);
    bad[2].psnr = std::nan("");
    EXPECT_NE(error_of(kAnchor, bad).find("not finite"), std::string::npos);
    bad = kTest;
    bad[3].psnr = bad[2].psnr;  // 3 distinct PSNR values: no unique cubic
    EXPECT_NE(error_of(kAnchor, bad).find("3 distinct PSNR values"), std::string::npos);

    Curve higher = kAnchor;
    for (RatePoint& p : higher) p.psnr += 10;  // 45.7..50.0 against 35.7..40.0
    EXPECT_NE(error_of(kAnchor, higher).find("ranges do not overlap"), std::string::npos);
    const Curve touching = {{1e4, 40.037}, {2e4, 41.0}, {4e4, 42.0}, {8e4, 43.0}};  // one PSNR
    EXPECT_NE(error_of(kAnchor, touching).find("ranges do not overlap"), std::string::npos);
    Curve richer = kAnchor;
    for (RatePoint& p : richer) p.rate *= 100;
    EXPECT_THROW(bd_psnr(kAnchor, richer), Error);  // rate ranges apart
}

}  // namespace
}  // namespace tesswave
