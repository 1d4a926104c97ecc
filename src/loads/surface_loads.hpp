#pragma once
// Loads on surface faces: the confining pressure on the lateral surface (scene `confinement`;
// physics/confinement.hpp) and the scene's surface conditions on named groups: `pressure` (the
// same follower load), `traction` and `absorbing` (physics/surface_loads.hpp). Each face puts
// one force on each of its three nodes. On the hydrostatic path the confining pressure follows
// the platens' axial stress up to its target.
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/forall.hpp"
#include "core/vec.hpp"
#include "io/checkpoint.hpp"
#include "model/model.hpp"
#include "physics/confinement.hpp"
#include "physics/integrate.hpp"
#include "physics/surface_loads.hpp"
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/pass_support.hpp"
#include "solver/sum_slots.hpp"

namespace fdem {

/// Each scene condition's face law at one evaluation, passed to the pass by value: its type and
/// its value there (pressure: value.x in Pa; traction: the vector in Pa; absorbing: none, each
/// face has its rock's impedances). Conditions that are not face loads are unused.
struct FaceLaws {
  ConditionType type[BoundaryCondition::kMax];
  Vec3 value[BoundaryCondition::kMax];
};

namespace device_pass {
/// A face's power: its force F (on each of its three nodes) dot their velocities, owned nodes.
FDEM_HD real face_power(Vec3 F, const int* face, const Vec3* v, const std::uint8_t* own_n) {
  real p = 0;
  for (int j = 0; j < 3; ++j)
    if (own_n[face[j]]) p += dot(F, v[face[j]]);
  return p;
}
/// The power of the last faces' forces with the velocities v, one face per call. Where the faces
/// keep their works, each face's work over the step (dt/2 times its powers before and after).
struct FacePower {
  const int* face;
  const Vec3* force;
  const real* power_before;  // null: no works kept
  real* work;
  real half_dt;
  FDEM_HD void add(int i, const Vec3* v, const std::uint8_t* own_n, real& acc) const {
    const real p = face_power(force[i], face + 3 * i, v, own_n);
    acc += p;
    if (power_before) work[i] += half_dt * (power_before[i] + p);
  }
};
/// The faces' forces held for the fused pass: a node's faces' sum.
struct HeldFaceForces {
  const int* place;  // per node, -1: none
  const int* ptr;
  const int* face;
  const Vec3* force;
  FDEM_HD void add(int n, Vec3& fe) const {
    const int li = place[n];
    if (li >= 0)
      for (int j = ptr[li]; j < ptr[li + 1]; ++j) fe += force[face[j]];
  }
};
/// Face i's force per node: the confining pressure pr where its condition c < 0, else its law;
/// z: an absorbing face's P and S impedances (z.x, z.y, Pa s/m).
FDEM_HD Vec3 face_force(int c, real pr, const FaceLaws& laws, real area0, Vec3 z, const int* q, const Vec3* x,
                        const Vec3* v) {
  if (c < 0) return face_pressure_force(pr, x[q[0]], x[q[1]], x[q[2]]);
  switch (laws.type[c]) {
    case ConditionType::pressure:
      return face_pressure_force(laws.value[c].x, x[q[0]], x[q[1]], x[q[2]]);
    case ConditionType::traction:
      return face_traction_force(laws.value[c], area0);
    default: {  // absorbing
      const Vec3 vm = (real(1) / 3) * (v[q[0]] + v[q[1]] + v[q[2]]);
      return face_dashpot_force(z.x, z.y, x[q[0]], x[q[1]], x[q[2]], vm);
    }
  }
}
}  // namespace device_pass

class SurfaceLoads : SumSlots {
 public:
  bool enabled = false;                   // faces to load: the confining pressure or a surface condition
  bool confining = false;                 // the scene's confinement
  bool hydrostatic = false;               // the pressure follows the axial stress up to `target` (confinement.path)
  real target = 0;                        // Pa, sigma_3
  real ramp = 0;                          // s, the constant path's smooth rise
  std::vector<std::array<int, 3>> faces;  // the lateral surface's faces, then the conditions'
  std::vector<int> face_condition;        // per face: its scene condition, -1 for the confinement's
  std::vector<real> face_area0;           // per face, its reference area, m^2 (with conditions only)
  // Per face, its tet's P and S impedances (x, y; Pa s/m, mass scaling included); with absorbing
  // conditions only.
  std::vector<Vec3> face_impedance;
  // State: each face's force per node at the last evaluation, the pressure then and its power;
  // with conditions, each face's power then (W) and work so far (J).
  std::vector<Vec3> face_force;
  std::vector<real> face_power, face_work;
  real pressure = 0;  // Pa
  real power = 0;     // W

  /// From the scene's `confinement` (the lateral faces) and its surface conditions on model m;
  /// `transits` (s) is the confinement's ramp when the scene gives none.
  void set_up(const Scene& scene, const Model& m, real transits);
  bool on() const { return enabled; }

