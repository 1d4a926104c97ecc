#pragma once
// The loads of a run, each one type in a file of its own in this folder. A load holds its
// settings and its state, and gives the time loop its passes. Each has the same calls:
//   set_up(scene, ...)                from the scene's keys (its own ramp, faces or nodes);
//   on()                              declared by the scene (a load that is off costs nothing);
//   set_backend(b), place(model, held), upload_state(), download_state()
//                                     its arrays in the loop's memory (`held`: where the fused
//                                     pass integrates, its forces wait there for that pass);
//   monitor(model, row)               its monitor columns;
//   save(out), load(in, appended)     its part of a checkpoint.
// Its force and power passes (templates on the loop's Exec) are called by the step at the
// place its kind takes: a body force starts each node's force (gravity), a surface load adds to
// it after contact (platens, pressure), a kinematic condition follows the integration
// (prescribed velocities). Its law is in src/physics.
#include "loads/gravity.hpp"
#include "loads/platens.hpp"
#include "loads/prescribed.hpp"
#include "loads/surface_loads.hpp"

namespace fdem {

struct Loads {
  PlatenLoad platens;
  SurfaceLoads surface;  // the confining pressure and the surface conditions
  GravityLoad gravity;
  PrescribedVelocities prescribed;  // the scene's kinematic boundary conditions, and the caller's

  /// f(load) for every load, in this order (the checkpoint's and the monitor row's).
  template <class F>
  void each(F&& f) {
    f(platens), f(surface), f(gravity), f(prescribed);
  }
  template <class F>
  void each(F&& f) const {
    f(platens), f(surface), f(gravity), f(prescribed);
  }
  /// Each load's monitor columns, in turn.
  void monitor(const Model& m, Monitors& r) const {
    each([&](const auto& load) { load.monitor(m, r); });
  }
  /// Each load's part of a checkpoint, in turn.
  void save(CheckpointOut& out) const {
    each([&](const auto& load) { load.save(out); });
  }
  void load(CheckpointIn& in, bool ghosts_appended) {
    each([&](auto& load) { load.load(in, ghosts_appended); });
  }
};

/// The loads of `scene` on model m. `wave_speed` (m/s, the P-wave speed with mass scaling) sets
/// the automatic ramps: ten transits of the height. Prescribed velocities start with the scene's
/// boundary conditions; a caller may add its own (Solver::prescribe).
Loads make_loads(const Scene& scene, const Model& m, real wave_speed);

}  // namespace fdem
