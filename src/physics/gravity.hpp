#pragma once
// Gravity: a body force on every node's lumped mass, f = m g. Its power is f . v.
#include "core/vec.hpp"

namespace fdem {

/// N, the weight of a node of mass m (kg) under gravity g (m/s^2).
FDEM_HD Vec3 gravity_force(real m, Vec3 g) {
  return m * g;
}

}  // namespace fdem
