#pragma once
// Tet-tet contact's state on the host: activation flags, the candidate-pair list, the friction
// springs, the last forces of each pair and the gather index that sums them into the node forces
// (no atomics). The device loop builds and evaluates them (solver/device_loop_impl.hpp); this is
// their host copy for checkpoints, outputs and tests.
#include <array>
#include <cstdint>
#include <vector>

#include "contact/bonded.hpp"
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
  /// An empty set sized to read a saved one of another layout into: `tets` tets, and the plan
  /// positions of `plan_nodes` nodes (0 where it was saved on one rank).
  ContactSet(bool enabled, std::size_t tets, std::size_t plan_nodes) : plan_x_(plan_nodes), enabled_(enabled) {
    tet_flags.assign(tets, 0);
  }

  bool enabled() const { return enabled_; }
  real penalty() const { return penalty_; }  // Pa, material.contact_penalty
  ContactLaw law() const { return law_; }    // contact.law
  real friction() const { return mu_; }      // Coulomb coefficient, material.friction_rock
  real buffer() const { return buffer_; }    // m, the broad phase's box inflation
  /// Flags the vicinity of CE6 `c` (every tet sharing a vertex of its face) and its faces on its
  /// two tets as welding no more (contact/bonded.hpp), as its break does. Returns the number of
  /// tets newly activated.
  long activate_ce6(const Model& m, int c);
  /// Rebuild the candidate list at the next evaluation (as after an activation change).
  void request_rebuild() { rebuild_due = true; }

  /// A rank's part of a decomposed model (partition/): the rank holds every tet within `reach`
  /// (m) of its own tets (tet_owned, which must outlive the set) at the node positions set_plan
  /// gives (the reference configuration at the start, the positions of the last growth of the
  /// contact ghosts after one, partition/grow.hpp); check_reach() guards that.
  void set_ownership(const std::vector<std::uint8_t>* tet_owned, real reach);
  /// Several ranks: throws RunError, naming the tet and a reach to try, when a node of an owned
  /// tet has moved half the contact reach from plan_x (a partner this rank lacks could have
  /// touched it).
  void check_reach(const Model& m, const std::vector<Vec3>& x) const;
  /// The farthest a node of an owned tet has moved from plan_x (m), and that tet (-1: none,
  /// as on one rank).
  struct FarthestMove {
    real moved = 0;
    int tet = -1;
  };
  FarthestMove farthest_move(const Model& m, const std::vector<Vec3>& x) const;
  /// The fix for a node that moved `moved` (m) with contact reach `reach`: a larger reach.
  static std::string reach_fix(real reach, real moved);
  /// The node positions the reach counts from (empty on one rank); set_plan(x) after a growth.
  const std::vector<Vec3>& plan_x() const { return plan_x_; }
  void set_plan(const std::vector<Vec3>& x) { plan_x_ = x; }

  /// The activation's search: mesh vertex -> the tets touching it (CSR), and the CE6 on each
  /// face of a tet (face i: opposite corner i; -1: none).
  const std::vector<int>& vertex_tet_ptr() const { return vertex_tet_ptr_; }
  const std::vector<int>& vertex_tets() const { return vertex_tets_; }
  const std::vector<std::array<int, 4>>& face_ce6() const { return face_ce6_; }
  /// Per tet, the CE6 on each face (throws RunError where a CE6 lies on no face of its tet).
  static std::vector<std::array<int, 4>> face_ce6_of(const Model& m);

  long active_count() const { return active_count_; }
  /// Counts the active flags again (after the loop changed them).
  void recount_active();
  long pair_count() const { return long(pairs.size()); }

  /// Everything that changes during a run (flags, pairs, their histories, the last forces and the
  /// broad phase's watch list), so a restarted run continues bit for bit.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
  /// The contact ghosts grew: the state of `old` moves into this set, made for the grown model,
  /// without a copy of its pairs; the appended tets' flags follow the old ones, and the pairs
  /// are rebuilt at the next evaluation.
  void carry_from(ContactSet&& old, const std::vector<std::uint8_t>& appended);

  // The state the time loop builds and evaluates (solver/device_loop_impl.hpp); here its host
  // copy, for checkpoints, outputs and tests.
  std::vector<std::uint8_t> tet_flags;  // per tet: TetFlag bits (a candidate; its opened faces)
  bool rebuild_due = true;              // activation changed since the last build
  std::vector<ContactPair> pairs;       // the candidate list
  std::vector<PairHistory> history;     // per pair, its friction spring and overlap zero
  std::vector<ContactEval> eval;        // per pair, its normal evaluation
  std::vector<Vec3> pair_force;         // per pair, 8 nodal forces (a's 4 nodes, then b's), N
  // Gather index: node gather_node[k] receives pair_force[slot] for slots
  // gather_slot[gather_ptr[k] .. gather_ptr[k+1]).
  std::vector<int> gather_node, gather_ptr, gather_slot;
  std::vector<int> watch_nodes;  // nodes of active tets, with their positions at the last build
  std::vector<Vec3> watch_x;
  BroadPhaseStats last_build;
  long touching = 0;  // pairs in contact at the last evaluation
  ContactTimes times;

 private:
  const std::vector<std::uint8_t>* tet_owned_ = nullptr;
  real reach_ = 0;
  std::vector<Vec3> plan_x_;

  /// f(member of each set) for the state after the flags, in checkpoint order (save, load and
  /// carry_from list it once).
  template <class F, class... Sets>
  static void each_evolving(F&& f, Sets&... s) {
    f(s.active_count_...), f(s.rebuild_due...), f(s.pairs...), f(s.last_build...), f(s.watch_nodes...);
    f(s.watch_x...), f(s.eval...), f(s.pair_force...), f(s.gather_node...), f(s.gather_ptr...);
    f(s.gather_slot...), f(s.history...), f(s.times...), f(s.plan_x_...);
  }

  bool enabled_ = false;
  real penalty_ = 0, mu_ = 0, buffer_ = 0;
  ContactLaw law_ = ContactLaw::volume;
  long active_count_ = 0;
  std::vector<int> vertex_tet_ptr_, vertex_tets_;
  std::vector<std::array<int, 4>> face_ce6_;
};

}  // namespace fdem
