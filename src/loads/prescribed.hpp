#pragma once
// Prescribed velocity components of nodes (tests; the boundary conditions to come). After the
// central difference, a node's prescribed component takes its velocity and its position the
// matching displacement (physics/integrate.hpp: prescribe_velocity).
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

namespace device_pass {
/// A node's step by its force where the fused pass integrates: the central difference, then
/// its prescription (the arithmetic of the integration pass and PrescribedVelocities::apply).
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
}  // namespace device_pass

class PrescribedVelocities {
 public:
  std::vector<int> node, mask;        // mask bit 0 = x, 1 = y, 2 = z
  std::vector<Vec3> velocity;         // m/s
  std::unordered_map<int, int> slot;  // node -> its entry in the lists above

  /// Set by the caller (Solver::prescribe), none from the scene yet.
  void set_up(const Scene&) {}
  bool on() const { return !node.empty(); }
  /// One entry per node (the loop applies the entries in parallel): a node prescribed again
  /// takes the new components, as if the calls were applied in turn.
  void set(int n, int components, Vec3 v);
  /// No monitor column: the ledger does not count the work they bring.
  void monitor(const Model&, Monitors&) const {}
  /// Nothing in a checkpoint: the Solver counts the nodes there, and its caller sets them again.
  void save(CheckpointOut&) const {}
  void load(CheckpointIn&, bool) {}

  // The device loop's calls.
  void set_backend(Backend b) {
    b_ = b;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(node_, mask_, velocity_, place_of_);
  }
  /// `held`: each node's place in the lists too, for the fused pass that integrates.
  void place(const Model& m, bool held) { nodes_ = m.X.size(), per_node_ = held; }
  /// The lists (set between steps), and where per node, each node's place.
  void upload_state();
  void download_state() {}  // (the host's lists are the state)
  bool per_node() const { return place_of_.size() > 0; }

  /// The prescription on every listed node after a step of dt (s).
  template <class Exec>
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
