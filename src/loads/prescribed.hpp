#pragma once
// Prescribed velocity components of nodes: the scene's kinematic boundary conditions (fixed,
// roller, velocity on surface groups) and the tests' own (Solver::prescribe). After the central
// difference, a node's prescribed component takes its velocity and its position the matching
// displacement (physics/integrate.hpp: prescribe_velocity). The impulse that takes is the
// condition's reaction: R = m (v_prescribed - v_free) / dt on each prescribed component, the
// support's force on the rock with the (scaled) inertia of its nodes. Its work over the step,
// dt R.v, enters the energy ledger as external work.
#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/forall.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/integrate.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

/// Each scene condition's time-function scale over a step (passed to the passes by value).
struct ConditionScales {
  real at[BoundaryCondition::kMax];
};
static_assert(4 * BoundaryCondition::kMax <= Monitors::kMaxConditionColumns, "4 monitor columns per condition");

/// An entry's time-function scales, one byte per component d (bits 8d to 8d + 7): its scene
/// condition + 1, or 0 (the velocity as it is).
FDEM_HD int scale_in(int code, int d) {
  return (code >> (8 * d) & 255) - 1;
}
inline int with_scale(int code, int d, int condition) {
  return (code & ~(255 << (8 * d))) | ((condition + 1) << (8 * d));
}

namespace device_pass {
/// The prescription of entry i after a step of dt: the target velocity (each component's
/// condition's scale times its velocity), applied to x and v, and the reaction that took into
/// reaction[i].
FDEM_HD void prescribe_entry(int i, real mass, Vec3& x, Vec3& v, const int* mask, const Vec3* velocity,
                             const int* scale_of, const ConditionScales& scales, Vec3* reaction, real dt) {
  Vec3 target = velocity[i];
  for (int d = 0; d < 3; ++d)
    if (const int s = scale_in(scale_of[i], d); s >= 0) target[d] = scales.at[s] * target[d];
  const Vec3 free = v;
  prescribe_velocity(x, v, mask[i], target, dt);
  reaction[i] = (mass / dt) * (v - free);
}

/// A node's step by its force where the fused pass integrates: the central difference, then
/// its prescription (the arithmetic of the integration pass and PrescribedVelocities::apply).
struct NodeStep {
  const real* mass;     // 1/m divided here: correctly rounded, the same bits on every backend
  const int* fixed_of;  // per node: its place in the prescribed lists, or -1 (null: none)
  const int* fixed_mask;
  const Vec3* fixed_v;
  const int* scale_of;
  Vec3* reaction;
  ConditionScales scales;
  real dt;
  FDEM_HD void move_with(real m, Vec3& x, Vec3& v, const Vec3& f) const { central_difference(x, v, f, 1 / m, dt); }
  FDEM_HD void prescribe(int n, real m, Vec3& x, Vec3& v) const {
    const int i = fixed_of ? fixed_of[n] : -1;
    if (i >= 0) prescribe_entry(i, m, x, v, fixed_mask, fixed_v, scale_of, scales, reaction, dt);
  }
};
}  // namespace device_pass

class PrescribedVelocities {
 public:
  // One entry per node. Host lists, uploaded when they change (upload_state).
  std::vector<int> node, mask;                // mask bit 0 = x, 1 = y, 2 = z
  std::vector<Vec3> velocity;                 // m/s, each component times its condition's scale (scale_in)
  std::vector<int> scale_of;                  // per entry, the conditions whose scales apply (scale_in, with_scale)
  std::vector<std::array<int, 3>> condition;  // per component, the scene condition it reports to (-1: none)
  std::unordered_map<int, int> slot;          // node -> its entry
  // State: each entry's last reaction (N) and the work its components did so far (J).
  std::vector<Vec3> reaction, work;

