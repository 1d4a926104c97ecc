#pragma once
// The loads of a run as the time loop applies them: two rigid platens along z, a confining
// pressure on the lateral surface, gravity, and prescribed node velocities. Each holds what it
// is set up with (from the scene and the model) and its state between steps. The loop's passes
// (solver/device_loop_impl.hpp) compute their forces with the laws of src/physics.
#include <array>
#include <unordered_map>
#include <vector>

#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/confinement.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"

namespace fdem {

/// Two rigid platens along z (scene `platens`): the top one moves down at a ramped speed, the
/// bottom one stays. Each platen node presses on the nearer one through a penalty spring.
struct PlatenLoad {
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

  /// m, the travel after a step of dt (s) at step_speed.
  real top_offset_after(real dt) const { return top_offset + step_speed * dt; }
  /// Mean of the two reactions over the loaded area area0 (m^2), compression positive, Pa.
  real axial_stress(real area0) const { return mean_axial_stress(force_top, force_bottom, area0); }
  /// Its monitor columns: axial strain and stress, the two reactions, and a line-loaded disc's
  /// indirect tensile stress.
  void monitor(const Model& m, Monitors& r) const;
  /// Its part of a checkpoint: travel, reactions, anchors.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
};

/// Confining pressure on the lateral surface (scene `confinement`): a follower load, -p a / 3
/// on each node of a face of current outward area vector a.
struct ConfiningPressure {
  bool enabled = false;
  bool hydrostatic = false;               // the pressure follows the axial stress up to `target` (confinement.path)
  real target = 0;                        // Pa, sigma_3
  real ramp = 0;                          // s, the constant path's smooth rise
  std::vector<std::array<int, 3>> faces;  // the lateral surface's faces
  // State: each face's force per node at the last evaluation, the pressure then and its power.
  std::vector<Vec3> face_force;
  real pressure = 0;  // Pa
  real power = 0;     // W

  /// The pressure an evaluation at `time` (s) applies, after platen reactions of axial stress
  /// `axial` (Pa, the hydrostatic path).
  real pressure_at(real time, real axial) const;
  /// Its monitor column: the pressure applied.
  void monitor(Monitors& r) const { r.confining_pressure = pressure; }
  /// Its part of a checkpoint: the pressure, its power and the face forces. `ghosts_appended`:
  /// the checkpoint's layout lacks the faces of contact ghosts gathered since (zero forces).
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);
};

/// Gravity (scene `gravity`, m/s^2) on every node's mass.
struct GravityLoad {
  bool enabled = false;
  Vec3 g{0, 0, 0};
  real power = 0;  // W, of the last evaluation's forces
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
};

/// Prescribed velocity components of nodes (tests; the boundary conditions to come).
struct PrescribedVelocities {
  std::vector<int> node, mask;        // mask bit 0 = x, 1 = y, 2 = z
  std::vector<Vec3> velocity;         // m/s
  std::unordered_map<int, int> slot;  // node -> its entry in the lists above

  bool empty() const { return node.empty(); }
  /// One entry per node (the loop applies the entries in parallel): a node prescribed again
  /// takes the new components, as if the calls were applied in turn.
  void set(int n, int components, Vec3 v);
};

struct Loads {
  PlatenLoad platens;
  ConfiningPressure confinement;
  GravityLoad gravity;
  PrescribedVelocities prescribed;  // (set by the caller, not saved: a checkpoint counts them)
  /// Each load's part of a checkpoint, in turn.
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);
};

/// The loads of `scene` on model m. `wave_speed` (m/s, the P-wave speed with mass scaling) sets
/// the automatic ramps: ten transits of the height. Prescribed velocities start empty.
Loads make_loads(const Scene& scene, const Model& m, real wave_speed);

}  // namespace fdem
