#pragma once
// The evolving state of a run's nodes and CE6s, with its clock: what a step changes besides the
// loads' state, the energy ledger and the contact set, which hold and save their own. A
// checkpoint saves it as one thing (solver/solver.cpp puts the others after it).
#include <cstdint>
#include <vector>

#include "core/vec.hpp"
#include "solver/ce6_states.hpp"

namespace fdem {

class CheckpointOut;
class CheckpointIn;
struct GhostState;

struct SolverState {
  long step = 0;
  real time = 0;                        // s
  std::vector<Vec3> x, v, f;            // per node: position (m), velocity (m/s), force (N)
  Ce6States ce6;                        // per CE6: damage and friction anchors
  std::vector<std::uint8_t> ce6_broke;  // per CE6: set by the CE6 pass on the step it breaks

  /// At rest in the reference configuration X, nc CE6s intact, the clock at 0.
  void start(const std::vector<Vec3>& X, std::size_t nc);
  void save(CheckpointOut& out) const;
  /// A state save() wrote for the node and CE6 counts held now. A count that differs is the
  /// checkpoint's mismatch.
  void load(CheckpointIn& in);
  /// The contact ghosts grew (partition/grow.hpp): their nodes' and CE6s' state appended, their
  /// forces zero until the next evaluation.
  void append(const GhostState& added);
};

}  // namespace fdem
