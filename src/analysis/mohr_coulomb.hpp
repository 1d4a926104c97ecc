#pragma once
// Mohr-Coulomb envelope of a series of triaxial peaks (compression positive, Pa).
//
// At failure sigma_1 = a + b sigma_3 with b = (1 + sin phi) / (1 - sin phi) and
// a = 2 c cos phi / (1 - sin phi) (the unconfined strength). A least-squares line through
// the peaks (sigma_3, sigma_1) gives a and b, hence
//   phi = asin((b - 1) / (b + 1)),   c = a (1 - sin phi) / (2 cos phi),
// the envelope tau = c + sigma_n tan phi of the Mohr circles. The fit error is reported as
// the standard errors of c and phi (from those of a and b, first-order propagation) and the
// RMS misfit of sigma_1.
#include <vector>

#include "core/vec.hpp"

namespace fdem {

struct MohrCoulombFit {
  real cohesion = 0;           // Pa
  real friction_angle = 0;     // degrees
  real cohesion_se = 0;        // Pa, standard error (0 with two points or an exact fit)
  real friction_angle_se = 0;  // degrees, standard error
  real intercept = 0;          // Pa, sigma_1 at sigma_3 = 0 (fitted unconfined strength)
  real slope = 0;              // -, d sigma_1 / d sigma_3
  real rms_misfit = 0;         // Pa, RMS of sigma_1 - (a + b sigma_3)
};

/// Fits the envelope to peaks (sigma_3[i], sigma_1[i]). Throws InputError for fewer than two
/// points, all sigma_3 equal, or a slope <= 1 (no positive friction angle fits).
MohrCoulombFit fit_mohr_coulomb(const std::vector<real>& sigma3, const std::vector<real>& sigma1);

}  // namespace fdem
