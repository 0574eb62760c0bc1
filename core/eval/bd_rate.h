// Bjontegaard deltas (VCEG-M33): the average rate and PSNR differences of two rate-distortion
// curves, for comparing a codec with a peer over a range of qualities.
//
// BD-rate: each curve's log(rate) is fitted as a cubic polynomial of PSNR by least squares (four
// points: the cubic through them), both polynomials are integrated over the PSNR interval the two
// curves share, [max(min PSNR), min(max PSNR)], and the mean difference d = (test - reference)
// becomes (exp(d) - 1) * 100 percent. BD-PSNR swaps the roles: PSNR fitted as a cubic of
// log(rate), integrated over the shared log-rate interval, mean difference in dB. The logarithm's
// base cancels out, so these equal the numbers of the VCEG-M33 spreadsheet (log10, 10^d) and of
// the usual Python and MATLAB scripts.
#pragma once

#include <span>

namespace tesswave {

struct RatePoint {
    double rate = 0;  // any unit of size or bit rate, the same for both curves; > 0
    double psnr = 0;  // dB
};

// Percent more rate the test curve needs for the same PSNR: negative when the test codec needs
// fewer bits (-50: half the rate). Points may come in any order. Throws Error for fewer than 4
// points on a curve, fewer than 4 distinct PSNR values, a rate <= 0, a non-finite value, or curves
// whose PSNR ranges do not overlap (or meet in a single value).
double bd_rate(std::span<const RatePoint> reference, std::span<const RatePoint> test);

// dB of PSNR the test curve gains at equal rate: positive when the test codec is better. Throws
// Error as bd_rate(), with distinct rates and overlapping rate ranges in place of PSNR's.
double bd_psnr(std::span<const RatePoint> reference, std::span<const RatePoint> test);

}  // namespace tesswave
