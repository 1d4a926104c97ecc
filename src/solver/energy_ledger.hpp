#pragma once
// The energy account of a run: the work each force has done so far and the last force
// evaluation's powers, from which the next interval's works begin. The monitor rows balance it
// against what is stored, dissipated and moving; a kinetic energy far above the work put in
// stops the run with advice on the likely cause.
#include <string>

#include "core/vec.hpp"
#include "scene/scene.hpp"

namespace fdem {

struct StableStep;

struct EnergyLedger {
  // Works integrated over time, J.
  real external = 0;         // platens, confining pressure and gravity
  real cohesive = 0;         // CE6 cohesive forces: stored and dissipated
  real friction = 0;         // CE6 friction of broken faces
  real viscous = 0;          // TET4 damping
  real platen_friction = 0;  // dissipated by sliding on the platens
  real contact = 0;          // tet-tet contact forces, normal and friction
  real contact_slip = 0;     // of that, the friction work dissipated by sliding
  real initial_kinetic = 0;  // velocities set before the first step
  real contact_spring = 0;   // J, the contact friction springs' energy now
  // The last force evaluation's powers, W (contact's with the velocities of that evaluation).
  real p_cohesive = 0, p_friction = 0, p_viscous = 0, p_contact = 0;
  real floor = 0;  // J, the scale below which the balance's error is measured against it

  /// J, the work put in: external work and the initial kinetic energy.
  real input() const { return external + initial_kinetic; }
};

/// What an unstable run is told: "Cause: ... Fix: ...", the time step against its bound, mass
/// scaling, contact's energy, the penalties, in that order of likelihood. `touching`: pairs in
/// contact at the last evaluation.
std::string instability_advice(const Scene& scene, const StableStep& stable, real dt, const EnergyLedger& e,
                               long touching);

}  // namespace fdem
