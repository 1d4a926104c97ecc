#pragma once
// Loads on surface faces besides the confining pressure (physics/confinement.hpp, whose
// follower pressure the `pressure` condition shares): a fixed traction on the reference area,
// and viscous dashpots that absorb waves leaving the model (Lysmer and Kuhlemeyer: a plane wave
// meeting the boundary head-on is absorbed whole). Each gives a face's force per corner.
#include <cmath>

#include "core/vec.hpp"

namespace fdem {

/// N, each corner's share of traction t (Pa, a fixed vector) on a face of reference area
/// area0 (m^2): a dead load that does not turn with the face.
FDEM_HD Vec3 face_traction_force(Vec3 t, real area0) {
  return (area0 / 3) * t;
}

/// Pa s/m, the rock's P and S impedances rho c_p and rho c_s: the dashpots' coefficients per unit
/// area. rho (kg/m^3) is the mass-scaled density, which sets the waves' speed in the run.
FDEM_HD real p_impedance(real rho, real lambda, real mu) {
  return std::sqrt(rho * (lambda + 2 * mu));
}
FDEM_HD real s_impedance(real rho, real mu) {
  return std::sqrt(rho * mu);
}

/// N, each corner's share of the dashpots on the face with corners a, b, c (m, ordered so that
/// (b - a) x (c - a) points out of the rock) moving at the mean velocity vm of its corners (m/s):
/// -(A/3) (zp (vm.n) n + zs (vm - (vm.n) n)), with A and n the face's current area and outward
/// normal, zp = rho c_p and zs = rho c_s the P and S impedances (Pa s/m). It only takes energy
/// out: its power on the three corners is -A (zp (vm.n)^2 + zs |vm_t|^2).
FDEM_HD Vec3 face_dashpot_force(real zp, real zs, Vec3 a, Vec3 b, Vec3 c, Vec3 vm) {
  const Vec3 area = real(0.5) * cross(b - a, c - a);
  const real A = norm(area);
  if (!(A > 0)) return Vec3{0, 0, 0};
  const Vec3 n = (1 / A) * area;
  const real vn = dot(vm, n);
  return (-A / 3) * (zp * vn * n + zs * (vm - vn * n));
}

}  // namespace fdem
