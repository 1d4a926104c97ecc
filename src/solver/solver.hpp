#pragma once
// The solver of a run: the model, the state, the loading and the energy balance. Its time loop
// (forces, contact, integration) is the device loop (solver/device_loop.hpp) on every backend;
// the Solver keeps the scalar bookkeeping: the works, the checks, the clock.
#include <mpi.h>

#include <array>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "model/model.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"
#include "physics/cohesive6.hpp"
#include "scene/scene.hpp"
#include "solver/ce6_states.hpp"
#include "solver/contact_set.hpp"
#include "solver/device_loop.hpp"

namespace fdem {

/// A solver.time_step beyond SolverSettings::kMaxSafety times the stable-step bound: no run is
/// stable there. An input error for fdem run; an unstable variant for a series.
struct TimeStepBeyondBound : InputError {
  using InputError::InputError;
};

class CheckpointOut;
class CheckpointIn;
struct GhostState;

/// One row of the monitor CSV (SI units; stresses and strains compression positive).
struct Monitors {
  long step = 0;
  real time = 0;
  real axial_strain = 0, axial_stress = 0, lateral_strain = 0, volumetric_strain = 0;
  real force_top = 0, force_bottom = 0;  // N, platen reactions along the axis (compression positive)
  long damaged = 0, broken = 0, broken_I = 0, broken_II = 0, broken_mixed = 0;
  real kinetic = 0, strain = 0, cohesive_stored = 0, cohesive_dissipated = 0, friction = 0, viscous = 0;
  real platen_stored = 0, platen_friction = 0, external_work = 0;
  real contact = 0, contact_friction = 0;                 // J, work into tet-tet contact (normal) and its friction
  long active_tets = 0, contact_pairs = 0, contacts = 0;  // activated tets, candidate pairs, touching pairs
  real confining_pressure = 0;                            // Pa, applied on the lateral surface
  // Pa, -(s_xx + s_yy)/2 with the viscous part, averaged over the tets of the middle third of the height
  real lateral_stress = 0;
  real indirect_tensile = 0;  // Pa, 2 P / (pi D t) of a line-loaded disc (Brazilian test), else 0
  real energy_error = 0;      // |external - (everything else)| / max(external, floor)
};

/// Growths of the contact ghosts so far (several ranks, partition/grow.hpp).
struct GhostGrowths {
  long count = 0;      // how often every rank gathered its contact ghosts again
  long tets = 0;       // tets added to the rank models, all ranks together
  long step = -1;      // the step of the last growth
  double seconds = 0;  // wall time of the gatherings and the set-ups of the grown layouts
};

struct StableStep {
  real dt = 0;                                                 // s, including the safety factor
  real dt_tet = 0, dt_ce6 = 0, dt_platen = 0, dt_contact = 0;  // s, without it
  std::string limit;                                           // which part limits, e.g. "CE6 #12 (P_overlap)"
};

class Solver {
 public:
  /// One rank: the whole model. Several: this rank's model and decomposition (partition/), and
  /// the communicator of the ranks running it together (every rank calls step() and measure()
  /// together; their results are the whole model's on every rank).
  Solver(const Scene& scene, Model model, Decomposition dd = {}, MPI_Comm comm = MPI_COMM_SELF);
  Solver(const Solver&) = delete;
  Solver& operator=(const Solver&) = delete;

  const Decomposition& decomposition() const { return dd_; }
  bool distributed() const { return dd_.distributed(); }
  int rank() const { return dd_.rank; }
  MPI_Comm comm() const { return comm_; }
  /// Per local node / tet / CE6: 1 where this rank owns it (all 1 on one rank).
  const std::vector<std::uint8_t>& owned_nodes() const { return own_node_; }
  const std::vector<std::uint8_t>& owned_tets() const { return own_tet_; }
  const std::vector<std::uint8_t>& owned_ce6() const { return own_ce6_; }
  /// Bytes and wall time of the node halo exchanges so far (0 on one rank).
  std::size_t halo_bytes_per_step() const { return halo_ ? halo_->node_bytes_sent() : 0; }
  /// Several ranks with contact: the contact ghosts are gathered again, with the current
  /// positions, at the end of a step in which an owned node (of any rank) has come a quarter
  /// of the contact reach from where they were last gathered; the model() then holds the new
  /// ghosts after the old ones (every local id keeps its meaning). Counts of that so far.
  const GhostGrowths& ghost_growths() const { return growth_; }
  double halo_seconds() const { return halo_seconds_; }

