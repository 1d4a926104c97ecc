#pragma once
// The solver of a run. It holds the run's parts: the static model, this rank's layout, the
// element laws, the evolving state, the loads, the energy ledger and the stable step. Its time
// loop (forces, contact, integration) is the device loop (solver/device_loop.hpp) on every
// backend, which works on those parts by name (LoopParts); the Solver keeps the step's scalar
// bookkeeping: the works, the checks, the clock.
#include <mpi.h>

#include <array>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "loads/loads.hpp"
#include "model/laws.hpp"
#include "model/model.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"
#include "physics/cohesive6.hpp"
#include "scene/scene.hpp"
#include "solver/ce6_states.hpp"
#include "solver/contact_set.hpp"
#include "solver/device_loop.hpp"
#include "solver/energy_ledger.hpp"
#include "solver/monitors.hpp"
#include "solver/rank_layout.hpp"
#include "solver/saved_layout.hpp"
#include "solver/solver_state.hpp"
#include "solver/stable_step.hpp"

namespace fdem {

/// A solver.time_step beyond SolverSettings::kMaxSafety times the stable-step bound: no run is
/// stable there. An input error for fdem run; an unstable variant for a series.
struct TimeStepBeyondBound : InputError {
  using InputError::InputError;
};

class CheckpointOut;
class CheckpointIn;
struct SavedRankState;

/// Growths of the contact ghosts so far (several ranks, partition/grow.hpp).
struct GhostGrowths {
  long count = 0;      // how often every rank gathered its contact ghosts again
  long unchanged = 0;  // of those, the gatherings that added no tet to any rank (layout kept)
  long tets = 0;       // tets added to the rank models, all ranks together
  long step = -1;      // the step of the last growth
  double seconds = 0;  // wall time of the gatherings and the set-ups of the grown layouts
};

/// Every scene value the equations of motion use, and the time step dt (s), hashed after seed:
/// the part of a checkpoint's fingerprint that does not depend on the model.
std::uint64_t scene_physics_hash(const Scene& s, real dt, std::uint64_t seed);

class Solver : private StepBookkeeping {
 public:
  /// One rank: the whole model. Several: this rank's model and decomposition (partition/), and
  /// the communicator of the ranks running it together (every rank calls step() and measure()
  /// together; their results are the whole model's on every rank).
  Solver(const Scene& scene, Model model, Decomposition dd = {}, MPI_Comm comm = MPI_COMM_SELF);
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  const Decomposition& decomposition() const { return layout_.dd; }
  bool distributed() const { return layout_.distributed(); }
  int rank() const { return layout_.dd.rank; }
  MPI_Comm comm() const { return layout_.comm; }
  /// Per local node / tet / CE6: 1 where this rank owns it (all 1 on one rank).
  const std::vector<std::uint8_t>& owned_nodes() const { return layout_.own_node; }
  const std::vector<std::uint8_t>& owned_tets() const { return layout_.own_tet; }
  const std::vector<std::uint8_t>& owned_ce6() const { return layout_.own_ce6; }
  /// Bytes and wall time of the node halo exchanges so far (0 on one rank).
  std::size_t halo_bytes_per_step() const { return layout_.halo ? layout_.halo->node_bytes_sent() : 0; }
  /// Several ranks with contact: the contact ghosts are gathered again, with the current
  /// positions, at the end of a step in which an owned node (of any rank) has come a quarter
  /// of the contact reach from where they were last gathered; the model() then holds the new
  /// ghosts after the old ones (every local id keeps its meaning). Counts of that so far.
  const GhostGrowths& ghost_growths() const { return growth_; }
  /// Whether an excavation stage done has removed tet t (solver/excavation.cpp), and how many.
  bool removed_tet(std::size_t t) const;
  int excavation_stages_done() const { return excavated_; }
  double halo_seconds() const { return layout_.halo_seconds; }