  /// The confining pressure an evaluation at `time` (s) applies, after platen reactions of
  /// axial stress `axial` (Pa, the hydrostatic path); 0 without confinement.
  real pressure_at(real time, real axial) const;
  /// The conditions' face laws at `time` (s).
  FaceLaws laws_at(real time) const;
  /// Its monitor column: the confining pressure applied.
  void monitor(const Model&, Monitors& r) const { r.confining_pressure = pressure; }
  /// The conditions' monitor columns: force on the rock (x, y, z, N) and work (J) per condition,
  /// over the owned nodes (`owned`: per node, empty: all), before the sum over the ranks.
  std::vector<real> condition_sums(const std::vector<std::uint8_t>& owned) const;
  /// Its part of a checkpoint: the pressure, its power, the face forces, powers and works.
  /// `ghosts_appended`: the checkpoint's layout lacks the faces of contact ghosts gathered
  /// since (no load on them).
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);

  // The device loop's calls.
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(faces_, cond_, node_, ptr_, face_, held_of_, area0_, power_, work_, force_, impedance_);
  }
  /// The faces and, per node, the faces it sums in face order (the reference stepper's order, so
  /// the sums agree bit for bit). `held`: where the fused pass integrates, each node's place in
  /// the node list (the pass adds the faces' forces itself).
  void place(const Model& m, bool held);
  void upload_state();
  void download_state();
  /// Where its forces are held: the nodes they act on (empty when off).
  const std::vector<int>& loaded_nodes() const { return loaded_nodes_; }
  int face_count() const { return int(force_.size()); }
  /// Entries of the per-node face lists: the faces' forces the fused pass reads.
  int node_face_entries() const { return int(face_.size()); }

  /// Each face's force per node at x (and v, for the dashpots), and its power with v into
  /// kPressurePower; then, unless held for the fused pass, added to f. The confining pressure
  /// follows the platen reactions in sums (kTop, kBottom) on the hydrostatic path, its ramp at
  /// `time` (s) on the constant one; the conditions follow their time functions.
  template <class Exec>
  void forces(real area0, real time, const Vec3* x, const Vec3* v, const std::uint8_t* own_n, Vec3* f, real* sums) {
    const bool hydro = hydrostatic;
    const real goal = target, ramped = hydro ? goal : ramped_speed(time, goal, ramp);
    const FaceLaws laws = laws_at(time);
    const int* lf = faces_.data();
    const int* fc = cond_.size() ? cond_.data() : nullptr;
    const real* fa = area0_.data();
    const Vec3* fz = impedance_.size() ? impedance_.data() : nullptr;
    real* fp = power_.size() ? power_.data() : nullptr;
    Vec3* lforce = force_.data();
    Exec::template sum_to<1>(
        int(force_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const int c = fc ? fc[i] : -1;
          real pr = 0;
          if (c < 0) {
            const real axial = hydro ? mean_axial_stress(sums[kTop], sums[kBottom], area0) : 0;
            pr = confining_pressure(hydro, goal, ramped, axial);
          }
          lforce[i] =
              device_pass::face_force(c, pr, laws, fc ? fa[i] : 0, fz ? fz[i] : Vec3{0, 0, 0}, lf + 3 * i, x, v);
          const real p = device_pass::face_power(lforce[i], lf + 3 * i, v, own_n);
          acc[0] += p;
          if (fp) fp[i] = p;
        },
        sums + kPressurePower);
    if (held_) return;  // the pass that steps adds them (ElementPasses::fused_pass)
    const int* ln = node_.data();
    const int* lp = ptr_.data();
    const int* lfa = face_.data();
    Exec::forall(int(node_.size()), [=] FDEM_LAMBDA(int k) {
      for (int j = lp[k]; j < lp[k + 1]; ++j) f[ln[k]] += lforce[lfa[j]];
    });
  }

  /// The faces' forces held for the fused pass.
  device_pass::HeldFaceForces held() const {
    return device_pass::HeldFaceForces{held_of_.data(), ptr_.data(), face_.data(), force_.data()};
  }
  /// The power of the last faces' forces, and with conditions their works over a step of dt (s).
  device_pass::FacePower new_power(real dt) {
    const bool works = power_.size() > 0;
    return device_pass::FacePower{faces_.data(), force_.data(), works ? power_.data() : nullptr,
                                  works ? work_.data() : nullptr, dt / 2};
  }

 private:
  Backend b_ = Backend::cpu;
  bool held_ = false;
  std::vector<int> loaded_nodes_;  // (held only)
  std::vector<ConditionType> type_;
  std::vector<Vec3> value_;         // per scene condition, its value at scale 1
  std::vector<TimeFunction> time_;  // per scene condition
  DeviceArray<int> faces_, cond_, node_, ptr_, face_, held_of_;
  DeviceArray<real> area0_, power_, work_;
  DeviceArray<Vec3> force_;      // per face, on each of its nodes
  DeviceArray<Vec3> impedance_;  // face_impedance
};

}  // namespace fdem
