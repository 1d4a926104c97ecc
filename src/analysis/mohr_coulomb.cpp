#include "analysis/mohr_coulomb.hpp"

#include <cmath>

#include "core/error.hpp"
#include "core/format.hpp"

namespace fdem {

MohrCoulombFit fit_mohr_coulomb(const std::vector<real>& sigma3, const std::vector<real>& sigma1) {
  const std::size_t n = sigma3.size();
  if (n != sigma1.size()) throw InputError("Mohr-Coulomb fit: sigma_3 and sigma_1 lists differ in length");
  if (n < 2) throw InputError("Mohr-Coulomb fit: need peaks at two or more confining pressures");
  real m3 = 0, m1 = 0;
  for (std::size_t i = 0; i < n; ++i) m3 += sigma3[i] / n, m1 += sigma1[i] / n;
  real s33 = 0, s31 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    s33 += (sigma3[i] - m3) * (sigma3[i] - m3);
    s31 += (sigma3[i] - m3) * (sigma1[i] - m1);
  }
  if (!(s33 > 0)) throw InputError("Mohr-Coulomb fit: all peaks have the same confining pressure");
  MohrCoulombFit f;
  f.slope = s31 / s33;
  f.intercept = m1 - f.slope * m3;
  if (!(f.slope > 1))
    throw InputError("Mohr-Coulomb fit: sigma_1 grows by " + fmt(f.slope, 4) +
                     " per unit sigma_3 (need more than 1 for a positive friction angle)");
  real sse = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const real r = sigma1[i] - (f.intercept + f.slope * sigma3[i]);
    sse += r * r;
  }
  f.rms_misfit = std::sqrt(sse / n);
  const real b = f.slope, a = f.intercept;
  const real sin_phi = (b - 1) / (b + 1);
  const real phi = std::asin(sin_phi), cos_phi = std::cos(phi);
  f.friction_angle = phi * 180 / M_PI;
  f.cohesion = a * (1 - sin_phi) / (2 * cos_phi);
  if (n > 2) {
    // Standard errors of the line, then first-order propagation to c and phi.
    const real var = sse / (n - 2);
    const real se_b = std::sqrt(var / s33);
    const real se_a = std::sqrt(var * (1.0 / n + m3 * m3 / s33));
    const real cov_ab = -m3 * var / s33;
    // dphi/db = 1 / ((b + 1) sqrt(b)); c = a / (2 sqrt(b)) since (1 - sin)/cos = 1/sqrt(b).
    const real dphi_db = 1 / ((b + 1) * std::sqrt(b));
    f.friction_angle_se = dphi_db * se_b * 180 / M_PI;
    const real dc_da = 1 / (2 * std::sqrt(b)), dc_db = -a / (4 * b * std::sqrt(b));
    f.cohesion_se = std::sqrt(dc_da * dc_da * se_a * se_a + dc_db * dc_db * se_b * se_b + 2 * dc_da * dc_db * cov_ab);
  }
  return f;
}

}  // namespace fdem
