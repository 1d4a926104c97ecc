#pragma once
// Gravity (scene `gravity`, m/s^2): the weight of every node's mass (physics/gravity.hpp). It
// starts the sum of each node's force. Its power counts in the external work.
#include <cstdint>

#include "core/forall.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/gravity.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/sum_slots.hpp"

namespace fdem {

class GravityLoad : SumSlots {
 public:
  bool enabled = false;
  Vec3 g{0, 0, 0};  // m/s^2
  // State.
  real power = 0;  // W, of the last evaluation's forces with their velocities

  void set_up(const Scene& scene) { enabled = scene.has_gravity(), g = scene.gravity; }
  bool on() const { return enabled; }

  // The device loop's calls: no arrays (g travels by value into the passes).
  void set_backend(Backend) {}
  void place(const Model&, bool) {}
  void upload_state() {}  // (its power is the evaluation's sum)
  void download_state() {}

  /// f = m g on every node, and its power with v into kGravity.
  template <class Exec>
  void start_forces(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, Vec3* f, real* sums) const {
    const Vec3 gv = g;
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          f[n] = gravity_force(mass[n], gv);
          if (own_n[n]) acc[0] += dot(f[n], v[n]);
        },
        sums + kGravity);
  }

  /// The power of gravity's forces with the velocities v into kGravityNew.
  template <class Exec>
  void new_power(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, real* sums) const {
    const Vec3 gv = g;
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          if (own_n[n]) acc[0] += mass[n] * dot(gv, v[n]);
        },
        sums + kGravityNew);
  }

  /// No monitor column of its own: its work is part of external_work_J.
  void monitor(const Model&, Monitors&) const {}
  /// Its part of a checkpoint: its power.
  void save(CheckpointOut& out) const { out.put(power); }
  void load(CheckpointIn& in, bool) { in.get(power); }
};

}  // namespace fdem
