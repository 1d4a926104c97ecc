#pragma once
// The time loop of every backend: the Solver's per-step array passes (forces, activation, the
// contact candidate list, narrow phase and friction, platens, pressure, integration, the halo's
// packing) written once over raw arrays with Exec::forall / Exec::sum (core/forall.hpp). The cpu
// backend runs them on the host in place (its arrays borrow the Solver's), the debug backend on
// the host with separate buffers, the CUDA backend as kernels. The Solver keeps the scalar
// bookkeeping (energies, checks, loading) and its host vectors as the host copy, brought up to
// date at monitor rows and output.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/device_memory.hpp"
#include "core/vec.hpp"
#include "loads/loads.hpp"
#include "model/laws.hpp"
#include "model/model.hpp"
#include "scene/scene.hpp"
#include "solver/ce6_states.hpp"
#include "solver/contact_set.hpp"
#include "solver/energy_ledger.hpp"
#include "solver/rank_layout.hpp"

namespace fdem {

/// Wall time per pass, s (with `timing` on, each pass waits for the device before the clock).
/// (narrow: the contact pairs' pass, friction and their power included.)
struct DeviceTimes {
  double tet4 = 0, ce6 = 0, activation = 0, broad = 0, narrow = 0, contact_sum = 0, platens = 0, pressure = 0,
         integrate = 0, energy = 0, copies = 0, monitor = 0;
  long steps = 0, rebuilds = 0, pair_growth = 0;
  double total() const {
    return tet4 + ce6 + activation + broad + narrow + contact_sum + platens + pressure + integrate + energy + copies;
  }
};

/// What integration returns to the Solver's bookkeeping (this rank's sums).
struct AdvanceSums {
  real bad = 0;             // nodes whose velocity is not finite
  real kinetic2 = 0;        // sum of m v.v (twice the kinetic energy), J
  real contact_power = 0;   // -sum f.v of the last contact forces with the new velocities, W
  real pressure_power = 0;  // the same for the confining pressure, W
  real gravity_power = 0;   // sum m g.v with the new velocities, W
  real reaction_power = 0;  // sum R.v of the prescribed velocities' reactions over the step, W
  real far = 0;             // owned nodes a quarter of the contact reach from ContactSet::plan_x()
  real lost = 0;            // owned nodes half the contact reach from there
  // Several ranks: what this rank adds to the step's one reduction besides the above
  // (Solver::finish_step hands them back summed: DeviceLoop::take_reduced). n_more is 0 on one
  // rank.
  int n_more = 0;
  std::array<real, 11> more{};
};

/// One rank's sums for a monitor row; Solver::measure sums them over the ranks.
struct MonitorSums {
  real lateral_ratio = 0;          // owned lateral nodes' radial displacement over their radius, summed
  real lateral_nodes = 0;          // owned lateral nodes
  real kinetic = 0;                // J
  real strain = 0;                 // J, TET4 strain energy
  real lateral_stress_volume = 0;  // N m, -(s_xx + s_yy)/2 x volume over the tets of the middle third
  real middle_volume = 0;          // m^3, of those tets
  real cohesive_stored = 0;        // J, CE6s not broken
  real friction_stored = 0;        // J, friction springs of broken CE6s
  real damaged = 0, broken = 0, broken_I = 0, broken_II = 0, broken_mixed = 0;  // rock CE6 counts
  real joint_damaged = 0, joint_broken = 0;                                     // joint CE6 counts
  real platen_stored = 0;                                                       // J
  real active_tets = 0, contact_pairs = 0;
  /// f(field) for every field, in the order above (the reduction over the ranks packs them so).
  template <class F>
  void for_each(F&& f) {
    for (real* p : {&lateral_ratio, &lateral_nodes, &kinetic, &strain, &lateral_stress_volume, &middle_volume,
                    &cohesive_stored, &friction_stored, &damaged, &broken, &broken_I, &broken_II, &broken_mixed,
                    &joint_damaged, &joint_broken, &platen_stored, &active_tets, &contact_pairs})
      f(*p);
  }
};

/// The step's one reduction over the ranks: this rank's integration sums and works over the
/// step, then a device loop's values (AdvanceSums::more).
struct StepSums {
  real bad = 0, ke = 0, w_con = 0, w_pre = 0, w_grav = 0, w_kin = 0, far = 0, lost = 0;
  static constexpr int kValues = 8;  // the values above, summed over the ranks in this order
  template <class F>
  void for_each(F&& f) {
    for (real* p : {&bad, &ke, &w_con, &w_pre, &w_grav, &w_kin, &far, &lost}) f(*p);
  }
  int n_more = 0;  // a device loop's values summed after them (AdvanceSums::more)
  std::array<real, 11> more{};
};

/// The run's bookkeeping that a step's passes call back into (the Solver).
class StepBookkeeping {
 public:
  /// The part of a step after its integration: the works of the interval, the stability checks
  /// (they throw RunError), the clock. True when the contact ghosts are to be gathered again.
  virtual bool finish_step(const AdvanceSums& a) = 0;
  /// Names the first inverted TET4 of the host copy of the state and throws RunError.
  [[noreturn]] virtual void report_inverted() const = 0;

