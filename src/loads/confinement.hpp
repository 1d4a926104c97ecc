#pragma once
// Confining pressure on the lateral surface (scene `confinement`; physics/confinement.hpp): a
// follower load, -p a / 3 on each node of a face of current outward area vector a. On the
// hydrostatic path p follows the platens' axial stress up to its target.
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
#include "scene/scene.hpp"
#include "solver/monitors.hpp"
#include "solver/pass_support.hpp"
#include "solver/sum_slots.hpp"

namespace fdem {

namespace device_pass {
/// A pressure face's power: its force F (on each of its three nodes) dot their velocities,
/// added to acc node by node, owned nodes only.
FDEM_HD void add_face_power(Vec3 F, const int* face, const Vec3* v, const std::uint8_t* own_n, real& acc) {
  for (int j = 0; j < 3; ++j)
    if (own_n[face[j]]) acc += dot(F, v[face[j]]);
}
/// The power of the last pressure faces' forces with the velocities v, one face per call.
struct FacePower {
  const int* face;
  const Vec3* force;
  FDEM_HD void add(int i, const Vec3* v, const std::uint8_t* own_n, real& acc) const {
    add_face_power(force[i], face + 3 * i, v, own_n, acc);
  }
};
/// The pressure faces' forces held for the fused pass: a node's faces' sum.
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
}  // namespace device_pass

class ConfiningPressure : SumSlots {
 public:
  bool enabled = false;
  bool hydrostatic = false;               // the pressure follows the axial stress up to `target` (confinement.path)
  real target = 0;                        // Pa, sigma_3
  real ramp = 0;                          // s, the constant path's smooth rise
  std::vector<std::array<int, 3>> faces;  // the lateral surface's faces
  // State: each face's force per node at the last evaluation, the pressure then and its power.
  std::vector<Vec3> face_force;
  real pressure = 0;  // Pa
  real power = 0;     // W

  /// From the scene's `confinement` on model m (its lateral faces); `transits` (s) is the ramp
  /// when the scene gives none.
  void set_up(const Scene& scene, const Model& m, real transits);
  bool on() const { return enabled; }

  /// The pressure an evaluation at `time` (s) applies, after platen reactions of axial stress
  /// `axial` (Pa, the hydrostatic path).
  real pressure_at(real time, real axial) const;
  /// Its monitor column: the pressure applied.
  void monitor(const Model&, Monitors& r) const { r.confining_pressure = pressure; }
  /// Its part of a checkpoint: the pressure, its power and the face forces. `ghosts_appended`:
  /// the checkpoint's layout lacks the faces of contact ghosts gathered since (zero forces).
  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in, bool ghosts_appended);

  // The device loop's calls.
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(faces_, node_, ptr_, face_, force_, held_of_);
  }
  /// The lateral faces and, per node, the faces it sums in face order (the reference stepper's
  /// order, so the sums agree bit for bit). `held`: where the fused pass integrates, each node's
  /// place in the node list (the pass adds the faces' forces itself).
  void place(const Model& m, bool held);
  void upload_state() { fdem::place(b_, force_, face_force); }
  void download_state() { force_.download(face_force); }
  /// Where its forces are held: the nodes they act on (empty when the pressure is off).
  const std::vector<int>& loaded_nodes() const { return loaded_nodes_; }
  int face_count() const { return int(force_.size()); }
  /// Entries of the per-node face lists: the faces' forces the fused pass reads.
  int node_face_entries() const { return int(face_.size()); }

  /// Each face's force -p a / 3 per node at x, and its power with v into kPressurePower; then,
  /// unless held for the fused pass, added to f. On the hydrostatic path p follows the platen
  /// reactions in sums (kTop, kBottom); on the constant one, its ramp at `time` (s).
  template <class Exec>
  void forces(real area0, real time, const Vec3* x, const Vec3* v, const std::uint8_t* own_n, Vec3* f, real* sums) {
    const bool hydro = hydrostatic;
    const real goal = target, ramped = hydro ? goal : ramped_speed(time, goal, ramp);
    const int* lf = faces_.data();
    Vec3* lforce = force_.data();
    Exec::template sum_to<1>(
        int(force_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const real axial = hydro ? mean_axial_stress(sums[kTop], sums[kBottom], area0) : 0;
          const real pr = confining_pressure(hydro, goal, ramped, axial);
          lforce[i] = face_pressure_force(pr, x[lf[3 * i]], x[lf[3 * i + 1]], x[lf[3 * i + 2]]);
          device_pass::add_face_power(lforce[i], lf + 3 * i, v, own_n, acc[0]);
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
  /// The power of the last faces' forces.
  device_pass::FacePower new_power() const { return device_pass::FacePower{faces_.data(), force_.data()}; }

 private:
  Backend b_ = Backend::cpu;
  bool held_ = false;
  std::vector<int> loaded_nodes_;  // (held only)
  DeviceArray<int> faces_, node_, ptr_, face_, held_of_;
  DeviceArray<Vec3> force_;  // per face, on each of its nodes
};

}  // namespace fdem
