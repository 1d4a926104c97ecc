#pragma once
// Gravity (scene `gravity`, m/s^2): the weight of every node's mass (physics/gravity.hpp). It
// starts the sum of each node's force. Its power counts in the external work.
// An excavation (solver/excavation.cpp) adds its forces here: per node, the force the removed
// rock put on it, relaxing to zero, and a held force that takes the removed rock's weight off.
// They too start each node's force, and their power counts with gravity's.
#include <cstdint>
#include <vector>

#include "core/device_memory.hpp"
#include "core/forall.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/gravity.hpp"
#include "physics/integrate.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/sum_slots.hpp"

namespace fdem {

/// An excavation's forces on one node, N.
struct NodePush {
  Vec3 relaxing{0, 0, 0};  // the force the removed rock put on the node, times the relaxation's factor
  Vec3 held{0, 0, 0};      // for good: minus the weight the node no longer carries
};

namespace device_pass {
/// The excavation's forces as a pass reads them: per node (null: none), with the factor now.
struct NodePushes {
  const NodePush* push;
  real scale;
  FDEM_HD Vec3 at(int n) const { return push ? scale * push[n].relaxing + push[n].held : Vec3{0, 0, 0}; }
};
}  // namespace device_pass

class GravityLoad : SumSlots {
 public:
  bool enabled = false;  // gravity, or an excavation's forces
  Vec3 g{0, 0, 0};       // m/s^2
  // The excavation's forces (set by the solver at a stage): the relaxing part falls from 1 at
  // relax_start (s) to 0 after relax_time (s) along the smooth ramp, at once where that is 0.
  std::vector<NodePush> push;  // per node; empty: none
  real relax_start = 0, relax_time = 0;
  // State.
  real power = 0;  // W, of the last evaluation's forces with their velocities

  void set_up(const Scene& scene) { enabled = scene.has_gravity(), g = scene.gravity; }
  bool on() const { return enabled; }

  // The device loop's calls: the excavation's forces, where there are any (g travels by value).
  void set_backend(Backend b) { push_.set_backend(b); }
  void place(const Model&, bool) {
    if (push.empty())
      push_.release();
    else
      push_.upload(push);
  }
  void upload_state() {}  // (its power is the evaluation's sum)
  void download_state() {}
  /// The relaxing forces' factor at time t (s).
  real relaxation(real t) const {
    if (!(relax_time > 0)) return 0;
    return 1 - (t <= relax_start ? 0 : ramped_speed(t - relax_start, 1, relax_time));
  }
  /// The excavation's forces on a state at time t (s).
  device_pass::NodePushes pushes(real t) const {
    return {push.empty() ? nullptr : push_.data(), push.empty() ? real(0) : relaxation(t)};
  }

  /// f = m g (and the excavation's forces at time t) on every node, and its power with v into
  /// kGravity.
  template <class Exec>
  void start_forces(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, Vec3* f, real* sums,
                    real t) const {
    const Vec3 gv = g;
    const device_pass::NodePushes np = pushes(t);
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          f[n] = gravity_force(mass[n], gv) + np.at(n);
          if (own_n[n]) acc[0] += dot(f[n], v[n]);
        },
        sums + kGravity);
  }

  /// The power of those forces (at time t) with the velocities v into kGravityNew.
  template <class Exec>
  void new_power(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, real* sums, real t) const {
    const Vec3 gv = g;
    const device_pass::NodePushes np = pushes(t);
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          if (own_n[n]) acc[0] += mass[n] * dot(gv, v[n]) + dot(np.at(n), v[n]);
        },
        sums + kGravityNew);
  }

  /// No monitor column of its own: its work is part of external_work_J.
  void monitor(const Model&, Monitors&) const {}
  /// Its part of a checkpoint: its power.
  void save(CheckpointOut& out) const { out.put(power); }
  void load(CheckpointIn& in, bool) { in.get(power); }

 private:
  DeviceArray<NodePush> push_;
};

}  // namespace fdem
