#pragma once
// The sums of a step on the device: one array of slots that the passes add to, so that a step
// brings them to the host in one copy. On the host they become structs with named fields.
#include <array>

#include "core/config.hpp"
#include "core/vec.hpp"
#include "solver/device_loop.hpp"
#include "solver/sum_slots.hpp"

namespace fdem {

/// A force evaluation's start: the last one's scalars [0, kBad) kept at [kPrev, kPrev + kBad)
/// (when `keep`), then slots [0, clear) zeroed.
struct KeepAndClear {
  real* sums;
  bool keep;
  int clear;
  FDEM_HD void operator()() const {
    if (keep)
      for (int k = 0; k < SumSlots::kBad; ++k) sums[SumSlots::kPrev + k] = sums[k];
    for (int k = 0; k < clear; ++k) sums[k] = 0;
  }
};

/// A force evaluation's sums (slots [0, kBad)) by name: this rank's, or after the step's
/// reduction the whole model's where SumSlots::kWhole says so.
struct ForceSums {
  real candidates_changed = 0;  // activation: tets added and CE6 faces opened
  real touching = 0;            // contact pairs that touch
  real contact_slip = 0;        // J, friction dissipated by contact
  real contact_spring = 0;      // J, stored in the friction springs
  real contact_energy = 0;      // J, the pairs' contact energy (the volume law)
  real contact_power = 0;       // W
  real platen_top = 0;          // N, z reactions
  real platen_bottom = 0;
  real platen_friction = 0;  // J, dissipated by the platens' friction
  real pressure_power = 0;   // W
  real gravity_power = 0;    // W
  real viscous_power = 0;    // W
  real inverted = 0;         // TET4s with J <= 0
  real cohesive_power = 0;   // W, intact CE6s
  real friction_power = 0;   // W, broken CE6s
  static ForceSums from_slots(const real* b) {
    using S = SumSlots;
    ForceSums s;
    s.candidates_changed = b[S::kAdded], s.touching = b[S::kTouching], s.contact_slip = b[S::kConDiss];
    s.contact_spring = b[S::kConStored], s.contact_energy = b[S::kConEnergy], s.contact_power = b[S::kConPower],
    s.platen_top = b[S::kTop];
    s.platen_bottom = b[S::kBottom], s.platen_friction = b[S::kPlatenFric], s.pressure_power = b[S::kPressurePower];
    s.gravity_power = b[S::kGravity], s.viscous_power = b[S::kVisc], s.inverted = b[S::kInverted];
    s.cohesive_power = b[S::kCoh], s.friction_power = b[S::kFric];
    return s;
  }
};

/// The integration's sums (slots [kBad, kSums) of r) by name.
inline AdvanceSums advance_sums_from(const real* r) {
  using S = SumSlots;
  AdvanceSums out;
  out.bad = r[S::kBad], out.kinetic2 = r[S::kKinetic2], out.contact_power = r[S::kConPowerNew];
  out.pressure_power = r[S::kPressurePowerNew], out.gravity_power = r[S::kGravityNew], out.far = r[S::kFar];
  out.lost = r[S::kLost], out.reaction_power = r[S::kReactionPower];
  return out;
}

}  // namespace fdem
