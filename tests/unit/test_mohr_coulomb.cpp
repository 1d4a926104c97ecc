// fit_mohr_coulomb: recovers c and phi exactly from peaks on a known envelope, reports a
// standard error that covers the truth for noisy peaks, and refuses series it cannot fit.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "analysis/mohr_coulomb.hpp"
#include "core/error.hpp"

using namespace fdem;

namespace {

/// sigma_1 at failure on the envelope tau = c + sigma tan(phi).
real sigma1_on_envelope(real c, real phi_deg, real s3) {
  const real s = std::sin(phi_deg * M_PI / 180), co = std::cos(phi_deg * M_PI / 180);
  return 2 * c * co / (1 - s) + s3 * (1 + s) / (1 - s);
}

}  // namespace

TEST(MohrCoulomb, RecoversCohesionAndFrictionAngleExactly) {
  for (real phi : {15.0, 25.0, 40.0}) {
    const real c = 4.2e6;
    std::vector<real> s3{0, 2.5e6, 5e6, 7.5e6, 10e6, 12.5e6, 15e6}, s1;
    for (real x : s3) s1.push_back(sigma1_on_envelope(c, phi, x));
    const MohrCoulombFit f = fit_mohr_coulomb(s3, s1);
    EXPECT_NEAR(f.cohesion, c, 1e-9 * c) << phi;
    EXPECT_NEAR(f.friction_angle, phi, 1e-9 * phi);
    EXPECT_NEAR(f.intercept, sigma1_on_envelope(c, phi, 0), 1e-3);
    EXPECT_LT(f.rms_misfit, 1e-6);
    EXPECT_LT(f.cohesion_se, 1e-6 * c);
    EXPECT_LT(f.friction_angle_se, 1e-9);
  }
  // Two points define the line exactly (no error estimate).
  const MohrCoulombFit two =
      fit_mohr_coulomb({0, 10e6}, {sigma1_on_envelope(3e6, 30, 0), sigma1_on_envelope(3e6, 30, 10e6)});
  EXPECT_NEAR(two.friction_angle, 30, 1e-9);
  EXPECT_NEAR(two.cohesion, 3e6, 1e-3);
}

TEST(MohrCoulomb, NoisyPeaksGiveAnErrorThatCoversTheTruth) {
  const real c = 4.2e6, phi = 25;
  std::mt19937 rng(11);
  std::normal_distribution<real> noise(0, 0.5e6);  // 0.5 MPa scatter on sigma_1
  int covered_c = 0, covered_phi = 0;
  const int trials = 200;
  for (int t = 0; t < trials; ++t) {
    std::vector<real> s3{0, 2.5e6, 5e6, 7.5e6, 10e6, 12.5e6, 15e6}, s1;
    for (real x : s3) s1.push_back(sigma1_on_envelope(c, phi, x) + noise(rng));
    const MohrCoulombFit f = fit_mohr_coulomb(s3, s1);
    ASSERT_GT(f.cohesion_se, 0);
    ASSERT_GT(f.friction_angle_se, 0);
    EXPECT_GT(f.rms_misfit, 0.1e6);
    EXPECT_LT(f.rms_misfit, 1.0e6);
    covered_c += std::fabs(f.cohesion - c) < 2 * f.cohesion_se;
    covered_phi += std::fabs(f.friction_angle - phi) < 2 * f.friction_angle_se;
  }
  // Two standard errors cover the truth about 90-95 % of the time with 5 degrees of freedom.
  EXPECT_GT(covered_c, 0.8 * trials);
  EXPECT_GT(covered_phi, 0.8 * trials);
  EXPECT_LT(covered_phi, trials);  // and the error is not absurdly wide
  RecordProperty("coverage_c", std::to_string(double(covered_c) / trials));
  RecordProperty("coverage_phi", std::to_string(double(covered_phi) / trials));
}

TEST(MohrCoulomb, RefusesSeriesItCannotFit) {
  EXPECT_THROW(fit_mohr_coulomb({5e6}, {20e6}), InputError);
  EXPECT_THROW(fit_mohr_coulomb({5e6, 5e6}, {20e6, 21e6}), InputError);
  EXPECT_THROW(fit_mohr_coulomb({0, 10e6}, {20e6, 25e6}), InputError);  // slope 0.5: phi < 0
  EXPECT_THROW(fit_mohr_coulomb({0, 10e6}, {20e6}), InputError);
}
