#pragma once
// Central difference with velocities at half steps:
//   v^{n+1/2} = v^{n-1/2} + dt f^n / m,   x^{n+1} = x^n + dt v^{n+1/2}.
#include "core/vec.hpp"

namespace fdem {

FDEM_HD void central_difference(Vec3& x, Vec3& v, Vec3 f, real inv_mass, real dt) {
  v += (dt * inv_mass) * f;
  x += dt * v;
}

/// Smooth start of a prescribed speed: 0 at t=0, `speed` from t=ramp on, C1 in between.
FDEM_HD real ramped_speed(real t, real speed, real ramp) {
  if (!(ramp > 0) || t >= ramp) return speed;
  const real s = t / ramp;
  return speed * s * s * (3 - 2 * s);
}

}  // namespace fdem
