#pragma once
// Confining pressure on the lateral surface: a follower load. Each face of current area vector
// a (outward, half the cross product of two edges) puts -p a / 3 on each of its corners, so the
// load turns and stretches with the surface. The pressure follows one of two paths: constant
// (sigma_3 after a smooth ramp) or hydrostatic (the platens' mean axial stress, up to sigma_3).
#include "core/vec.hpp"

namespace fdem {

/// Pa, the mean axial stress (compression positive) of the platens' reactions on the rock along
/// +z (N), over the loaded area area0 (m^2; 0: no loaded area, no stress).
FDEM_HD real mean_axial_stress(real force_top, real force_bottom, real area0) {
  return area0 > 0 ? real(0.5) * (-force_top + force_bottom) / area0 : 0;
}

/// Pa, the pressure of an evaluation: on the hydrostatic path the axial stress `axial` (Pa)
/// between 0 and `target`; on the constant path `ramped`, the target's ramp at its time.
FDEM_HD real confining_pressure(bool hydrostatic, real target, real ramped, real axial) {
  if (!hydrostatic) return ramped;
  return axial < 0 ? 0 : (axial < target ? axial : target);
}

/// N, each corner's share of pressure p (Pa) on the face with corners a, b, c (m), ordered so
/// that (b - a) x (c - a) points out of the rock.
FDEM_HD Vec3 face_pressure_force(real p, Vec3 a, Vec3 b, Vec3 c) {
  const Vec3 area = real(0.5) * cross(b - a, c - a);
  return (-p / 3) * area;
}

}  // namespace fdem
