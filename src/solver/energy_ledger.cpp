#include "solver/energy_ledger.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"
#include "solver/stable_step.hpp"

namespace fdem {

namespace {
/// f(value) for every value of the ledger's checkpoint part, in its order.
template <class Ledger, class F>
void each_saved(Ledger& e, F&& f) {
  for (auto* r : {&e.external, &e.cohesive, &e.friction, &e.viscous, &e.platen_friction, &e.contact, &e.contact_slip,
                  &e.initial_kinetic, &e.contact_spring, &e.contact_stored, &e.p_cohesive, &e.p_friction, &e.p_viscous,
                  &e.p_contact, &e.cohesive_start, &e.excavated})
    f(*r);
}
}  // namespace

void EnergyLedger::save(CheckpointOut& out) const {
  each_saved(*this, [&](const real& r) { out.put(r); });
}

void EnergyLedger::load(CheckpointIn& in) {
  each_saved(*this, [&](real& r) { in.get(r); });
}

std::string instability_advice(const Scene& scene, const StableStep& stable, real dt, const EnergyLedger& e,
                               long touching) {
  const SolverSettings& s = scene.solver;
  const Material& mat = scene.material();
  const real bound = stable.dt / scene.solver.time_step_safety;
  const real ratio = dt / bound;
  const real E = mat.youngs_modulus;
  // The CE6 penalty furthest above its material's E (an interface's: the softer side's E).
  real p_ce6 = 0, E_ce6 = E;
  auto consider = [&](const Material& law, real youngs) {
    const real p = std::max({law.cohesive_penalty_open, law.cohesive_penalty_tangential, law.cohesive_penalty_overlap});
    if (p / youngs > p_ce6 / E_ce6) p_ce6 = p, E_ce6 = youngs;
  };
  for (const Material& m : scene.materials) consider(m, m.youngs_modulus);
  for (const MaterialInterface& f : scene.interfaces) {
    real youngs = 1e300;
    for (const Material& m : scene.materials)
      if (m.name == f.between[0] || m.name == f.between[1]) youngs = std::min(youngs, m.youngs_modulus);
    consider(f.law, youngs);
  }
  for (const Joint& j : scene.joints) {  // (against the softest rock: a joint may lie in any)
    real youngs = 1e300;
    for (const Material& m : scene.materials) youngs = std::min(youngs, m.youngs_modulus);
    consider(j.law, youngs);
  }
  std::string cause;
  if (ratio > 1)
    cause = "the time step " + fmt(dt, 3) + " s is " + fmt(ratio, 3) + " x the stable-step bound " + fmt(bound, 3) +
            " s (limited by " + stable.limit + ")";
  else if (s.mass_scaling >= 100)
    cause = "mass scaling m = " + fmt(s.mass_scaling, 3) +
            ": the loading is no longer quasi-static and the inertia of the fragments dominates";
  else if (scene.contact.enabled() && touching > 0 && e.contact < -0.01 * std::max(std::fabs(e.input()), e.floor))
    cause = "tet-tet contact has put " + fmt(-e.contact, 3) + " J in (" + std::to_string(touching) +
            " pairs touching, penalty " + fmt(mat.contact_penalty, 3) + " Pa = " + fmt(mat.contact_penalty / E, 3) +
            " E)" +
            (scene.contact.law == ContactLaw::munjiza
                 ? ": Munjiza's contact force is not conservative, and overlapping fragments can feed energy in "
                   "whatever the time step; contact.law: volume is conservative (docs/physics.md)"
                 : ": the contact law is conservative, so the time step is too long for the touching pairs' "
                   "stiffness (docs/stability.md)");
  else if (p_ce6 > 1000 * E_ce6)
    cause = "the cohesive penalty " + fmt(p_ce6, 3) + " Pa (" + fmt(p_ce6 / E_ce6, 3) + " E)";
  else
    cause = "large deformation or fragment overlap beyond the stable-step bound " + fmt(bound, 3) + " s (limited by " +
            stable.limit + "); the time step is " + fmt(ratio, 3) + " of it";
  const std::string step_fix =
      s.time_step > 0 ? "lower solver.time_step (now " + fmt(s.time_step, 3) + " s, " + fmt(ratio, 3) +
                            " x the stable-step bound), or set it to 0 for the bound times solver.time_step_safety"
                      : "lower solver.time_step_safety (now " + fmt(s.time_step_safety, 3) +
                            ", <= 1 is stable for the small-strain model)";
  return "Cause: " + cause + ". Fix: " + step_fix +
         ", lower the penalties (material.contact_penalty, "
         "material.cohesive_penalty_*), or lower solver.mass_scaling (now " +
         fmt(s.mass_scaling, 3) + ")";
}

}  // namespace fdem
