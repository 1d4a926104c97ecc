#pragma once
// Tet-tet contact's state on the host: activation flags, the candidate-pair list, the friction
// springs, the last forces of each pair and the gather index that sums them into the node forces
// (no atomics). The device loop builds and evaluates them (solver/device_loop_impl.hpp); this is
// their host copy for checkpoints, outputs and tests.
#include <array>
#include <cstdint>
#include <vector>

#include "contact/broad_phase.hpp"
#include "model/model.hpp"
#include "physics/cohesive6.hpp"
#include "physics/contact.hpp"
#include "scene/scene.hpp"

namespace fdem {

class CheckpointOut;
class CheckpointIn;

/// A candidate pair: tets a < b and the CE6 that joins them (-1 if none). While that CE6
/// is intact the pair is skipped; once it breaks the two faces meet through contact.
struct ContactPair {
  int a, b, joint;
};

/// Wall time spent in each phase, s, and how often the broad phase ran.
struct ContactTimes {
  double broad = 0, narrow = 0;  // (narrow: the pairs' pass with their friction, and the gather)
  long rebuilds = 0;
};

class ContactSet {
 public:
  ContactSet() = default;
  ContactSet(const Model& m, const Scene& s);

  bool enabled() const { return enabled_; }
  /// Flags the vicinity of CE6 `c` (every tet sharing a vertex of its face). Returns the
  /// number of tets newly activated.
  long activate_ce6(const Model& m, int c);
  /// Rebuild the candidate list at the next evaluation (as after an activation change).
  void request_rebuild() { dirty_ = true; }

  /// A rank's part of a decomposed model (partition/): the rank holds every tet within `reach`
  /// (m) of its own tets (tet_owned, which must outlive the set) at the node positions `plan_x`
  /// (the reference configuration at the start, the positions of the last growth of the contact
  /// ghosts after one, partition/grow.hpp); check_reach() guards that.
  void set_ownership(const std::vector<std::uint8_t>* tet_owned, real reach, const std::vector<Vec3>& plan_x);
  /// Several ranks: throws RunError, naming the tet and a reach to try, when a node of an owned
  /// tet has moved half the contact reach from plan_x (a partner this rank lacks could have
  /// touched it).
  void check_reach(const Model& m, const std::vector<Vec3>& x) const;
  /// The node positions the reach counts from (empty on one rank); set_plan(x) after a growth.
  const std::vector<Vec3>& plan_x() const { return plan_x_; }
  void set_plan(const std::vector<Vec3>& x) { plan_x_ = x; }

  const std::vector<std::uint8_t>& active() const { return active_; }
  long active_count() const { return active_count_; }
  long pair_count() const { return long(pairs_.size()); }
  real buffer() const { return buffer_; }
  const std::vector<ContactPair>& pairs() const { return pairs_; }
  /// The last evaluation's forces of each pair (8: a's nodes, then b's; N), for tests.
  const std::vector<Vec3>& pair_forces() const { return pair_force_; }
  const BroadPhaseStats& last_build() const { return stats_; }
  ContactTimes times;

  /// Friction springs per pair (same order as pairs()), for checkpoints and tests.
  std::vector<Vec3> spring;

  /// Everything that changes during a run (flags, pairs, springs, the last forces and the
  /// broad phase's watch list), so a restarted run continues bit for bit.
  /// With `appended`, the state of a set whose model has these tets' flags appended (the
  /// contact ghosts grew): the saved flags are extended with them and the pairs rebuilt at the
  /// next evaluation.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, const std::vector<std::uint8_t>* appended = nullptr);

 private:
  template <class>
  friend class DeviceLoopImpl;  // the device loop's narrow phase works on these arrays

  const std::vector<std::uint8_t>* tet_owned_ = nullptr;
  real reach_ = 0;
  std::vector<Vec3> plan_x_;

  bool enabled_ = false;
  real penalty_ = 0, mu_ = 0, buffer_ = 0;
  std::vector<std::uint8_t> active_;
  long active_count_ = 0;
  bool dirty_ = true;                              // activation changed since the last build
  std::vector<int> vertex_tet_ptr_, vertex_tets_;  // mesh vertex -> tets touching it (CSR)
  std::vector<std::array<int, 4>> tet_ce6_;        // CE6 on each face of a tet (-1 none)
  std::vector<ContactPair> pairs_;
  BroadPhaseStats stats_;
  std::vector<int> watch_nodes_;  // nodes of active tets, with their positions at the last build
  std::vector<Vec3> watch_x_;
  // Per pair: normal evaluation and the 8 nodal forces (a's 4 nodes, then b's).
  std::vector<ContactEval> eval_;
  std::vector<Vec3> pair_force_;
  // Gather index: node gather_node_[k] receives pair_force_[slot] for slots
  // gather_slot_[gather_ptr_[k] .. gather_ptr_[k+1]).
  std::vector<int> gather_node_, gather_ptr_, gather_slot_;
};

}  // namespace fdem
