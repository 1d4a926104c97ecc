// core/portable_math.hpp: the logarithm (TET4's ln J), exponential (CE6 softening) and cube
// root (friction spring stiffness) the time loop uses on the host and the GPU alike, against
// the C library's long double functions rounded to double (a reference more accurate than the
// double ones, which are themselves up to an ulp off), over the ranges the physics meets and far
// beyond, in units in the last place.
#include <gtest/gtest.h>

#include <cfloat>
#include <cmath>
#include <random>

#include "core/portable_math.hpp"

using namespace fdem;

namespace {

/// |a - b| in units in the last place of b.
double ulps(double a, double b) {
  if (a == b) return 0;
  const double ulp = std::nextafter(std::fabs(b), HUGE_VAL) - std::fabs(b);
  return std::fabs(a - b) / ulp;
}

/// Largest error in ulps of f against g over n log-uniform arguments in [lo, hi] (lo > 0),
/// or uniform ones where `uniform`.
template <class F, class G>
double worst_ulps(F f, G g, double lo, double hi, bool uniform, int n = 200000) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(uniform ? lo : std::log(lo), uniform ? hi : std::log(hi));
  double worst = 0;
  for (int i = 0; i < n; ++i) {
    const double x = uniform ? u(rng) : std::exp(u(rng));
    worst = std::max(worst, ulps(f(x), g(x)));
  }
  return worst;
}

}  // namespace

TEST(PortableMath, LogIsWithinTwoUlps) {
  auto f = [](double x) { return portable_log(x); };
  auto g = [](double x) { return double(std::log((long double)x)); };
  const double near_one = worst_ulps(f, g, 1 - 1e-3, 1 + 1e-3, true);  // ln J of a tet
  const double half_two = worst_ulps(f, g, 0.5, 2, true);
  const double wide = worst_ulps(f, g, 1e-300, 1e300, false);
  RecordProperty("ulps_near_one", std::to_string(near_one));
  RecordProperty("ulps_wide", std::to_string(wide));
  EXPECT_LE(near_one, 2);
  EXPECT_LE(half_two, 2);
  EXPECT_LE(wide, 2);
  EXPECT_EQ(portable_log(1.0), 0.0);
  EXPECT_EQ(portable_log(std::exp(1.0)), std::log(std::exp(1.0)));
  EXPECT_EQ(portable_log(DBL_MIN / 4), std::log(DBL_MIN / 4));  // subnormal
  EXPECT_EQ(portable_log(0.0), -HUGE_VAL);
  EXPECT_TRUE(std::isnan(portable_log(-1.0)));
  EXPECT_EQ(portable_log(HUGE_VAL), HUGE_VAL);
}

TEST(PortableMath, ExpIsWithinOneUlp) {
  auto f = [](double x) { return portable_exp(x); };
  auto g = [](double x) { return double(std::exp((long double)x)); };
  const double unit = worst_ulps(f, g, -1, 1, true);
  const double softening = worst_ulps(f, g, -30, 0, true);  // the CE6 softening's exponents
  const double wide = worst_ulps(f, g, -700, 700, true);
  RecordProperty("ulps_wide", std::to_string(wide));
  EXPECT_LE(unit, 1);
  EXPECT_LE(softening, 1);
  EXPECT_LE(wide, 1);
  EXPECT_EQ(portable_exp(0.0), 1.0);
  EXPECT_EQ(portable_exp(1000.0), HUGE_VAL);
  EXPECT_EQ(portable_exp(-1000.0), 0.0);
  EXPECT_EQ(portable_exp(-HUGE_VAL), 0.0);
  EXPECT_TRUE(std::isnan(portable_exp(std::nan(""))));
  for (double x : {-745.0, -708.5, 709.7})  // subnormal results, and near the largest double
    EXPECT_LE(ulps(portable_exp(x), std::exp(x)), 2) << x;
}

TEST(PortableMath, CbrtIsWithinOneUlp) {
  auto f = [](double x) { return portable_cbrt(x); };
  auto g = [](double x) { return double(std::cbrt((long double)x)); };
  const double volumes = worst_ulps(f, g, 1e-18, 1e-3, false);  // tet volumes, m^3
  const double wide = worst_ulps(f, g, 1e-300, 1e300, false);
  RecordProperty("ulps_wide", std::to_string(wide));
  EXPECT_LE(volumes, 1);
  EXPECT_LE(wide, 1);
  for (int i = 1; i <= 100; ++i) EXPECT_EQ(portable_cbrt(double(i) * i * i), double(i)) << i;
  EXPECT_EQ(portable_cbrt(-27.0), -3.0);
  EXPECT_EQ(portable_cbrt(0.0), 0.0);
  EXPECT_EQ(portable_cbrt(HUGE_VAL), HUGE_VAL);
  EXPECT_LE(ulps(portable_cbrt(DBL_MIN / 8), std::cbrt(DBL_MIN / 8)), 2);  // subnormal
}
