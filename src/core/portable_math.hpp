#pragma once
// Logarithm, exponential and cube root for the time loop's physics, built from the operations
// IEEE 754 rounds exactly (+, -, *, /, and scaling by powers of two: frexp, ldexp, floor).
// The host's libm and CUDA's differ in the last bit for some arguments, and the forces of the
// CE6 penalty amplify a last-bit difference in a position some 10^7-fold (two split nodes a
// fraction of a nanometre apart); with these functions, and no contraction of a * b + c into
// one rounding (-ffp-contract=off on the host, --fmad=false for nvcc: CMakeLists.txt), the CPU
// and CUDA backends compute the same bits. Accuracy against a long double reference
// (tests/unit/test_portable_math.cpp): log within 2 units in the last place, exp and cbrt 1.
#include <cfloat>
#include <cmath>

#include "core/config.hpp"

namespace fdem {

namespace portable_detail {
// ln 2 split so that k * ln2_hi is exact for |k| < 2^20 (the high part has 21 trailing zero
// bits), and 1 / ln 2.
constexpr real ln2_hi = 0x1.62e42feep-1;
constexpr real ln2_lo = 0x1.a39ef35793c76p-33;
constexpr real inv_ln2 = 0x1.71547652b82fep+0;
}  // namespace portable_detail

/// Natural logarithm. log(1) = 0 exactly; 0 gives -inf; a negative or NaN argument, NaN.
FDEM_HD real portable_log(real x) {
  if (!(x > 0) || !(x <= DBL_MAX)) return std::log(x);  // 0, negative, inf, NaN: as the library
  const real sqrt_half = real(0.70710678118654752440);
  int e = 0;
  real m = x;  // x = m 2^e, m in [sqrt(1/2), sqrt(2)): most J of a tet are there already
  if (!(x >= sqrt_half && x < 2 * sqrt_half)) {
    m = std::frexp(x, &e);  // in [1/2, 1)
    if (m < sqrt_half) m = 2 * m, --e;
  }
  // log m = 2 atanh(s) = 2 (s + s^3/3 + s^5/5 + ...), s = (m - 1)/(m + 1), |s| < 0.172: the
  // terms to s^23 reach below half a unit in the last place.
  const real s = (m - 1) / (m + 1), s2 = s * s;
  real t = real(1) / 23;  // Horner: 1/3 + s2/5 + s2^2/7 + ... + s2^10/23
  t = t * s2 + real(1) / 21;
  t = t * s2 + real(1) / 19;
  t = t * s2 + real(1) / 17;
  t = t * s2 + real(1) / 15;
  t = t * s2 + real(1) / 13;
  t = t * s2 + real(1) / 11;
  t = t * s2 + real(1) / 9;
  t = t * s2 + real(1) / 7;
  t = t * s2 + real(1) / 5;
  t = t * s2 + real(1) / 3;
  const real log_m = 2 * s + 2 * s * (s2 * t);
  const real k = real(e);
  return k * portable_detail::ln2_hi + (log_m + k * portable_detail::ln2_lo);
}

/// e^x. exp(0) = 1 exactly; overflow gives inf, underflow 0.
FDEM_HD real portable_exp(real x) {
  if (x != x) return x;
  if (x > real(709.782712893384)) return HUGE_VAL;
  if (x < real(-745.1332191019412)) return 0;
  // x = k ln 2 + r, |r| <= ln2 / 2; e^r by its Taylor series to r^13 (the rest is below
  // half a unit in the last place), then scaled by 2^k.
  const real k = std::floor(x * portable_detail::inv_ln2 + real(0.5));
  const real r = (x - k * portable_detail::ln2_hi) - k * portable_detail::ln2_lo;
  real p = real(1) / 6227020800;  // Horner: 1 + r + r^2/2! + ... + r^13/13!
  p = p * r + real(1) / 479001600;
  p = p * r + real(1) / 39916800;
  p = p * r + real(1) / 3628800;
  p = p * r + real(1) / 362880;
  p = p * r + real(1) / 40320;
  p = p * r + real(1) / 5040;
  p = p * r + real(1) / 720;
  p = p * r + real(1) / 120;
  p = p * r + real(1) / 24;
  p = p * r + real(1) / 6;
  p = p * r + real(1) / 2;
  p = p * r + 1;
  p = p * r + 1;
  return std::ldexp(p, int(k));
}

/// Cube root, of either sign. cbrt(0) = 0; exact for the cubes of small integers.
FDEM_HD real portable_cbrt(real v) {
  if (v == 0 || v != v || !(std::fabs(v) <= DBL_MAX)) return v;
  const real a = std::fabs(v);
  int e;
  real m = std::frexp(a, &e);  // a = m 2^e, m in [1/2, 1)
  int r = e % 3;               // e = 3 q + r, r in {0, 1, 2}
  if (r < 0) r += 3;
  const int q = (e - r) / 3;
  m *= r == 0 ? 1 : r == 1 ? 2 : 4;  // in [1/2, 4): its cube root in [0.79, 1.59]
  // A quadratic within 1.7 % of the cube root on [1/2, 4), two steps of Halley's iteration for
  // y^3 = m (the error cubes each time) and one of Newton's, in a form exact near the root.
  real y = real(0.605) + m * (real(0.424) - real(0.046) * m);
  for (int i = 0; i < 2; ++i) {
    const real y3 = y * y * y;
    y = y * (y3 + 2 * m) / (2 * y3 + m);
  }
  y = y - (y - m / (y * y)) / 3;
  const real c = std::ldexp(y, q);
  return v < 0 ? -c : c;
}

}  // namespace fdem
