#pragma once
// Two rigid platens along z (scene `platens`; physics/platen.hpp): the top one moves down at a
// ramped speed, the bottom one stays. Each platen node presses on the nearer one through a
// penalty spring with Coulomb friction. The lab tests' axial columns are theirs.
#include <cstdint>
#include <vector>

#include "core/forall.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/confinement.hpp"
#include "physics/platen.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

class PlatenLoad {
 public:
  bool enabled = false;
  real speed = 0;                  // m/s, the top platen's speed after its ramp
  real ramp = 0;                   // s, the speed's smooth rise
  real friction = 0;               // Coulomb coefficient, rock on platen
  real top_z0 = 0, bottom_z0 = 0;  // m, the platens' start
  std::vector<real> k;             // N/m, per platen node (Model::platen_nodes)
  // State.
  std::vector<Vec3> anchor;              // friction anchors per platen node (top/bottom share: one at a time)
  real top_offset = 0;                   // m, downward travel of the top platen from its start
  real step_speed = 0;                   // m/s, the speed over the step being taken
  real force_top = 0, force_bottom = 0;  // N, the last evaluation's reactions on the rock along +z

  /// From the scene's `platens` on model m; `transits` (s) is the ramp when the scene gives none.
  void set_up(const Scene& scene, const Model& m, real transits);
  bool on() const { return enabled; }

  /// m, the travel after a step of dt (s) at step_speed.
  real top_offset_after(real dt) const { return top_offset + step_speed * dt; }
  /// Mean of the two reactions over the loaded area area0 (m^2), compression positive, Pa.
  real axial_stress(real area0) const { return mean_axial_stress(force_top, force_bottom, area0); }
  /// Its monitor columns: axial strain and stress, the two reactions, and a line-loaded disc's
  /// indirect tensile stress.
  void monitor(const Model& m, Monitors& r) const;
  /// Its part of a checkpoint: travel, reactions, anchors.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);

  // The device loop's calls.
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(nodes_, k_, anchor_, held_, held_of_);
  }
  /// The platen nodes and their springs. `held`: the forces wait in an array of their own for
  /// the fused pass that integrates, with each node's place in it.
  void place(const Model& m, bool held);
  void upload_state() { fdem::place(b_, anchor_, anchor); }
  void download_state() { anchor_.download(anchor); }
  int nodes() const { return int(nodes_.size()); }

  /// One platen node's force at the platens' heights: added to f, or held for the fused pass.
  /// Its reaction goes to acc[0] (top) or acc[1] (bottom), its friction loss to acc[2].
  struct Forces {
    const int* node;
    const real* k;
    Vec3* anchor;
    Vec3* held;  // null: added to f
    Vec3* f;
    real ztop, zbot, mu;
    FDEM_HD void apply(int i, const Vec3* x, real* acc) const {
      const int n = node[i];
      bool near_top = false;
      const PlatenEval pe = nearer_platen_force(x[n], ztop, zbot, k[i], mu, anchor[i], near_top);
      if (held)
        held[i] = pe.force;
      else
        f[n] += pe.force;
      acc[near_top ? 0 : 1] += pe.force.z;
      acc[2] += pe.dissipated;
    }
  };
  /// The forces with the top platen `offset` (m) below its start.
  Forces forces(real offset, bool held, Vec3* f) {
    return Forces{nodes_.data(),   k_.data(), anchor_.data(), held ? held_.data() : nullptr, f,
                  top_z0 - offset, bottom_z0, friction};
  }

  /// J, the energy the platen springs store at x (the anchors not moved).
  template <class Exec>
  real stored(const Vec3* x) const {
    const int* pn = nodes_.data();
    const real* pk = k_.data();
    const Vec3* a0 = anchor_.data();
    const real ztop = top_z0 - top_offset, zbot = bottom_z0, mu_p = friction;
    return Exec::template sum<1>(int(nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
      Vec3 a = a0[i];  // measuring must not move the anchor
      bool near_top = false;
      acc[0] += nearer_platen_force(x[pn[i]], ztop, zbot, pk[i], mu_p, a, near_top).stored;
    })[0];
  }

  /// Held forces for the fused pass: per node its place (-1: none), per place the force.
  const int* held_place() const { return held_of_.data(); }
  const Vec3* held_force() const { return held_.data(); }

 private:
  Backend b_ = Backend::cpu;
  DeviceArray<int> nodes_, held_of_;
  DeviceArray<real> k_;  // N/m
  DeviceArray<Vec3> anchor_, held_;
};

}  // namespace fdem
