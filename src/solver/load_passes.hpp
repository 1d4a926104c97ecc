#pragma once
// The loads' passes in the device loop, one type per load (solver/loads.hpp holds their set-up
// and state on the host): gravity, the two platens, the confining pressure and the prescribed
// velocities. Each has the same four calls, which the loop makes for every load in turn:
//   set_backend(b); place(model, loads, held): its constants (`held`: where the fused pass
//   integrates, its forces wait for that pass); upload_state(loads); download_state(loads).
// Then it gives the loop its passes, or a view that the loop runs inside a launch it shares.
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "core/forall.hpp"
#include "model/model.hpp"
#include "physics/confinement.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "solver/loads.hpp"
#include "solver/loop_sums.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

namespace device_pass {
/// A pressure face's power: its force F (on each of its three nodes) dot their velocities,
/// added to acc node by node, owned nodes only.
FDEM_HD void add_face_power(Vec3 F, const int* face, const Vec3* v, const std::uint8_t* own_n, real& acc) {
  for (int j = 0; j < 3; ++j)
    if (own_n[face[j]]) acc += dot(F, v[face[j]]);
}
/// A node's step by its force where the fused pass integrates: the central difference, then
/// its prescription (the arithmetic of the integration pass and PrescribedPass::apply).
struct NodeStep {
  const real* mass;     // 1/m divided here: correctly rounded, the same bits on every backend
  const int* fixed_of;  // per node: its place in the prescribed lists, or -1 (null: none)
  const int* fixed_mask;
  const Vec3* fixed_v;
  real dt;
  FDEM_HD void move_with(real m, Vec3& x, Vec3& v, const Vec3& f) const { central_difference(x, v, f, 1 / m, dt); }
  FDEM_HD void prescribe(int n, Vec3& x, Vec3& v) const {
    const int i = fixed_of ? fixed_of[n] : -1;
    if (i >= 0) prescribe_velocity(x, v, fixed_mask[i], fixed_v[i], dt);
  }
};
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

/// Gravity on every node's mass: it starts the sum of each node's force.
template <class Exec>
class GravityPass : SumSlots {
 public:
  bool enabled = false;
  Vec3 g{0, 0, 0};  // m/s^2

  void set_backend(Backend) {}
  void place(const Model&, const Loads& loads, bool) { enabled = loads.gravity.enabled, g = loads.gravity.g; }
  void upload_state(const Loads&) {}  // (its power is the evaluation's sum)
  void download_state(Loads&) const {}

  /// f = m g on every node, and its power with v into kGravity.
  void start_forces(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, Vec3* f, real* sums) const {
    const Vec3 gv = g;
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          f[n] = mass[n] * gv;
          if (own_n[n]) acc[0] += dot(f[n], v[n]);
        },
        sums + kGravity);
  }

  /// The power of gravity's forces with the velocities v into kGravityNew.
  void power(int nodes, const real* mass, const Vec3* v, const std::uint8_t* own_n, real* sums) const {
    const Vec3 gv = g;
    Exec::template sum_to<1>(
        nodes,
        [=] FDEM_LAMBDA(int n, real* acc) {
          if (own_n[n]) acc[0] += mass[n] * dot(gv, v[n]);
        },
        sums + kGravityNew);
  }
};