  const Model& model() const { return model_; }
  const Scene& scene() const { return scene_; }
  /// The element laws: per material its TET4 law, and the CE6 laws (model/laws.hpp).
  const ElementLaws& laws() const { return laws_; }
  /// The loads with their state (platen anchors and travel, the confining pressure's forces):
  /// the host copy, as `state` below.
  const Loads& loads() const { return loads_; }
  /// m, the top platen's downward travel from its start.
  real platen_travel() const { return loads_.platens.top_offset; }
  const EnergyLedger& energy() const { return energy_; }
  const StableStep& stable_step() const { return stable_; }
  /// s: the stable-step bound itself, before solver.time_step_safety is applied.
  real stable_bound() const { return stable_.dt / scene_.solver.time_step_safety; }
  /// "Cause: ... Fix: ..." for an unstable run: the time step against its bound, mass scaling,
  /// the penalties, in that order of likelihood.
  std::string instability_advice() const;
  real dt() const { return dt_; }
  /// The steps the scene's end takes at most from step 0 at this time step (end.steps, end.time,
  /// or end.axial_strain at the platen speed, its ramp aside), and the key; infinite where only
  /// the post-peak fraction ends the run.
  struct EndSteps {
    real steps;
    std::string key;
  };
  EndSteps end_steps() const;
  long step_count() const { return state.step; }
  real time() const { return state.time; }

  /// Advance one step. Throws RunError (naming the element, step and a fix) when the
  /// run becomes unstable: an inverted tet or a non-finite velocity.
  void step();
  /// Reductions over the whole model; also checks the energy for runaway growth.
  Monitors measure();

  /// The whole evolving state (nodes, CE6 damage and slip, contact, platen anchors and travel,
  /// pressure, energy integrals, step and time) for a checkpoint. load() continues a run of the
  /// same scene and model bit for bit (same thread count); it throws InputError naming what
  /// differs when the checkpoint belongs to another model, time step or loading.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
  /// A checkpoint of another rank count (solver/saved_ranks.cpp): every rank reads each saved
  /// rank's file in rank order. read_saved_rank() takes the solver's part of one, keeping what
  /// this rank holds from the saved rank that owned it, and returns where that rank's arrays go
  /// here (for the run record's part after it). Then finish_saved_ranks(), on every rank
  /// together: it checks that every node, tet and CE6 was found, gathers the contact ghosts at
  /// the positions reached and places the saved contact pairs. InputError (naming the file)
  /// where the files belong to another model or scene, or do not cover it.
  EntityMap read_saved_rank(CheckpointIn& in);
  void finish_saved_ranks();
  /// Reads the solver's part of a saved rank's file as read_saved_rank() does, with its checks,
  /// and changes nothing (a restart looks at a set before it takes any of it).
  void check_saved_rank(CheckpointIn& in) const;

  /// The backend running the time loop (scene solver.backend). The state lives in the loop's
  /// arrays during steps; `state`, the contact set and the loads' state are the host
  /// copy, brought up to date by sync_host() (measure(), save() and the output functions call
  /// it). On the cpu backend they are mostly the loop's arrays themselves, but not all the time
  /// (the fused schedules swap copies; several ranks keep the CE6 state in slot order), so the
  /// rule is the same on every backend. Code that writes the host copy between steps calls
  /// host_changed() so the next step uploads it. Several ranks: sync_host() (and so prescribe(),
  /// measure(), save() and output) sums the last force evaluation's scalars over the ranks while
  /// they wait on the device, so every rank calls it at once.
  Backend backend() const { return backend_; }
  const DeviceLoop* device_loop() const { return dev_.get(); }
  DeviceLoop* device_loop() { return dev_.get(); }
  void sync_host() const;
  void host_changed() {
    device_current_ = false;
    if (dev_) dev_->discard_pending();  // the host's scalars, not the device's last ones
  }

  /// Prescribe velocity components (mask bit 0 = x, 1 = y, 2 = z) of a node. Prescribing a node
  /// again sets the new components (the others stay prescribed).
  void prescribe(int node, int mask, Vec3 velocity);
  /// The kinematic conditions' monitor columns (their reactions and works, whole model) into r.
  void condition_columns(Monitors& r);
  /// The history points' monitor columns (solver/history.cpp) into r: each point's values from
  /// the rank that holds its tet.
  void history_columns(Monitors& r);