  const Model& model() const { return model_; }
  const Scene& scene() const { return scene_; }
  /// The CE6 law's parameters (from the scene's material).
  const Ce6Params& ce6_params() const { return ce6p_; }
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
  long step_count() const { return step_; }
  real time() const { return time_; }

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

  /// The backend running the time loop (scene solver.backend). The state lives in the loop's
  /// arrays during steps; x, v, f, ce6, platen_anchor and the contact set here are the host
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

  /// Per-tet Cauchy stress and von Mises stress at node positions xs and velocities vs (for
  /// output; the current state or a saved one).
  void tet_stress(const std::vector<Vec3>& xs, const std::vector<Vec3>& vs, std::vector<Sym3>& stress,
                  std::vector<real>& von_mises) const;
  /// Damaged or broken faces (A side) of CE6 states cs, their damage and break mode (for output).
  void crack_faces(const std::vector<Ce6State>& cs, std::vector<std::array<int, 3>>& faces, std::vector<real>& damage,
                   std::vector<int>& mode) const;
  /// Reference-configuration corners and break mode of every broken CE6 (for fracture statistics).
  void broken_faces(std::vector<std::array<Vec3, 3>>& corners, std::vector<int>& mode) const;

  // State (node arrays indexed by node id; CE6 state by CE6 id).
  std::vector<Vec3> x, v, f;
  Ce6States ce6;
  ContactSet contacts;              // tet-tet contact (activation, pairs, friction history)
  std::vector<Vec3> platen_anchor;  // friction anchors per platen node (top/bottom share: one at a time)
  real top_offset = 0;              // m, downward travel of the top platen from its start

 private:
  template <class>
  friend class DeviceLoopImpl;  // the device loop's passes read and write this state
  /// Names the first inverted TET4 of the current state (host copy) and throws RunError.
  [[noreturn]] void report_inverted() const;
  /// The constructor's work on model_ and dd_: the initial state and every derived array (the
  /// halo, the contact set, masses, the stable step, the lateral faces); not the forces and
  /// not the device loop.
  void setup();
  /// Every rank together: the contact ghosts gathered again (partition/grow.hpp) and the layout
  /// set up for the grown rank model, the state carried over.
  void grow_contact_ghosts();
  /// A rank model replaces the one running (grown contact ghosts): the derived arrays set up
  /// afresh, halo and contact set included, the device loop dropped; the time step kept.
  void adopt_layout(RankModel rm);
  /// A new loop for the layout, with the host state uploaded.
  void restart_device();
  /// The evolving state in checkpoint order; load_state with `appended` reads a state saved
  /// before the contact ghosts grew and appends the ghosts' state.
  void save_state(CheckpointOut& out) const;
  void load_state(CheckpointIn& in, const GhostState* appended = nullptr);
  void compute_forces();
  /// The host copy to the device loop where code wrote it since (host_changed()).
  void upload_if_changed();
  /// What the integration gives the bookkeeping of a step (this rank's): non-finite nodes,
  /// 2 x kinetic energy, the works of contact, pressure and gravity over the step, owned nodes a
  /// quarter and half the contact reach from ContactSet::plan_x.
  struct StepSums {
    real bad = 0, ke = 0, w_con = 0, w_pre = 0, w_grav = 0, far = 0, lost = 0;
    static constexpr int kValues = 7;  // the values above, summed over the ranks in this order
    template <class F>
    void for_each(F&& f) {
      for (real* p : {&bad, &ke, &w_con, &w_pre, &w_grav, &far, &lost}) f(*p);
    }
    int n_more = 0;  // a device loop's values summed after them (AdvanceSums::more)
    std::array<real, 10> more{};
  };
  /// A device integration's sums as StepSums (the works with the last force evaluation's powers).
  StepSums step_sums(const AdvanceSums& a) const;
  /// The host's part of a step after its integration: the works of the interval (platen speed
  /// step_speed_), the stability checks (they throw), the clock. True when the contact ghosts
  /// are to be gathered again. A device backend on one rank calls it from inside the next force
  /// evaluation (DeviceLoop::advance).
  bool finish_step(const StepSums& st);
  /// The platen travel and the clock finish_step() leaves (a device loop queues the next force
  /// evaluation's platens and pressure at them before the step is finished).
  real top_offset_after_step() const { return top_offset + step_speed_ * dt_; }
  real time_after_step() const { return time_ + dt_; }
  real step_speed_ = 0;
  StableStep stable_step_bound() const;
  void check_finite(long bad_nodes) const;
  /// Throws RunError when the kinetic energy ke (J) far exceeds the work put in.
  /// InputError (naming the scene) for a time step that is 0 or not finite, a solver.time_step
  /// beyond kMaxSafety times the stable-step bound, or an end that takes more than 1e12 steps:
  /// values beyond a rock's scale or a slip of units.
  void check_step_count() const;
  void check_runaway(real ke) const;