  /// The entries of the scene's kinematic conditions on model m's held nodes (node_conditions).
  void set_up(const Scene& scene, const Model& m);
  bool on() const { return !node.empty(); }
  /// Entries the caller set (Solver::prescribe): their work is counted, but they may be set at
  /// any time, so the runaway and balance checks are off.
  bool set_by_caller() const { return by_caller_; }
  /// The caller's entry for node n at time t (s): a node prescribed again takes the new
  /// components, as if the calls were applied in turn. Those leave the scene's scales and
  /// columns; the scene's other components on the node are held at their values at t.
  void set(int n, int components, Vec3 v, real t);
  /// Each condition's scale at time t (s).
  ConditionScales scales_at(real t) const;
  /// Its monitor columns: each scene condition's reaction and work summed over the owned nodes
  /// (`owned`: per node, empty: all), 4 per condition, before the sum over the ranks.
  std::vector<real> condition_sums(const std::vector<std::uint8_t>& owned) const;
  void monitor(const Model&, Monitors&) const {}  // (condition_sums: summed over the ranks first)
  /// Its part of a checkpoint: the reactions and works (the lists come from the scene and the
  /// caller; the Solver counts the nodes).
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);

  // The device loop's calls.
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(node_, mask_, scale_of_, place_of_, velocity_, reaction_, work_);
  }
  /// `held`: each node's place in the lists too, for the fused pass that integrates.
  void place(const Model& m, bool held) { nodes_ = m.X.size(), per_node_ = held; }
  /// The lists, the reactions and works, and where per node, each node's place.
  void upload_state();
  void download_state();
  bool per_node() const { return place_of_.size() > 0; }

  /// The prescription on every listed node after a step of dt (s) from time t, with masses
  /// `mass`: velocities, positions and reactions.
  template <class Exec>
  void apply(Vec3* x, Vec3* v, const real* mass, real t, real dt) {
    const int* fn = node_.data();
    const int* fm = mask_.data();
    const Vec3* fv = velocity_.data();
    const int* so = scale_of_.data();
    Vec3* r = reaction_.data();
    const ConditionScales sc = scales_at(t + dt / 2);
    Exec::forall(int(node_.size()), [=] FDEM_LAMBDA(int i) {
      const int n = fn[i];
      device_pass::prescribe_entry(i, mass[n], x[n], v[n], fm, fv, so, sc, r, dt);
    });
  }
  /// After the step's prescription (v: the new velocities): each entry's work over the step of
  /// dt, dt R.v, and their power sum R.v over the owned nodes into *power.
  template <class Exec>
  void reaction_power(const Vec3* v, const std::uint8_t* own_n, real dt, real* power) {
    if (node_.size() == 0) return;
    const int* fn = node_.data();
    const Vec3* r = reaction_.data();
    Vec3* w = work_.data();
    Exec::template sum_to<1>(
        int(node_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const Vec3 vn = v[fn[i]];
          const Vec3 p{r[i].x * vn.x, r[i].y * vn.y, r[i].z * vn.z};
          w[i] += dt * p;
          if (own_n[fn[i]]) acc[0] += p.x + p.y + p.z;
        },
        power);
  }

  /// After the step's prescription (v: the new velocities): what it changed of sum m v.v over
  /// the owned nodes, added to *kinetic2, so that the step's kinetic energy counts each held
  /// component at its prescribed velocity, not at the free one its reaction stopped.
  template <class Exec>
  void kinetic_change(const Vec3* v, const real* mass, const std::uint8_t* own_n, real dt, real* kinetic2) {
    if (node_.size() == 0) return;
    const int* fn = node_.data();
    const Vec3* r = reaction_.data();
    Exec::template sum_to<1>(
        int(node_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const int n = fn[i];
          if (!own_n[n]) return;
          const Vec3 vn = v[n], free = vn - (dt / mass[n]) * r[i];
          acc[0] += mass[n] * (dot(vn, vn) - dot(free, free));
        },
        kinetic2);
  }

  /// The node step of the fused pass that integrates a step of dt (s) from time t.
  device_pass::NodeStep node_step(const real* mass, real t, real dt) {
    return device_pass::NodeStep{mass,
                                 per_node() ? place_of_.data() : nullptr,
                                 mask_.data(),
                                 velocity_.data(),
                                 scale_of_.data(),
                                 reaction_.data(),
                                 scales_at(t + dt / 2),
                                 dt};
  }

 private:
  Backend b_ = Backend::cpu;
  std::size_t nodes_ = 0;
  bool per_node_ = false, by_caller_ = false;
  std::vector<TimeFunction> time_;  // per scene condition
  DeviceArray<int> node_, mask_, scale_of_, place_of_;
  DeviceArray<Vec3> velocity_, reaction_, work_;

  int entry_of(int n);
};

}  // namespace fdem