 protected:
  ~StepBookkeeping() = default;
};

/// What the time loop reads and writes of a run, by name. The loop keeps these references for
/// its life: the Solver, which owns the loop, owns what they refer to.
struct LoopParts {
  const Scene& scene;
  const Model& model;
  const ElementLaws& laws;
  RankLayout& layout;  // (the halo's exchanges count their time there)
  const real& dt;      // s, the time step
  const real& time;    // s, the clock at the state
  // The evolving state's host copy (node arrays by node id, CE6 arrays by CE6 id).
  std::vector<Vec3>& x;
  std::vector<Vec3>& v;
  std::vector<Vec3>& f;
  Ce6States& ce6;
  std::vector<std::uint8_t>& ce6_broke;  // set by the CE6 pass on the step a CE6 breaks
  ContactSet& contacts;
  Loads& loads;  // with their state: platen anchors and travel, pressure forces
  EnergyLedger& energy;
  StepBookkeeping& book;
};

class DeviceLoop {
 public:
  virtual ~DeviceLoop() = default;
  virtual Backend backend() const = 0;
  /// Several ranks: true when the halo hands device buffers to MPI (GPU-aware MPI, or
  /// FDEM_GPU_AWARE_MPI=1), false when it stages them through host memory.
  virtual bool halo_passes_device_buffers() const = 0;
  /// True when the TET4 and CE6 forces are one pass over the tets (plan_fused_pass), false when
  /// they are colour-by-colour passes.
  virtual bool fused() const = 0;
  /// True when the fused pass also integrates (one rank; FDEM_DEVICE_SCHEDULE=auto): a force
  /// evaluation computes contact, platens and pressure and leaves its elements to the next
  /// step's pass, which computes them, adds the forces held for each node and moves the tet's
  /// nodes by the step. No force array and no integration pass; a read of the state in between
  /// completes the evaluation first (the same bits).
  virtual bool integrates() const = 0;
  /// The resident blocks of 256 threads per multiprocessor the CUDA kernels of the fused pass are
  /// compiled for (FDEM_CUDA_BLOCKS_PER_SM, device_blocks_per_sm): 1, or 2 (half the registers
  /// per thread, the rest spilled to local memory). The same results; the debug backend runs the
  /// same host code either way.
  virtual int blocks_per_sm() const = 0;
  /// The whole state and the model's constants, host to device.
  virtual void upload() = 0;
  /// The evolving state, device to host (x, v, f, CE6 state, platen anchors, pressure forces,
  /// contact flags, springs and pair forces).
  virtual void download() = 0;
  /// Debug backend: fill the host copies of the evolving state with NaN (flags with 0xAA), and
  /// the last force evaluation's scalars while they wait on the device, so a read without
  /// download() or settle() is caught. Nothing elsewhere.
  virtual void poison_host() = 0;
  /// Kinetic energy x 2 of the state on the device (the first step's initial energy).
  virtual real kinetic2() = 0;
  /// The forces at the state, with no step before them: the first evaluation, and the one after
  /// the contact ghosts were gathered again.
  virtual void evaluate() = 0;
  /// One step of dt: the central difference, the prescribed velocities and the powers with the
  /// new velocities, then the forces at the new state. The step's bookkeeping
  /// (StepBookkeeping::finish_step) runs at the step's first copy to the host. One rank: the
  /// copy that brings the broad phase's decision, so a step copies to the host once. Several
  /// ranks: the integration's sums with the last evaluation's scalars, before the forces (the
  /// Solver sums them over the ranks in one reduction, take_reduced). Returns true when
  /// finish_step asked for the contact ghosts to be gathered again: the forces then wait for the
  /// Solver, which gathers them and calls evaluate() on the grown layout's loop.
  virtual bool step(real dt) = 0;
  /// Several ranks: AdvanceSums::more summed over the ranks, in Solver::finish_step's one
  /// reduction of the step: the last force evaluation's whole-model sums (platen reactions,
  /// powers, slip, touching pairs) to the Solver, and whether any rank activated tets in it or
  /// took flags from its host since the last merge (the next evaluation merges the flags then).
  virtual void take_reduced(const real* more) = 0;
  /// The last force evaluation's scalars to the Solver now (one copy), if they are still on the
  /// device: Solver::measure and Solver::sync_host call it, so that between steps the Solver's
  /// platen reactions, powers and slip energies are those of the forces on the device. Several
  /// ranks: they are summed over the ranks here (while they wait, which is from a force
  /// evaluation to the next step's reduction), so every rank calls it at once, as they call
  /// measure(), write output and checkpoints.
  virtual void settle() = 0;
  /// Forget what settle() would bring: the host copy was written (a checkpoint loaded, a
  /// prescription) and is the state now; the next step uploads it.
  virtual void discard_pending() = 0;
  /// A monitor row's sums from the device state, without copying it to the host.
  virtual MonitorSums measure_sums() = 0;
  /// Wait for the device before each pass's clock (benchmarks).
  virtual void set_timing(bool on) = 0;
  virtual const DeviceTimes& times() const = 0;
  /// Bytes the passes of one step read and write (the step's floor at a memory bandwidth), by
  /// this model's array sizes and the contact pairs now.
  virtual double bytes_per_step() const = 0;
};

/// The fused element pass's plan: for each tet of m.tet_colours.order, four entries
/// (k << 2 | side << 1 | writer) for the CE6s on its faces, k being the CE6's place in
/// m.ce6_colours.order, in ascending k (colour order), -1 after the last; side: the tet's side
/// of the CE6; writer: the first side whose tet is computed. sides[k]: how many of CE6 k's tets
/// are computed.
struct FusedPlan {
  std::vector<int> list;
  std::vector<std::uint8_t> sides;
  bool integrate = false;  // the pass integrates too (DeviceLoop::integrates)
  int blocks_per_sm = 1;   // DeviceLoop::blocks_per_sm
};
/// Fills `plan` and returns true when the model allows the fused pass: every node in at most
/// one computed tet (split nodes: a CE6 on every internal face of the rank's elements), each
/// side's nodes of a computed CE6 its tet's own, and every computed CE6 with a computed tet.
bool plan_fused_pass(const Model& m, FusedPlan& plan);
/// The device loop's element passes on backend b by FDEM_DEVICE_SCHEDULE: `auto` (unset: the
/// default of debug and cuda): fused where plan_fused_pass allows, and integrating in that pass
/// where the run allows (DeviceLoop::integrates); `fused`: fused, the integration a pass of its
/// own; `colour` (unset: the cpu backend's default): the colour-by-colour passes. Another value
/// throws InputError naming it.
enum class DeviceSchedule { automatic, fused, colour };
DeviceSchedule device_schedule(Backend b);
/// FDEM_CUDA_BLOCKS_PER_SM: 1 (or unset, the default) or 2, the resident blocks per
/// multiprocessor the fused pass's kernels are compiled for (DeviceLoop::blocks_per_sm), for
/// measuring what occupancy buys against what spilling costs. Another value throws InputError
/// naming it.
int device_blocks_per_sm();

// Host work of the device loop, the same for every Exec (solver/device_loop.cpp).
/// Debug backend: the host copies of the evolving state filled with NaN (flags with 0xAA), and
/// the last force evaluation's scalars where they wait on the device (`scalars_waiting`; with
/// gravity's power where the fused pass `integrates`).
void poison_host_state(const LoopParts& s, bool scalars_waiting, bool integrates);
/// Per tet, 1 where its reference centroid lies in the middle third of the height (the monitor
/// rows' lateral stress).
std::vector<std::uint8_t> middle_third_tets(const Model& m);
/// Per tet, 2 where a node lies on a platen or on the pressure's `lateral_nodes` (each where
/// that load is on), else 0: the tets whose held forces the fused pass that integrates reads.
std::vector<std::uint8_t> tets_on_loads(const LoopParts& s, const std::vector<int>& lateral_nodes);

/// The device loop of backend b on a run's parts. Throws InputError when the CUDA backend was not
/// built or no GPU is visible.
std::unique_ptr<DeviceLoop> make_device_loop(Backend b, const LoopParts& parts);

}  // namespace fdem