  Scene scene_;
  Model model_;
  Decomposition dd_;
  MPI_Comm comm_ = MPI_COMM_SELF;
  std::unique_ptr<Halo> halo_;
  double halo_seconds_ = 0;
  std::vector<std::uint8_t> own_node_, own_tet_, own_ce6_;
  // Per tet, bit i: its node i takes its first force from this tet (assigned, not added); the
  // nodes no TET4 of the colours reaches, zeroed apart. Without gravity only.
  std::vector<std::uint8_t> tet_assigns_;
  std::vector<int> unreached_nodes_;
  /// Sums values over the ranks in place (nothing on one rank).
  void sum(real* values, int n) const;
  StableStep stable_;
  Ce6Params ce6p_{};
  real lambda_ = 0, mu_ = 0, dt_ = 0, time_ = 0;
  long step_ = 0;
  std::vector<real> platen_k_;
  std::vector<int> fixed_node_, fixed_mask_;
  std::vector<Vec3> fixed_velocity_;
  std::unordered_map<int, int> fixed_slot_;  // node -> its entry in the lists above
  real top_z0_ = 0, bottom_z0_ = 0, ramp_ = 0;
  // Platen reactions (N, on the rock, along +z) from the last force evaluation.
  real force_top_ = 0, force_bottom_ = 0;
  // Energies integrated over time, J.
  real w_external_ = 0, w_cohesive_ = 0, w_friction_ = 0, w_viscous_ = 0, w_platen_friction_ = 0;
  real p_cohesive_ = 0, p_friction_ = 0, p_viscous_ = 0;  // from the last evaluation
  real initial_kinetic_ = 0;                              // J, from velocities set before the first step
  // Tet-tet contact: total work of its forces (normal and friction), the friction work
  // dissipated by sliding, and the friction springs' energy now.
  real w_contact_ = 0, w_contact_slip_ = 0, contact_spring_ = 0;
  real p_contact_ = 0, p_gravity_ = 0;
  long touching_ = 0;
  // Confining pressure: lateral surface faces, the pressure applied at the last evaluation,
  // each face's force per node (-p a / 3, a the current outward area vector) and its power.
  std::vector<std::array<int, 3>> lateral_faces_;
  std::vector<Vec3> lateral_force_;
  real pressure_ = 0, p_pressure_ = 0, confine_ramp_ = 0;
  bool hydrostatic_ = false;  // confinement.path, decided once
  /// Mean of the two platen reactions over the loaded area (compression positive), Pa.
  real axial_stress() const;
  std::vector<std::uint8_t> ce6_broke_;  // set by the CE6 loop on the step a CE6 breaks
  real platen_stored_ = 0;
  real energy_floor_ = 0;
  Backend backend_ = Backend::cpu;
  std::unique_ptr<DeviceLoop> dev_;
  GhostGrowths growth_;
  bool device_current_ = false;       // the device arrays hold the newest state
  mutable bool host_current_ = true;  // the host copy holds it
};

}  // namespace fdem
