#pragma once
// Contact ghosts that follow the fragments (design §4): when nodes have moved far from where the
// ranks last planned their contact ghosts, every rank looks again, with the current positions,
// for the other ranks' tets within the contact reach of its own, and the owners send the ones
// it lacks, with their state, when the broad phase rebuilds. See docs/architecture.md,
// "Multi-rank runs".
#include <mpi.h>

#include <cstdint>
#include <vector>

#include "partition/partition.hpp"
#include "physics/cohesive6.hpp"

namespace fdem {

/// The evolving state of a rank model's nodes, CE6s and tets, as a growth appends it.
struct GhostState {
  std::vector<Vec3> x, v;            // per node: position (m) and velocity (m/s)
  std::vector<Ce6State> ce6;         // per CE6
  std::vector<std::uint8_t> active;  // per tet: contact candidate (empty without contact)
};

/// The state a gathering reads, where it lies (nothing is copied): per node x and v, per CE6
/// its damage and friction anchors, per tet its activation flag (empty without contact).
struct GhostStateNow {
  const std::vector<Vec3>& x;
  const std::vector<Vec3>& v;
  const std::vector<Ce6Damage>& ce6_damage;
  const std::vector<Ce6Anchors>& ce6_anchors;
  const std::vector<std::uint8_t>& active;
  /// CE6 c's state as one value, as a ghost's record carries it.
  Ce6State ce6_state(int c) const { return ce6_state_of(ce6_damage[c], ce6_anchors[c]); }
};

/// What a gathering appended to a rank model.
struct GhostGrowth {
  GhostState added;      // x, v of the appended nodes, state of the appended CE6s, flags of the tets
  long added_tets = 0;   // appended here
  long added_total = 0;  // appended on all ranks together
};

/// Collective on comm. Every rank finds, with the positions in `now`, the tets of other ranks
/// whose boxes come within dd.reach of the box of one of its own tets (as plan_partition does in
/// the reference configuration), asks their owners for those it does not hold, and appends them
/// to m and dd in place: the tet, its nodes (owner, groups, position and velocity), its CE6s to
/// tets it holds (with their damage and slip), its surface faces and its activation flag.
/// The model is not copied, and every old local id keeps its meaning. Every rank holding a tet
/// learns who else holds it, so the lists of shared tets stay the same on both sides of every
/// pair (in global order). Ghosts are never dropped: a rank model only grows. The appended
/// elements are in no colouring (they act on no owned node, so this rank never computes them).
/// Where no rank lacks a tet, added_total is 0 and m and dd are unchanged. The RunErrors of a
/// bad request or holder list are thrown before anything is appended.
GhostGrowth grow_contact_ghosts(MPI_Comm comm, Model& m, Decomposition& dd, const GhostStateNow& now);

}  // namespace fdem
