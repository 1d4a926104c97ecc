#pragma once
// Central difference with velocities at half steps:
//   v^{n+1/2} = v^{n-1/2} + dt f^n / m,   x^{n+1} = x^n + dt v^{n+1/2}.
#include "core/vec.hpp"

namespace fdem {

FDEM_HD void central_difference(Vec3& x, Vec3& v, Vec3 f, real inv_mass, real dt) {
  v += (dt * inv_mass) * f;
  x += dt * v;
}

/// A prescribed velocity after a step of dt: each component d with bit d of `mask` takes
/// `prescribed`, and x the displacement that velocity makes over the step instead of v's.
FDEM_HD void prescribe_velocity(Vec3& x, Vec3& v, int mask, Vec3 prescribed, real dt) {
  for (int d = 0; d < 3; ++d)
    if (mask >> d & 1) {
      x[d] += dt * (prescribed[d] - v[d]);
      v[d] = prescribed[d];
    }
}

/// Smooth start of a prescribed speed: 0 at t=0, `speed` from t=ramp on, C1 in between.
FDEM_HD real ramped_speed(real t, real speed, real ramp) {
  if (!(ramp > 0) || t >= ramp) return speed;
  const real s = t / ramp;
  return speed * s * s * (3 - 2 * s);
}

}  // namespace fdem
