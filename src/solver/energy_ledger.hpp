#pragma once
// The energy account of a run: the work each force has done so far and the last force
// evaluation's powers, from which the next interval's works begin. The monitor rows balance it
// against what is stored, dissipated and moving; a kinetic energy far above the work put in
// stops the run with advice on the likely cause.
#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
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
  real contact_stored = 0;   // J, the pairs' contact energy now (the volume law's W)
  // The last force evaluation's powers, W (contact's with the velocities of that evaluation).
  real p_cohesive = 0, p_friction = 0, p_viscous = 0, p_contact = 0;
  real floor = 0;  // J, the scale below which the balance's error is measured against it
  // J, the work the boundary conditions that put energy in have done (their positive works, set
  // at each monitor row). Where an absorbing boundary takes out what came in, the net input is
  // near zero: the balance is then measured against what came in.
  real inflow = 0;
  // J, the elastic energy of the in-situ stress (scene initial_stress): the most that releasing
  // it, as a free face or an excavation does, can turn into motion with no work put in.
  real in_situ = 0;
  // J, what the rock has given up of it so far (minus the strain energy, set at each monitor row):
  // the scale of a balance with no work put in.
  real released = 0;
  // J, the CE6s' stored energy in the in-situ state, from which their stored energy counts
  // (less an excavation's removed CE6s').
  real cohesive_start = 0;
  // J, the strain and kinetic energy the excavation stages took out with their rock.
  real excavated = 0;

  /// Its part of a checkpoint: the works and the last powers (the floor comes from the scene).
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);

  /// J, the work put in: external work and the initial kinetic energy.
  real input() const { return external + initial_kinetic; }

  /// The elements' and the top platen's works over a step of dt (s) from the last force
  /// evaluation's powers; the platen moved down at `platen_speed` (m/s) against `force_top` (N).
  void add_step_works(real dt, real force_top, real platen_speed) {
    external += force_top * (-platen_speed * dt);
    viscous += p_viscous * dt;
    cohesive += p_cohesive * dt;
    friction += p_friction * dt;
  }

  /// J, what the ledger holds stored, dissipated and moving, with the kinetic, strain and
  /// platen-spring energies a monitor row measures (the CE6s' stored energy is in `cohesive`,
  /// the friction springs' of broken faces in `friction`).
  real accounted(real kinetic, real strain, real platen_stored) const {
    return kinetic + strain + cohesive + friction + viscous + platen_stored + platen_friction + contact + excavated;
  }
  /// The balance's relative error: |input - accounted| over the input (or the floor, the
  /// conditions' inflow or the in-situ energy released where larger).
  real balance_error(real accounted) const {
    return std::fabs(input() - accounted) / std::max({std::fabs(input()), floor, inflow, released});
  }

  /// The checks that stop an unstable run with RunError. `at`: "step n (t = ... s)"; `advice`
  /// returns instability_advice() (built only when a check fails). `own_work`: prescribed
  /// velocities (tests) bring work the ledger does not count, so the runaway and balance checks
  /// are off.
  /// A kinetic energy ke (J) far above the work put in.
  template <class Advice>
  void check_runaway(real ke, bool own_work, const std::string& at, Advice&& advice) const {
    if (own_work || ke <= 2 * (std::fabs(input()) + in_situ) + floor) return;
    throw RunError(at + ": kinetic energy " + fmt(ke, 3) + " J against external work " + fmt(input(), 3) +
                   " J: the run is unstable. " + advice());
  }
  /// A monitor row's checks, in this order: an energy no longer finite, the runaway check with
  /// the row's kinetic energy ke (J), and (tolerance > 0) a balance off by more than it.
  template <class Advice>
  void check_row(real accounted, real ke, real tolerance, bool own_work, const std::string& at, Advice&& advice) const {
    if (!std::isfinite(accounted))
      throw RunError(at + ": an energy is no longer finite: the run is unstable. " + advice());
    check_runaway(ke, own_work, at, advice);
    const real error = balance_error(accounted);
    if (tolerance > 0 && !own_work && std::max({std::fabs(input()), inflow, released}) > 100 * floor &&
        error > tolerance)
      throw RunError(at + ": the energy balance is off by " + fmt(100 * error, 3) + " % of the work put in (" +
                     fmt(input(), 3) + " J against " + fmt(accounted, 3) +
                     " J stored, dissipated and kinetic), above solver.max_energy_error " + fmt(100 * tolerance, 3) +
                     " %: the run is unstable. " + advice());
  }
};

/// What an unstable run is told: "Cause: ... Fix: ...", the time step against its bound, mass
/// scaling, contact's energy, the penalties, in that order of likelihood. `touching`: pairs in
/// contact at the last evaluation.
std::string instability_advice(const Scene& scene, const StableStep& stable, real dt, const EnergyLedger& e,
                               long touching);

}  // namespace fdem
