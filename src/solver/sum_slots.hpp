#pragma once
// The slots of the device loop's sums array, by name: a step's passes add to them, and the
// step brings them to the host in one copy (solver/loop_sums.hpp names them there).
#include <array>

namespace fdem {

/// The slots of the loop's sums array. [0, kBad): a force evaluation's sums, [kBad, kSums): an
/// integration's. Gravity's and the element passes' come last of the first, and the
/// integration's kinetic energy and gravity power first of the second, so that a fused pass that
/// integrates sums into one run of slots (kGravity to kGravityNew). A pass that sums into a run
/// of slots asserts their order where it does.
struct SumSlots {
  enum Slot : int {
    kAdded,     // activation: tets it added to the candidates and CE6 faces it opened
    kMoved,     // the broad phase's watch: nodes that moved half the buffer
    kTouching,  // contact: touching pairs, slip dissipated, spring energy, contact energy, power
    kConDiss,
    kConStored,
    kConEnergy,
    kConPower,
    kTop,  // platens: the two reactions and the friction dissipated
    kBottom,
    kPlatenFric,
    kPressurePower,
    kGravity,  // gravity's power with the forces' velocities
    kVisc,     // the element passes: viscous power, inverted TET4s, CE6 powers, breaks
    kInverted,
    kCoh,
    kFric,
    kBreaks,
    kBad,  // integration: non-finite velocities, m v.v, gravity's new power, reach counts
    kKinetic2,
    kGravityNew,
    kFar,
    kLost,
    kConPowerNew,  // the last forces' powers with the new velocities
    kPressurePowerNew,
    kWatched,        // the broad phase's watch where the fused pass steps (with the new powers)
    kReactionPower,  // the prescribed velocities' reactions with the new velocities
    kSums = 26,      // (kReactionPower + 1 at most)
    kPrev = kSums,   // [kPrev, kPrev + kBad): the last evaluation's [0, kBad), kept for its step
    kAll = kPrev + kBad
  };
  static_assert(kReactionPower < kSums, "an integration's slots end before kPrev");
  /// The sums that the whole model sums over the ranks (the others are each rank's own).
  static constexpr std::array<int, 10> kWhole = {kTop,  kBottom,  kPlatenFric, kVisc,      kCoh,
                                                 kFric, kConDiss, kConStored,  kConEnergy, kTouching};
};

}  // namespace fdem