/// Two rigid platens along z: each platen node against the nearer one (physics/platen.hpp).
template <class Exec>
class PlatenPass {
 public:
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(nodes_, k_, anchor_, held_, held_of_);
  }

  /// The platen nodes and their springs. `held`: the forces wait in an array of their own for
  /// the fused pass that integrates, with each node's place in it.
  void place(const Model& m, const Loads& loads, bool held) {
    const PlatenLoad& load = loads.platens;
    fdem::place(b_, nodes_, m.platen_nodes);
    fdem::place(b_, k_, load.k);
    if (!held) return;
    std::vector<int> of(m.X.size(), -1);
    if (load.enabled)
      for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) of[m.platen_nodes[i]] = int(i);
    held_of_.upload(of);
    held_.resize(m.platen_nodes.size());
  }
  void upload_state(const Loads& loads) { fdem::place(b_, anchor_, loads.platens.anchor); }
  void download_state(Loads& loads) const { anchor_.download(loads.platens.anchor); }
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
  /// The forces with the top platen `top_offset` (m) below its start.
  Forces forces(const PlatenLoad& load, real top_offset, bool held, Vec3* f) {
    return Forces{
        nodes_.data(),  k_.data(),    anchor_.data(), held ? held_.data() : nullptr, f, load.top_z0 - top_offset,
        load.bottom_z0, load.friction};
  }

  /// J, the energy the platen springs store at x (the anchors not moved).
  real stored(const PlatenLoad& load, const Vec3* x) const {
    const int* pn = nodes_.data();
    const real* pk = k_.data();
    const Vec3* anchor = anchor_.data();
    const real ztop = load.top_z0 - load.top_offset, zbot = load.bottom_z0, mu_p = load.friction;
    return Exec::template sum<1>(int(nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
      Vec3 a = anchor[i];  // measuring must not move the anchor
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

/// Confining pressure, a follower load on the lateral faces (physics/confinement.hpp).
template <class Exec>
class PressurePass : SumSlots {
 public:
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(faces_, node_, ptr_, face_, force_, held_of_);
  }

  /// The lateral faces and, per node, the faces it sums in face order (the reference stepper's
  /// order, so the sums agree bit for bit). `held`: where the fused pass integrates, each node's
  /// place in the node list (the pass adds the faces' forces itself).
  void place(const Model& m, const Loads& loads, bool held) {
    const ConfiningPressure& load = loads.confinement;
    const auto& faces = load.faces;
    fdem::place(b_, faces_, reinterpret_cast<const int*>(faces.data()), 3 * faces.size());
    std::vector<std::array<int, 2>> nf;
    for (int i = 0; i < int(faces.size()); ++i)
      for (int n : faces[i]) nf.push_back({n, i});
    std::stable_sort(nf.begin(), nf.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
    std::vector<int> node, ptr{0}, face;
    for (std::size_t k = 0; k < nf.size(); ++k) {
      if (k > 0 && nf[k][0] != nf[k - 1][0]) ptr.push_back(int(k));
      if (k == 0 || nf[k][0] != nf[k - 1][0]) node.push_back(nf[k][0]);
      face.push_back(nf[k][1]);
    }
    if (!nf.empty()) ptr.push_back(int(nf.size()));
    node_.upload(node);
    ptr_.upload(ptr);
    face_.upload(face);
    held_ = held;
    if (held) {
      std::vector<int> of(m.X.size(), -1);
      if (load.enabled)
        for (std::size_t k = 0; k < node.size(); ++k) of[node[k]] = int(k);
      held_of_.upload(of);
      loaded_nodes_ = load.enabled ? node : std::vector<int>{};
    }
  }
  void upload_state(const Loads& loads) { fdem::place(b_, force_, loads.confinement.face_force); }
  void download_state(Loads& loads) const { force_.download(loads.confinement.face_force); }
  /// Where its forces are held: the nodes they act on (empty when the pressure is off).
  const std::vector<int>& loaded_nodes() const { return loaded_nodes_; }
  int faces() const { return int(force_.size()); }
  /// Entries of the per-node face lists: the faces' forces the fused pass reads.
  int node_face_entries() const { return int(face_.size()); }

  /// Each face's force -p a / 3 per node at x, and its power with v into kPressurePower; then,
  /// unless held for the fused pass, added to f. On the hydrostatic path p follows the platen
  /// reactions in sums (kTop, kBottom); on the constant one, its ramp at `time` (s).
  void forces(const ConfiningPressure& load, real area0, real time, const Vec3* x, const Vec3* v,
              const std::uint8_t* own_n, Vec3* f, real* sums) {
    const bool hydrostatic = load.hydrostatic;
    const real target = load.target, ramped = hydrostatic ? target : ramped_speed(time, target, load.ramp);
    const int* lf = faces_.data();
    Vec3* lforce = force_.data();
    Exec::template sum_to<1>(
        int(force_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const real axial = hydrostatic ? mean_axial_stress(sums[kTop], sums[kBottom], area0) : 0;
          const real pr = confining_pressure(hydrostatic, target, ramped, axial);
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
  device_pass::FacePower power() const { return device_pass::FacePower{faces_.data(), force_.data()}; }

 private:
  Backend b_ = Backend::cpu;
  bool held_ = false;
  std::vector<int> loaded_nodes_;  // (held only)
  DeviceArray<int> faces_, node_, ptr_, face_, held_of_;
  DeviceArray<Vec3> force_;  // per face, on each of its nodes
};

/// Prescribed velocity components: after the central difference, the node's component takes
/// the prescribed velocity and its position the matching displacement.
template <class Exec>
class PrescribedPass {
 public:
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(node_, mask_, velocity_, place_of_);
  }

  /// `held`: each node's place in the lists too, for the fused pass that integrates.
  void place(const Model& m, const Loads&, bool held) { nodes_ = m.X.size(), per_node_ = held; }
  /// The lists (set between steps: Solver::prescribe), and where per node, each node's place.
  void upload_state(const Loads& loads) {
    const PrescribedVelocities& p = loads.prescribed;
    const std::size_t nodes = nodes_;
    const bool per_node = per_node_;
    fdem::place(b_, node_, p.node);
    fdem::place(b_, mask_, p.mask);
    fdem::place(b_, velocity_, p.velocity);
    if (per_node && !p.node.empty()) {
      std::vector<int> of(nodes, -1);
      for (std::size_t i = 0; i < p.node.size(); ++i) of[p.node[i]] = int(i);
      place_of_.upload(of);
    } else {
      place_of_.resize(0);
    }
  }
  void download_state(Loads&) const {}  // (the host's lists are the state)
  bool per_node() const { return place_of_.size() > 0; }

  /// The prescription on every listed node after a step of dt (s).
  void apply(Vec3* x, Vec3* v, real dt) {
    const int* fn = node_.data();
    const int* fm = mask_.data();
    const Vec3* fv = velocity_.data();
    Exec::forall(int(node_.size()),
                 [=] FDEM_LAMBDA(int i) { prescribe_velocity(x[fn[i]], v[fn[i]], fm[i], fv[i], dt); });
  }

  /// The node step of the fused pass that integrates, with masses `mass` and time step dt (s).
  device_pass::NodeStep node_step(const real* mass, real dt) const {
    return device_pass::NodeStep{mass, per_node() ? place_of_.data() : nullptr, mask_.data(), velocity_.data(), dt};
  }

 private:
  Backend b_ = Backend::cpu;
  std::size_t nodes_ = 0;
  bool per_node_ = false;
  DeviceArray<int> node_, mask_, place_of_;
  DeviceArray<Vec3> velocity_;
};

}  // namespace fdem