  /// Per-tet Cauchy stress and von Mises stress at node positions xs and velocities vs (for
  /// output; the current state or a saved one).
  void tet_stress(const std::vector<Vec3>& xs, const std::vector<Vec3>& vs, std::vector<Sym3>& stress,
                  std::vector<real>& von_mises) const;
  /// Damaged or broken faces (A side) of CE6 damage states cs, their damage and break mode (for output).
  void crack_faces(const std::vector<Ce6Damage>& cs, std::vector<std::array<int, 3>>& faces, std::vector<real>& damage,
                   std::vector<int>& mode) const;
  /// Reference-configuration corners and break mode of every broken CE6 of the rock, not of a joint
  /// (for fracture statistics).
  void broken_faces(std::vector<std::array<Vec3, 3>>& corners, std::vector<int>& mode) const;

  /// The nodes' and CE6s' evolving state with the clock (the host copy: see sync_host()).
  SolverState state;
  ContactSet contacts;  // tet-tet contact (activation, pairs, friction history)

 private:
  /// The parts the device loop works on, by name.
  LoopParts loop_parts();
  // StepBookkeeping: the device loop's calls back.
  [[noreturn]] void report_inverted() const override;
  bool finish_step(const AdvanceSums& a) override;
  /// The constructor's work on model_ and the decomposition: the initial state and every
  /// derived part (set_up_layout's, then the stable step and the energies' reference values);
  /// not the forces and not the device loop.
  void setup(Decomposition dd);
  /// The initial state (unless `keep_state`: a growth's, which matches the grown model) and the
  /// parts derived from the model's layout: the layout with its halo, the contact set (without
  /// the positions the reach counts from where `keep_state`), the loads.
  void set_up_layout(Decomposition dd, bool keep_state);
  /// Every rank together: the contact ghosts gathered again (partition/grow.hpp). Where tets
  /// were added, the model grew in place and the layout is set up for it; the state is kept,
  /// the ghosts' state appended.
  void grow_contact_ghosts();
  /// A rank model replaces the one running (a checkpoint of grown contact ghosts): relayout().
  void adopt_layout(RankModel rm);
  /// The layout set up afresh for model_ (grown) and dd, halo and contact set included, the
  /// device loop dropped; the state started afresh at rest, unless `keep_state`. The time step, the stable bound
  /// and the energies' reference values stay: they are the partition's, and a rank never
  /// computes its contact ghosts.
  void relayout(Decomposition dd, bool keep_state);
  /// A new loop for the layout, with the host state uploaded.
  void restart_device();
  /// The evolving state in checkpoint order: the nodes' and CE6s', the loads', the energies'
  /// and the contact set's.
  void save_state(CheckpointOut& out) const;
  void load_state(CheckpointIn& in);
  /// Where this rank's arrays sit in the whole model (the head of its checkpoint).
  SavedLayout saved_layout() const;
  /// A fingerprint of the whole model (reference positions, connectivity, each element's
  /// material, law, factors and stage, in global numbering) and the scene's physics: the same
  /// on every rank count. Collective: the constructor computes it once (model_fp_).
  std::uint64_t whole_model_fingerprint() const;
  /// The saved ranks' scalars and per-entity state into this rank's (read_saved_rank).
  void take_saved_state(const SavedLayout& l, const EntityMap& map, SavedRankState& saved);
  /// The saved contact pairs this rank holds both tets of, in local ids (finish_saved_ranks).
  void place_saved_pairs();
  /// The loaded faces' forces, powers and works of a saved rank (read_saved_rank), then each
  /// face's summed power and work given to one rank (finish_saved_ranks).
  void take_saved_faces(const SavedLayout& l, const SurfaceLoads& saved);
  void finish_saved_faces();
  void compute_forces();
  /// The host copy to the device loop where code wrote it since (host_changed()).
  void upload_if_changed();
  /// A device integration's sums as StepSums (the works with the last force evaluation's powers).
  StepSums step_sums(const AdvanceSums& a) const;
  void check_finite(long bad_nodes) const;
  /// InputError (naming the scene) for a time step that is 0 or not finite, a solver.time_step
  /// beyond kMaxSafety times the stable-step bound, or an end that takes more than 1e12 steps:
  /// values beyond a rock's scale or a slip of units.
  void check_step_count() const;
  /// Every tet's material and CE6's law has an entry among the laws (a rank file of another scene
  /// must not index past them).
  void check_law_indices() const;
  /// Finds each history point's tet among this rank's own (of those that hold it, the lowest
  /// in the input's numbering, on every rank count); InputError for a point in no tet.
  void locate_history_points();
  /// Group entries' sums over this rank's own nodes and tets (solver/history.cpp).
  std::vector<real> history_group_sums() const;
  /// A history point's tet on this rank (-1: another rank's) and its barycentric weights there.
  struct HistoryProbe {
    int tet = -1;
    std::array<real, 4> w{};
  };
  std::vector<HistoryProbe> probes_;
  /// A point's columns: u and v interpolated in its tet, and the tet's stress.
  std::array<real, HistoryPoint::kColumns> history_point_values(const HistoryProbe& p) const;
  /// A frictional joint's CE6s start broken (kCe6NeverBonded), their vicinity a contact candidate
  /// and their faces released, as a break leaves them. Idempotent: a growth of the contact
  /// ghosts runs it again on the state it keeps.
  void break_frictional_joints();
  /// Throws RunError when the kinetic energy ke (J) far exceeds the work put in.
  void check_runaway(real ke) const;
  /// J, the elastic energy of the in-situ stress in the rock, all ranks: sum V s:C^-1:s / 2.
  real in_situ_energy() const;
  /// J, the intact CE6s' stored energy in the in-situ state at rest, all ranks.
  real in_situ_cohesive_energy() const;
  // Excavation (solver/excavation.cpp).
  /// The stages whose start has come, in order: the forces their rock put on the rest, then their
  /// removal; the relaxation runs from now.
  void excavate_due();
  /// The forces that the tets of `stage` (1 + its index) and their CE6s put on the nodes that
  /// stay, into the gravity load's relaxing forces; the weight taken off those nodes, and off
  /// the nodes only removed tets hold, into its held forces.
  void excavation_forces(int stage);
  /// The model and state for the stages done: their tets without stiffness or in-situ stress,
  /// out of contact, their CE6s removed, the nodes only they hold marked. Idempotent.
  void remove_excavated();
  /// Into the energy ledger: the strain and kinetic energy that `stage`'s rock takes out, and
  /// its CE6s' stored energy off the cohesive column's start.
  void book_removed_energy(int stage);
  /// 0, or 1 + the excavation stage that removes tet t.
  int stage_of(std::size_t t) const;
  /// Per node, 1 where a tet that the first `stages` excavation stages leave holds it.
  std::vector<char> kept_nodes(int stages) const;
  /// "step n (t = ... s)": where a check stopped the run.
  std::string where() const;

  Scene scene_;
  Model model_;
  RankLayout layout_;
  ElementLaws laws_;
  Loads loads_;
  EnergyLedger energy_;
  StableStep stable_;
  real dt_ = 0;
  Backend backend_ = Backend::cpu;
  std::unique_ptr<DeviceLoop> dev_;
  GhostGrowths growth_;
  bool grown_ = false;                    // a gathering added tets: the rank model is no longer the partition's
  std::uint64_t model_fp_ = 0;            // whole_model_fingerprint() at the start, before any excavation
  struct SavedRanks;                      // a restart on another rank count in progress
  std::shared_ptr<SavedRanks> saved_;     // (solver/saved_ranks.cpp; shared: a deleter for an incomplete type)
  int excavated_ = 0;                     // excavation stages done
  std::vector<char> held_by_excavation_;  // per node: only removed tets hold it
  bool device_current_ = false;           // the device arrays hold the newest state
  mutable bool host_current_ = true;      // the host copy holds it
};

}  // namespace fdem
