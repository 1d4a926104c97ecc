// Central-difference integration and the stable time step: against a spring's exact
// solution, a pair of masses, and the exact eigenvalues of one TET4 (Eigen).
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>

#include "physics/integrate.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"
#include "scene/scene.hpp"

using namespace fdem;

namespace {

/// Largest |x| of a mass-spring(-damper) integrated for n steps of dt from x = 1.
real spring_run(real m, real k, real c, real dt, int n) {
  Vec3 x{1, 0, 0}, v{0, 0, 0};
  real peak = 0;
  for (int i = 0; i < n; ++i) {
    const Vec3 f = -k * x - c * v;
    central_difference(x, v, f, 1 / m, dt);
    peak = std::max(peak, std::fabs(x.x));
  }
  return peak;
}

}  // namespace

TEST(Integration, CentralDifferenceFollowsTheHarmonicOscillatorToSecondOrder) {
  const real m = 2, k = 50, w = std::sqrt(k / m), T = 2 * M_PI / w;
  // At a quarter period x crosses zero, so |x| there is the phase error, O(dt^2).
  auto error_at_quarter = [&](int steps) {
    const real dt = 0.25 * T / steps;
    Vec3 x{1, 0, 0}, v{0, 0, 0};
    // Half-step start: v^{-1/2} = v(0) - dt/2 a(0) keeps the scheme second order.
    v.x = 0.5 * dt * k / m;
    for (int i = 0; i < steps; ++i) central_difference(x, v, -k * x, 1 / m, dt);
    return std::fabs(x.x);
  };
  const real e1 = error_at_quarter(50), e2 = error_at_quarter(100);
  EXPECT_LT(e1, 1e-3);
  EXPECT_NEAR(e1 / e2, 4.0, 0.2);  // halving dt quarters the error
}

TEST(Integration, StableJustBelowTwoOverOmegaUnstableJustAbove) {
  const real m = 1, k = 1e6, w = std::sqrt(k / m);
  // Bounded just below the limit (the amplitude grows to 1/sqrt(1 - (w dt/2)^2) = 3.2 at
  // 0.95 of it, but no further), growing without bound just above.
  EXPECT_LT(spring_run(m, k, 0, 0.95 * 2 / w, 5000), 3.3);
  EXPECT_GT(spring_run(m, k, 0, 1.02 * 2 / w, 5000), 1e3);
}

TEST(TimeStep, DampingLowersTheStableStepAsPredicted) {
  // One damped mode: dt = 2/w (sqrt(1 + xi^2) - xi). Check just inside and outside.
  const real m = 1, k = 1e6, w = std::sqrt(k / m), xi = 1.5, c = 2 * xi * w * m;
  const real dt = damped_stable_step(w * w, c / m);
  EXPECT_LT(spring_run(m, k, c, 0.98 * dt, 20000), 1.01);
  EXPECT_GT(spring_run(m, k, c, 1.02 * dt, 20000), 1e3);
}

TEST(TimeStep, Tet4PowerIterationMatchesTheExactElementEigenvalue) {
  const Material mat;
  const real lam = mat.lame_lambda(), mu = mat.lame_mu(), rho = mat.density;
  const Vec3 X[4] = {
      {0.001, -0.0004, 0.0002}, {0.0031, 0.0003, -0.0001}, {0.0005, 0.0027, 0.0004}, {0.0008, 0.0006, 0.0029}};
  const Tet4Reference ref = tet4_reference(X);
  // Stiffness by central differences of the force (linear regime), lumped mass rho V / 4.
  Eigen::Matrix<double, 12, 12> K;
  const real h = 1e-12;
  for (int j = 0; j < 12; ++j) {
    Vec3 xp[4], xm[4], v[4] = {}, fp[4], fm[4];
    for (int i = 0; i < 4; ++i) xp[i] = xm[i] = X[i];
    xp[j / 3][j % 3] += h;
    xm[j / 3][j % 3] -= h;
    tet4_forces(xp, v, ref.Xinv, ref.V0, lam, mu, 0, fp);
    tet4_forces(xm, v, ref.Xinv, ref.V0, lam, mu, 0, fm);
    for (int i = 0; i < 12; ++i) K(i, j) = -(fp[i / 3][i % 3] - fm[i / 3][i % 3]) / (2 * h);
  }
  K = 0.5 * (K + K.transpose()).eval();
  const real mass = rho * ref.V0 / 4;
  const real exact = Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>>(K / mass).eigenvalues().maxCoeff();
  EXPECT_NEAR(tet4_max_eigenvalue(ref.Xinv, lam, mu, rho), exact, 1e-4 * exact);
  // Undamped, the step is exactly 2 / w_max.
  EXPECT_NEAR(tet4_stable_step(ref.Xinv, lam, mu, 0, rho), 2 / std::sqrt(exact), 1e-4 * 2 / std::sqrt(exact));
}

TEST(Loading, RampIsSmoothAndReachesTheSpeed) {
  const real v = 0.1, T = 1e-4;
  EXPECT_EQ(ramped_speed(0, v, T), 0);
  EXPECT_EQ(ramped_speed(T, v, T), v);
  EXPECT_EQ(ramped_speed(2 * T, v, T), v);
  EXPECT_NEAR(ramped_speed(0.5 * T, v, T), 0.5 * v, 1e-15);
  // C1: the slope vanishes at both ends of the ramp.
  const real e = 1e-6 * T;
  EXPECT_LT(ramped_speed(e, v, T) / e, 1e-4 * v / T);
  EXPECT_LT((v - ramped_speed(T - e, v, T)) / e, 1e-4 * v / T);
}

TEST(Damping, CriticalDampingIsTheReferenceFormula) {
  EXPECT_DOUBLE_EQ(critical_damping(1e-3, 5, 1800, 12.2e9), 2 * 1e-3 * std::sqrt(5 * 1800 * 12.2e9));
}
