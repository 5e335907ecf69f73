// natural_log, the logarithm the contact barrier uses in place of std::log
// (whose glibc 2.29 symbol the distributed module cannot depend on).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "portable_math.h"

namespace {

TEST(PortableMath, NaturalLogMatchesStdLogAcrossTheRange) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> exponent(-300, 300), unit(0.5, 2.0);
  for (int k = 0; k < 200000; ++k) {
    const double x = k % 2 ? std::pow(10.0, exponent(random)) : unit(random);
    const double expected = std::log(x), got = arap::natural_log(x);
    EXPECT_LE(std::abs(got - expected), 4 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(expected)))
        << "x = " << x;
  }
}

TEST(PortableMath, NaturalLogNearOneKeepsItsDigits) {
  // The barrier evaluates log(d / d̂) with d just below d̂: relative accuracy matters there.
  for (double h : {1e-3, 1e-8, 1e-12, 1e-15}) {
    EXPECT_NEAR(arap::natural_log(1 - h) / std::log(1 - h), 1.0, 1e-14) << h;
    EXPECT_NEAR(arap::natural_log(1 + h) / std::log(1 + h), 1.0, 1e-14) << h;
  }
  EXPECT_EQ(arap::natural_log(1.0), 0.0);
}

TEST(PortableMath, NaturalLogEdgeValues) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(arap::natural_log(0.0), -inf);
  EXPECT_EQ(arap::natural_log(inf), inf);
  EXPECT_TRUE(std::isnan(arap::natural_log(-1.0)));
  EXPECT_TRUE(std::isnan(arap::natural_log(std::numeric_limits<double>::quiet_NaN())));
  const double smallest = std::numeric_limits<double>::denorm_min();
  EXPECT_NEAR(arap::natural_log(smallest), std::log(smallest), 1e-12);
}

}  // namespace
