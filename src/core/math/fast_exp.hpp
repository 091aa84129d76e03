// A vectorisable exp for the compiled 2D-field loops.
//
// libm's exp is one call per element, which the compiler cannot vectorise, so a 200x200 potential image over
// 720 obstacle points (28.8 M exponentials) takes ~160 ms with it. This version is arithmetic and one
// integer-to-float bit cast, so the obstacle loops vectorise.
//
// Method (Cody & Waite 1980; Muller, "Elementary Functions", 3rd ed., §11.3): x = k ln 2 + r with
// k = round(x / ln 2), |r| <= ln(2)/2, ln 2 split into a high and a low part so that r is exact to double
// precision; exp(r) by its degree-12 Taylor polynomial (truncation |r|^13/13! < 2e-16, Estrin's scheme); 2^k in the
// IEEE-754 exponent field. Relative error <= 3.4e-16 on [-700, 700]. Inputs below -700 are clipped to it: exp(-700)
// ~ 1e-304 stands for underflow. Above +700 is outside the domain: the 2D field's exponents are at most
// kr_slope * kr_dist <= 300 (VectorFieldParams refuses more). A second, upper clip made GCC 12 split the vectorised
// loops into in-range and two out-of-range selects (three compares and masked moves per vector), 10 % slower.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace pfield::math {

inline double fast_exp(double x) {
  constexpr double kLog2e = 1.4426950408889634;
  constexpr double kLn2Hi = 0.6931471803691238;
  constexpr double kLn2Lo = 1.9082149292705877e-10;
  constexpr double kClip = 700.0;
  x = std::max(x, -kClip);
  const double k = std::floor(x * kLog2e + 0.5);
  const double r = x - k * kLn2Hi - k * kLn2Lo;
  // exp(r) = sum r^i / i!, i = 0..12, in Estrin's scheme: the powers r^2, r^4, r^8 let the terms be summed
  // as a tree of depth 4 instead of Horner's chain of 12 dependent multiply-adds (the vectorised loops are
  // bound by that chain's latency).
  const double r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;
  const double p01 = 1.0 + r, p23 = 1.0 / 2 + r * (1.0 / 6), p45 = 1.0 / 24 + r * (1.0 / 120);
  const double p67 = 1.0 / 720 + r * (1.0 / 5040), p89 = 1.0 / 40320 + r * (1.0 / 362880);
  const double p1011 = 1.0 / 3628800 + r * (1.0 / 39916800), p12 = 1.0 / 479001600;
  const double p = (p01 + r2 * p23 + r4 * (p45 + r2 * p67)) + r8 * (p89 + r2 * p1011 + r4 * p12);
  // 2^k: k + 1.5·2^52 holds the integer k in its low mantissa bits (as 0x4338000000000000 + k); adding the
  // exponent bias and shifting it into the exponent field drops the constant's bits (no float-to-int
  // conversion, which AVX2 cannot vectorise).
  const double shifted = k + 6755399441055744.0;
  std::uint64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  bits = (bits + 1023) << 52;
  double two_k;
  std::memcpy(&two_k, &bits, sizeof two_k);
  return p * two_k;
}

}  // namespace pfield::math
