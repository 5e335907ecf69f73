#pragma once
// Math functions whose glibc symbols are old enough for the distributed module.
//
// glibc 2.29 gave log, exp and pow new symbol versions; a module that calls them
// does not load on the glibc 2.17 the README promises. frexp and log1p keep
// their first versions, so the natural logarithm is built from them.
#include <cmath>

namespace arap {

// ln x for x > 0 (NaN below 0, -inf at 0, +inf at +inf), within an ulp or two of std::log.
inline double natural_log(double x) {
  if (!(x > 0) || std::isinf(x)) return std::log1p(x - 1);  // log1p(-1) = -inf, NaN stays NaN
  int exponent = 0;
  double mantissa = std::frexp(x, &exponent);  // x = mantissa * 2^exponent, mantissa in [0.5, 1)
  if (mantissa < 0.70710678118654752) mantissa *= 2, --exponent;  // mantissa in [0.707, 1.414): log1p's best range
  // mantissa - 1 is exact (Sterbenz), so the only rounding is log1p's and the final sum's.
  return std::log1p(mantissa - 1) + exponent * 0.69314718055994530942;
}

}  // namespace arap
