#pragma once
// Stable time step of the explicit central-difference scheme.
//   TET4: dt = 2/w (sqrt(1 + xi^2) - xi) with w the element's highest natural frequency
//         (lumped mass) and xi its damping ratio (the element bound is an upper bound
//         for a mesh of tets alone).
//         w^2 and 2 xi w are the largest eigenvalues of M^-1 K and M^-1 C (12x12), found
//         by power iteration: K u at node i is V sigma(eps(u)) g_i with g_i = grad N_i,
//         C the same with the viscous stress eta eps.
//   The solver bounds the assembled model node by node (Solver::stable_step_bound): the
//   TET4 eigenvalue plus the row sums of the CE6 penalty springs (k = P A / (3 h) per node
//   pair) and platen springs at the node, over its mass.
#include <cmath>

#include "core/vec.hpp"

namespace fdem {

/// Largest eigenvalue of M^-1 K for a tet with lumped mass rho V / 4 per node and an
/// isotropic stress law sigma = lambda tr(eps) I + 2 mu eps (1/s^2).
FDEM_HD real tet4_max_eigenvalue(const Mat3& Xinv, real lambda, real mu, real density) {
  Vec3 g[4];
  g[0] = {0, 0, 0};
  for (int j = 1; j < 4; ++j) {
    g[j] = {Xinv.a[j - 1][0], Xinv.a[j - 1][1], Xinv.a[j - 1][2]};
    g[0] -= g[j];
  }
  // A start vector with components along every deformation mode.
  Vec3 u[4] = {{1, 0.3, -0.7}, {-0.2, 1, 0.5}, {0.6, -0.9, 1}, {-1, 0.1, 0.4}};
  real lam_max = 0;
  for (int it = 0; it < 60; ++it) {
    Mat3 eps = Mat3::zero();
    for (int j = 0; j < 4; ++j)
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b) eps.a[a][b] += real(0.5) * (u[j][a] * g[j][b] + u[j][b] * g[j][a]);
    const real tr = trace(eps);
    Mat3 sig = (2 * mu) * eps;
    for (int a = 0; a < 3; ++a) sig.a[a][a] += lambda * tr;
    Vec3 w[4];
    real uu = 0, uw = 0, ww = 0;
    for (int i = 0; i < 4; ++i) {
      w[i] = (4 / density) * (sig * g[i]);
      uu += dot(u[i], u[i]);
      uw += dot(u[i], w[i]);
      ww += dot(w[i], w[i]);
    }
    lam_max = uw / uu;        // Rayleigh quotient
    if (!(ww > 0)) return 0;  // no stiffness (e.g. an undamped element's C)
    const real s = 1 / std::sqrt(ww);
    for (int i = 0; i < 4; ++i) u[i] = s * w[i];
  }
  return lam_max;
}

/// Stable step of a mode with squared frequency w2 (1/s^2) and damping rate c = 2 xi w (1/s):
/// 2/w (sqrt(1 + xi^2) - xi).
FDEM_HD real damped_stable_step(real w2, real c) {
  const real w = std::sqrt(w2);
  const real xi = c / (2 * w);
  return 2 / w * (std::sqrt(1 + xi * xi) - xi);
}

/// Stable step of one damped TET4 (s); eta the viscous coefficient (sigma_v = eta D).
FDEM_HD real tet4_stable_step(const Mat3& Xinv, real lambda, real mu, real eta, real density_scaled) {
  return damped_stable_step(tet4_max_eigenvalue(Xinv, lambda, mu, density_scaled),
                            tet4_max_eigenvalue(Xinv, 0, real(0.5) * eta, density_scaled));
}

/// Critical viscous damping coefficient (reference paper Eq. 2), Pa s.
FDEM_HD real critical_damping(real h, real mass_scaling, real density, real youngs) {
  return 2 * h * std::sqrt(mass_scaling * density * youngs);
}

}  // namespace fdem
