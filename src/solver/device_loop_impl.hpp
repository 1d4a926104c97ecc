#pragma once
// DeviceLoopImpl<Exec>: the device loop (device_loop.hpp) for one Exec. Included by
// device_loop.cpp (CpuExec, the cpu backend; HostExec, the debug backend) and by
// cuda/device_loop.cu (CudaExec), so the passes are one source. Lambdas capture raw pointers by value; members are
// copied to locals first (a device lambda cannot read `this`).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <limits>
#include <utility>

#include "contact/broad_phase.hpp"
#include "core/forall.hpp"
#include "physics/cohesive6.hpp"
#include "physics/confinement.hpp"
#include "physics/contact.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "solver/candidate_build.hpp"
#include "solver/device_loop.hpp"
#include "solver/halo_passes.hpp"

namespace fdem {

namespace device_pass {
/// A TET4's forces on its nodes at xe, ve (fe), the inverted count into acc[1] and, for an owned
/// tet, its viscous power into acc[0]: the element of both schedules' TET4 passes.
FDEM_HD void tet4_element(const Vec3 (&xe)[4], const Vec3 (&ve)[4], const Mat3& Xinv, real V0, real lambda, real mu,
                          real eta, bool own, real* acc, Vec3 (&fe)[4]) {
  const Tet4Eval ev = tet4_forces(xe, ve, Xinv, V0, lambda, mu, eta, fe);
  if (!(ev.J > 0)) acc[1] += 1;
  if (own) acc[0] += ev.viscous_power;
}
/// A contact pair's power: -f.v of its forces fa (on nodes na) and fb (on nb), subtracted from
/// acc node by node, owned nodes only.
FDEM_HD void subtract_pair_power(const Vec3 (&fa)[4], const Vec3 (&fb)[4], const int (&na)[4], const int (&nb)[4],
                                 const Vec3* v, const std::uint8_t* own_n, real& acc) {
  for (int i = 0; i < 4; ++i) {
    if (own_n[na[i]]) acc -= dot(fa[i], v[na[i]]);
    if (own_n[nb[i]]) acc -= dot(fb[i], v[nb[i]]);
  }
}
/// A pressure face's power: its force F (on each of its three nodes) dot their velocities,
/// added to acc node by node, owned nodes only.
FDEM_HD void add_face_power(Vec3 F, const int* face, const Vec3* v, const std::uint8_t* own_n, real& acc) {
  for (int j = 0; j < 3; ++j)
    if (own_n[face[j]]) acc += dot(F, v[face[j]]);
}
/// A TET4's first force at its corners: assigned where `first` has the corner's bit, else added.
FDEM_HD void tet4_start(const Vec3* f, const int* q, int first, Vec3 (&fe)[4]) {
  for (int i = 0; i < 4; ++i) fe[i] = (first >> i & 1 ? Vec3{0, 0, 0} : f[q[i]]) + fe[i];
}
/// A CE6 that carries force, on its nodes at xe, ve (fe), with its damage d and anchors a
/// updated. Where `counts` (the one evaluation of it that keeps its results): its power into
/// acc[0] (intact) or acc[1] (broken) when owned, and a break into acc[2] and its flag.
FDEM_HD void ce6_element(const Ce6Params& p, const Vec3 (&xe)[6], const Vec3 (&ve)[6], real h, Ce6Damage& d,
                         Vec3 (&a)[3], bool counts, bool own, real* acc, std::uint8_t* broke, Vec3 (&fe)[6]) {
  const bool was_broken = ce6_broken(d);
  const Ce6Eval ev = cohesive6_forces(p, xe, ve, h, d, a, fe);
  if (!counts) return;
  if (own && was_broken) acc[1] += ev.power;  // constant indices: acc stays in registers
  if (own && !was_broken) acc[0] += ev.power;
  if (!was_broken && ce6_broken(d)) *broke = 1, acc[2] += 1;
}
/// The sum of the pair forces at gather node k (slots gs[gp[k]..gp[k+1]) of the pairs' forces pf).
FDEM_HD Vec3 pair_forces_at(const int* gp, const int* gs, const Vec3* pf, int k) {
  Vec3 sum{0, 0, 0};
  for (int j = gp[k]; j < gp[k + 1]; ++j) sum += pf[gs[j]];
  return sum;
}

/// A force evaluation's start: the last one's scalars [0, kBad) kept at [kPrev, kPrev + kBad)
/// (when `keep`), then slots [0, clear) zeroed (DeviceLoopImpl's Slot).
struct KeepAndClear {
  real* sums;
  bool keep;
  int clear;
  static constexpr int kBad = 16, kPrev = 24;
  FDEM_HD void operator()() const {
    if (keep)
      for (int k = 0; k < kBad; ++k) sums[kPrev + k] = sums[k];
    for (int k = 0; k < clear; ++k) sums[k] = 0;
  }
};

/// Where the fused pass integrates (DeviceLoop::integrates): a node's step by its force, the
/// arithmetic of advance() (central difference, then a prescribed velocity).
struct NodeStep {
  const real* mass;     // 1/m divided here: correctly rounded, the same bits on every backend
  const int* fixed_of;  // per node: its place in the prescribed lists, or -1 (null: none)
  const int* fixed_mask;
  const Vec3* fixed_v;
  real dt;
  FDEM_HD void move(int n, Vec3& x, Vec3& v, const Vec3& f) const { move_with(mass[n], x, v, f); }
  FDEM_HD void move_with(real m, Vec3& x, Vec3& v, const Vec3& f) const { central_difference(x, v, f, 1 / m, dt); }
  FDEM_HD void prescribe(int n, Vec3& x, Vec3& v) const {
    const int i = fixed_of ? fixed_of[n] : -1;
    if (i < 0) return;
    for (int d = 0; d < 3; ++d)
      if (fixed_mask[i] >> d & 1) {
        x[d] += dt * (fixed_v[i][d] - v[d]);
        v[d] = fixed_v[i][d];
      }
  }
};
}  // namespace device_pass

template <class Exec>
class DeviceLoopImpl final : public DeviceLoop {
 public:
  /// `plan`: the fused pass's (plan_fused_pass), or empty for the colour passes.
  DeviceLoopImpl(Backend b, const LoopParts& parts, bool direct_mpi, FusedPlan plan)
      : p_(parts),
        b_(b),
        direct_mpi_(direct_mpi),
        fused_(!plan.list.empty()),
        integrates_(fused_ && plan.integrate),
        blocks_(fused_ ? plan.blocks_per_sm : 1),
        plan_(std::move(plan)) {
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(tet_nodes_, tet_order_, ce6_nodes_, ce6_slot_, platen_nodes_, fixed_node_, fixed_mask_, lat_faces_, lat_ptr_,
        lat_face_, lat_node_, node_vertex_, vt_ptr_, vt_tets_, watch_nodes_, gather_node_, gather_ptr_, gather_slot_,
        lateral_nodes_);
    set(Xinv_, V0_, eta_, ce6_h_, mass_, platen_k_, sums_);
    set(X_, plan_x_, x_, v_, f_, anchor_, fixed_v_, lat_force_, watch_x_, spring_, pair_force_);
    set(dmg_, slip_, dmg_model_, slip_model_, broke_, active_, mid_third_, own_node_, own_tet_, own_ce6_, tet_assigns_,
        unreached_, pairs_, eval_);
    set(tet_global_, tet_ce6_, ce6_tets_, next_pairs_, next_spring_);
    candidates_.set_backend(b);
    set(fused_ce6_, ce6_sides_, dmg_next_, slip_next_, ce6_flag_, ce6_flag_next_, x2_, v2_, fixed_of_);
    set(contact_sum_, platen_force_, gather_of_, platen_of_, lateral_of_, ext_tet_, ext_static_);
    halo_.set_backend(b, direct_mpi);
    sums_.resize(kAll);
    clear_sums(0, kAll);  // a slot a schedule never writes (kWatched) reads 0
  }

  Backend backend() const override { return b_; }
  bool fused() const override { return fused_; }
  bool integrates() const override { return integrates_; }
  int blocks_per_sm() const override { return blocks_; }
  bool halo_passes_device_buffers() const override { return direct_mpi_; }
  void set_timing(bool on) override { timing_ = on; }
  const DeviceTimes& times() const override { return t_; }

  void upload() override {
    const auto t0 = now();
    if (!constants_) {
      place_elements(p_);
      place_layout_and_loads(p_);
      mark_middle_third(p_.model);
      if (p_.contacts.enabled()) place_contact_topology(p_);
      place_held_forces(p_, place_lateral_faces(p_.loads.confinement.faces));
      constants_ = true;
    }
    upload_state(p_);
    t_.copies += seconds_since(t0);
  }

  // The parts of upload(). (Public where they hold a pass: nvcc's extended lambdas need their
  // enclosing function public.)

  /// The elements' constants: connectivity, colour order, the CE6 slots, the shape constants and
  /// the masses.
  void place_elements(const LoopParts& s) {
    const Model& m = s.model;
    place(tet_nodes_, reinterpret_cast<const int*>(m.tet_nodes.data()), 4 * m.tet_nodes.size());
    place(tet_order_, m.tet_colours.order);
    // CE6 arrays in colour order (the CE6s no colour holds, on several ranks, after them), so
    // that a colour's launch reads them contiguously.
    const std::size_t nce = m.ce6_nodes.size();
    ce6_perm_ = m.ce6_colours.order;
    std::vector<int> slot(nce, -1);
    for (std::size_t k = 0; k < ce6_perm_.size(); ++k) slot[ce6_perm_[k]] = int(k);
    for (std::size_t i = 0; i < nce; ++i)
      if (slot[i] < 0) slot[i] = int(ce6_perm_.size()), ce6_perm_.push_back(int(i));
    if (ce6_perm_.size() != nce)  // the rank-file loader refuses such a colouring
      throw RunError("device loop: the CE6 colouring lists a CE6 more than once");
    // CE6 ids are colour order (model/build.cpp): on one rank the slots are the ids, and the
    // per-CE6 arrays are the host's (in place on the cpu backend); no slot map then.
    ce6_by_id_ = true;
    for (std::size_t k = 0; k < nce; ++k) ce6_by_id_ = ce6_by_id_ && ce6_perm_[k] == int(k);
    if (ce6_by_id_)
      ce6_slot_.release();
    else
      ce6_slot_.upload(slot);
    ce6_coloured_ = int(m.ce6_colours.order.size());
    ce6p_ = s.laws.ce6;
    place_in_slots(ce6_nodes_, m.ce6_nodes);
    place(Xinv_, m.tet_Xinv);
    place(V0_, m.tet_V0);
    place(eta_, m.tet_eta);
    place_in_slots(ce6_h_, m.ce6_h);
    place(mass_, m.mass);  // (1/m: divided where needed, no array read for it)
    // Every node's mass a quarter of its one tet's, rho V0 / 4 (model/build.cpp), to the bit:
    // then the fused pass computes it from V0, which it reads anyway, instead of reading it.
    const real rho = s.scene.solver.mass_scaling * s.scene.material.density;
    std::vector<int> tets_of(m.X.size(), 0);
    mass_from_volume_ = true;
    for (std::size_t t = 0; t < m.tet_nodes.size() && mass_from_volume_; ++t)
      for (int n : m.tet_nodes[t]) {
        mass_from_volume_ = mass_from_volume_ && ++tets_of[n] == 1 && m.mass[n] == rho * m.tet_V0[t] / 4;
        if (!mass_from_volume_) break;
      }
    node_density_ = mass_from_volume_ ? rho : 0;
  }

  /// This rank's layout (ownership, first touch, the halo), the constants of the loads, and the
  /// schedule's checks.
  void place_layout_and_loads(const LoopParts& s) {
    const Model& m = s.model;
    place(platen_nodes_, m.platen_nodes);
    place(platen_k_, s.loads.platens.k);
    place(node_vertex_, m.node_vertex);
    place(X_, m.X);
    if (s.layout.dd.distributed() && s.contacts.enabled()) {
      place(plan_x_, s.contacts.plan_x());
      place(tet_global_, s.layout.dd.tet_global);
    }
    place(lateral_nodes_, m.lateral_nodes);
    place(own_node_, s.layout.own_node);
    place(own_tet_, s.layout.own_tet);
    place_in_slots(own_ce6_, s.layout.own_ce6);
    place(tet_assigns_, s.layout.tet_assigns);
    assigned_corners_ = 0;
    for (std::uint8_t a : s.layout.tet_assigns)
      assigned_corners_ += (a & 1) + (a >> 1 & 1) + (a >> 2 & 1) + (a >> 3 & 1);
    gravity_ = s.loads.gravity.enabled;
    g_ = s.loads.gravity.g;
    place(unreached_, s.layout.unreached_nodes);
    plan_fused();
    // The fused pass integrates (make_device_loop: one rank, every node a tet's).
    if (integrates_ && (s.layout.halo || s.layout.dd.distributed() || !s.layout.unreached_nodes.empty()))
      throw RunError("device loop: the fused pass cannot integrate this run (several ranks or nodes outside the tets)");
    step_contact_ = s.contacts.enabled();
    step_pressure_ = s.loads.confinement.enabled;
    if (s.layout.halo) halo_.plan(*s.layout.halo, s.layout.dd);
  }

  /// Monitor rows: the tets whose reference centroid lies in the middle third of the height.
  void mark_middle_third(const Model& m) {
    std::vector<std::uint8_t> mid(m.tet_nodes.size());
    const real z_lo = m.box_min.z + (m.box_max.z - m.box_min.z) / 3,
               z_hi = m.box_max.z - (m.box_max.z - m.box_min.z) / 3;
    for (std::size_t t = 0; t < mid.size(); ++t) {
      const auto& q = m.tet_nodes[t];
      const real zc = 0.25 * (m.X[q[0]].z + m.X[q[1]].z + m.X[q[2]].z + m.X[q[3]].z);
      mid[t] = zc >= z_lo && zc <= z_hi;
    }
    mid_third_.upload(mid);
  }

  /// Contact's constants: the activation's vertex -> tets lists and the candidate filters.
  void place_contact_topology(const LoopParts& s) {
    const Model& m = s.model;
    place(vt_ptr_, s.contacts.vertex_tet_ptr());
    place(vt_tets_, s.contacts.vertex_tets());
    // The broad phase's filters: the CE6s on each tet's faces and the tets of each CE6.
    place(tet_ce6_, reinterpret_cast<const int*>(s.contacts.tet_ce6().data()), 4 * s.contacts.tet_ce6().size());
    place(ce6_tets_, reinterpret_cast<const int*>(m.ce6_tets.data()), 2 * m.ce6_tets.size());
  }

  /// Confining pressure: the lateral faces and, per node, the faces it sums in face order (the
  /// reference stepper's order, so the sums agree bit for bit). Returns the nodes.
  std::vector<int> place_lateral_faces(const std::vector<std::array<int, 3>>& faces) {
    place(lat_faces_, reinterpret_cast<const int*>(faces.data()), 3 * faces.size());
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
    lat_node_.upload(node);
    lat_ptr_.upload(ptr);
    lat_face_.upload(face);
    return node;
  }

  /// Where the fused pass integrates: the lists that hold the platens' and the pressure's forces
  /// for the pass (`lateral_nodes`: the pressure's nodes).
  void place_held_forces(const LoopParts& s, const std::vector<int>& lateral_nodes) {
    if (!integrates_) return;
    const Model& m = s.model;
    std::vector<int> pof(m.X.size(), -1), lof(m.X.size(), -1);
    if (s.loads.platens.enabled)
      for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) pof[m.platen_nodes[i]] = int(i);
    if (s.loads.confinement.enabled)
      for (std::size_t k = 0; k < lateral_nodes.size(); ++k) lof[lateral_nodes[k]] = int(k);
    std::vector<std::uint8_t> ext(m.tet_nodes.size(), 0);
    for (std::size_t t = 0; t < ext.size(); ++t)
      for (int n : m.tet_nodes[t])
        if (pof[n] >= 0 || lof[n] >= 0) ext[t] = 2;
    ext_nodes_ = 4 * long(std::count(ext.begin(), ext.end(), 2));
    platen_of_.upload(pof);
    lateral_of_.upload(lof);
    ext_static_.upload(ext);
    ext_tet_.upload(ext);
    platen_force_.resize(m.platen_nodes.size());
    gather_of_.upload(std::vector<int>(m.X.size(), -1));
  }

  /// The evolving state, host to loop (on the cpu backend borrowed, in place).
  void upload_state(const LoopParts& s) {
    discard_pending();  // the host copy, its scalars included, is the state
    place(x_, s.x);
    place(v_, s.v);
    place(f_, s.f);
    if (integrates_) own_copy(x2_, s.x.size()), own_copy(v2_, s.v.size());
    upload_ce6_state(s);
    place_in_slots(broke_, s.ce6_broke);
    place(anchor_, s.loads.platens.anchor);
    place(fixed_node_, s.loads.prescribed.node);
    place(fixed_mask_, s.loads.prescribed.mask);
    place(fixed_v_, s.loads.prescribed.velocity);
    step_pending_ = false;                                  // the host's state is the state
    if (integrates_ && !s.loads.prescribed.node.empty()) {  // each node's place in the prescribed lists
      std::vector<int> of(s.x.size(), -1);
      for (std::size_t i = 0; i < s.loads.prescribed.node.size(); ++i) of[s.loads.prescribed.node[i]] = int(i);
      fixed_of_.upload(of);
    } else {
      fixed_of_.resize(0);
    }
    place(lat_force_, s.loads.confinement.face_force);
    if (s.contacts.enabled()) upload_contact_state(s.contacts);
  }

  /// The second copy of a double-buffered array, n elements, the loop's own. On the cpu backend a
  /// swap can have left it borrowing the host's array, which the first copy borrows again at an
  /// upload: the pass would then read and write one array.
  template <class T>
  static void own_copy(DeviceArray<T>& second, std::size_t n) {
    if (second.borrowed()) second.release();
    second.resize(n);
  }

  /// The CE6 state: the host's arrays where the slots are the ids (in place on the cpu backend),
  /// else uploaded in id order and put into slots on the device; the fused pass's second copies.
  void upload_ce6_state(const LoopParts& s) {
    if (ce6_by_id_) {
      place(dmg_, s.ce6.damage);
      place(slip_, s.ce6.anchors);
    } else {
      dmg_model_.upload(s.ce6.damage);
      slip_model_.upload(s.ce6.anchors);
      dmg_.resize(s.ce6.size());
      slip_.resize(s.ce6.size());
      ce6_between_orders(true);
    }
    if (fused_) {  // the fused pass reads one copy and writes the other: both start current
      own_copy(dmg_next_, dmg_.size());
      own_copy(slip_next_, slip_.size());
      const Ce6Damage* d = dmg_.data();
      const Ce6Anchors* a = slip_.data();
      Ce6Damage* dn = dmg_next_.data();
      Ce6Anchors* an = slip_next_.data();
      Exec::forall(int(dmg_.size()), [=] FDEM_LAMBDA(int k) { dn[k] = d[k], an[k] = a[k]; });
      // Per slot: bit 0 the own flag, bit 1 a damage state other than the intact one (to the
      // bit), so that the pass reads the 32 bytes only there; both copies.
      const Ce6Damage intact{};
      std::vector<std::uint8_t> fl(ce6_perm_.size());
      for (std::size_t k = 0; k < fl.size(); ++k) {
        const Ce6Damage& dk = s.ce6.damage[ce6_perm_[k]];
        fl[k] = std::uint8_t((s.layout.own_ce6[ce6_perm_[k]] ? 1 : 0) | (std::memcmp(&dk, &intact, sizeof dk) ? 2 : 0));
      }
      ce6_flag_.upload(fl);
      ce6_flag_next_.upload(fl);
    }
  }

  /// Contact's state: flags, pairs, springs, forces and indices; the gather list followed anew.
  void upload_contact_state(const ContactSet& c) {
    place(active_, c.active);
    flags_merged_ = false;
    // Every node out of the old gather list (on the cpu backend the list this loop borrowed may
    // have been overwritten by a checkpoint's).
    if (integrates_) {
      int* of = gather_of_.data();
      Exec::forall(int(gather_of_.size()), [=] FDEM_LAMBDA(int n) { of[n] = -1; });
    }
    upload_pairs(c);
    pairs_on_host_ = true;
    if (integrates_) follow_gather(true);
  }

  void download() override {
    const LoopParts& s = p_;
    materialize();
    const auto t0 = now();
    x_.download(s.x);
    v_.download(s.v);
    f_.download(s.f);
    // The CE6 state: where the slots are not the ids, gathered into id order on the device first.
    if (ce6_by_id_) {
      dmg_.download(s.ce6.damage);
      slip_.download(s.ce6.anchors);
      broke_.download(s.ce6_broke);
    } else {
      dmg_model_.resize(dmg_.size());
      slip_model_.resize(dmg_.size());
      ce6_between_orders(false);
      dmg_model_.download(s.ce6.damage);
      slip_model_.download(s.ce6.anchors);
      std::vector<std::uint8_t> b;
      broke_.download(b);
      for (std::size_t k = 0; k < b.size(); ++k) s.ce6_broke[ce6_perm_[k]] = b[k];
    }
    anchor_.download(s.loads.platens.anchor);
    lat_force_.download(s.loads.confinement.face_force);
    if (s.contacts.enabled()) {
      ContactSet& c = s.contacts;
      active_.download(c.active);
      c.recount_active();
      spring_.download(c.spring);
      eval_.download(c.eval);
      pair_force_.download(c.pair_force);
      if (!pairs_on_host_) {  // built on the device since the last copy
        pairs_.download(c.pairs);
        gather_node_.download(c.gather_node);
        gather_ptr_.download(c.gather_ptr);
        gather_slot_.download(c.gather_slot);
        watch_nodes_.download(c.watch_nodes);
        watch_x_.download(c.watch_x);
        pairs_on_host_ = true;
      }
    }
    t_.copies += seconds_since(t0);
  }

  void poison_host() override {
    const LoopParts& s = p_;
    const real nan = std::numeric_limits<real>::quiet_NaN();
    const Vec3 bad{nan, nan, nan};
    for (auto* a : {&s.x, &s.v, &s.f, &s.loads.platens.anchor, &s.loads.confinement.face_force})
      std::fill(a->begin(), a->end(), bad);
    for (Ce6Damage& c : s.ce6.damage) c.D[0] = c.D[1] = c.D[2] = nan, c.mode = -1;
    for (Ce6Anchors& c : s.ce6.anchors) std::fill(std::begin(c.a), std::end(c.a), bad);
    std::fill(s.ce6_broke.begin(), s.ce6_broke.end(), 0xAA);
    if (s.contacts.enabled()) {
      ContactSet& c = s.contacts;
      std::fill(c.active.begin(), c.active.end(), 0xAA);
      std::fill(c.spring.begin(), c.spring.end(), bad);
      std::fill(c.pair_force.begin(), c.pair_force.end(), bad);
      std::fill(c.eval.begin(), c.eval.end(), ContactEval{bad, bad, nan});
    }
    // The last evaluation's scalars not yet settled: read before settle() they are NaN.
    if (forces_pending_) {
      s.loads.platens.force_top = s.loads.platens.force_bottom = s.energy.p_contact = s.energy.contact_spring = nan;
      s.energy.p_viscous = s.energy.p_cohesive = s.energy.p_friction = nan;
      if (integrates_) s.loads.gravity.power = nan;  // (with the elements' sums there)
      if (s.loads.confinement.enabled) s.loads.confinement.pressure = s.loads.confinement.power = nan;
    }
  }

  real kinetic2() override {
    materialize();
    const Vec3* v = v_.data();
    const real* mass = mass_.data();
    const std::uint8_t* own_n = own_node_.data();
    return Exec::template sum<1>(int(v_.size()), [=] FDEM_LAMBDA(int n, real* acc) {
      if (own_n[n]) acc[0] += mass[n] * dot(v[n], v[n]);
    })[0];
  }

  // Sums of a step stay in device memory (sums_). On one rank they come to the host once per
  // step, after the CE6 pass of the next force evaluation (breaks, the broad-phase watch: the
  // broad phase's decision; the count of tets an activation added comes with the evaluation's
  // scalars, or where the fused pass steps in one value more on the steps it broke a CE6),
  // with the integration's sums (slots kBad to kSums) and
  // the last force evaluation's scalars (platen reactions, powers, slip: slots below kBad, moved
  // to kPrev before the new evaluation clears them) in the same copy. Several ranks read them
  // twice: after the CE6 pass (the broad phase's decision), and after the integration with the
  // force evaluation's scalars, which the step's one reduction sums over the ranks (the contact
  // reach decides there whether to gather ghosts before the next forces); on the hydrostatic
  // path the platen reactions too, which the pressure follows.
  // [0, kBad): a force evaluation's sums, [kBad, kSums): an integration's. Gravity's and the
  // element passes' come last of the first, and the integration's kinetic energy and gravity
  // power first of the second, so that a fused pass that integrates sums into one run of slots
  // (kGravity to kGravityNew).
  enum Slot {
    kAdded,     // activation
    kMoved,     // the broad phase's watch
    kTouching,  // contact
    kConDiss,
    kConStored,
    kConPower,
    kTop,  // platens
    kBottom,
    kPlatenFric,
    kPressurePower,
    kGravity,
    kVisc,  // the element passes
    kInverted,
    kCoh,
    kFric,
    kBreaks,
    kBad,  // integration
    kKinetic2,
    kGravityNew,
    kFar,
    kLost,
    kConPowerNew,
    kPressurePowerNew,
    kWatched,       // the broad phase's watch where the fused pass steps (with the new powers; else kMoved)
    kSums = 24,     // (kWatched + 1 at most)
    kPrev = kSums,  // [kPrev, kPrev + kBad): the last evaluation's [0, kBad), kept for its step
    kAll = kPrev + kBad
  };
  static_assert(device_pass::KeepAndClear::kBad == kBad && device_pass::KeepAndClear::kPrev == kPrev,
                "KeepAndClear's slots");
  static_assert(kWatched < kSums, "an integration's slots end before kPrev");

  void compute_forces() override {
    const LoopParts& s = p_;
    // A step's integration not read yet (one rank): its sums come with this evaluation's first
    // copy, and so do the last evaluation's scalars, kept at kPrev. A second evaluation without a
    // step between brings the first's scalars to the Solver first.
    const bool finish = advance_pending_;
    if (forces_pending_ && !finish) settle();
    const bool prev = forces_pending_;
    real* sums = sums_.data();
    auto t0 = now();
    // Where the fused pass integrates, the element part of an evaluation waits for the next step:
    // that step's pass computes the elements at the state the last evaluation left, adds the
    // forces contact, platens and pressure put there, and moves its nodes (fused_pass, kStep).
    // Where it was completed since (complete_forces), the step is a pass of its own.
    const bool stepping = step_pending_ && elements_pending_;
    if (step_pending_ && !stepping) {
      step_pending_ = false;
      integrate_nodes(step_dt_, nullptr, 0);
      new_powers(step_contact_, step_pressure_, gravity_);
      t0 = lap(t0, t_.integrate);
    }
    // The last evaluation's scalars kept at kPrev, then the slots cleared: one launch, or where
    // the fused pass steps, in its launch (before it adds its sums).
    const device_pass::KeepAndClear keep_and_clear{sums, prev, stepping ? kSums : kBad};
    if (!stepping) Exec::forall(1, [=] FDEM_LAMBDA(int) { keep_and_clear(); });

    element_forces(s, stepping, keep_and_clear, t0);
    // The broad phase's watch: has a node of an active tet moved half the buffer? (A count.)
    const int nc = int(dmg_.size());
    ContactSet& cs = s.contacts;
    if (cs.enabled() && !stepping) activate(cs, 0, true);  // (stepping: with the new powers, above)
    t0 = lap(t0, t_.activation);
    // The step's one copy to the host. Where the fused pass integrates (one rank), the rest of
    // the evaluation is queued behind it, so that the device works while the host waits and
    // decides: contact's pairs on the candidate list as it stands, then the platens and the
    // confining pressure at the platen travel and the time the step leads to (those
    // finish_step() sets below). A rebuild below discards the pairs and runs them again (the
    // friction springs are kept apart until then; the timing columns count both runs). Their
    // forces, the platens' and the pressure's wait for the next step's pass in arrays of their
    // own, so their place among the launches does not change a sum. A run that stops in between
    // (an inverted TET4, a velocity not finite) downloads those pairs' forces with the springs
    // from before them, and the platens' anchors and the pressure's forces of the evaluation
    // queued (with their held sums, contact_sum_ and platen_force_, left on the device): its
    // diagnostic frame reads none of them.
    std::array<real, kAll> a;
    device::read_start(b_, sums_.data(), sizeof a);
    const bool ahead = integrates_ && cs.enabled() && !cs.rebuild_due;
    // The per-node sum of the pairs' forces queued ahead goes into the platens' launch (both write
    // forces held for the pass: their order changes no sum); after a rebuild, its own launch.
    const bool gather_with_platens = ahead && s.loads.platens.enabled;
    if (ahead) contact_pairs(s, t0, !gather_with_platens);
    if (integrates_)
      platens_and_pressure(s, finish ? s.loads.platens.top_offset_after(s.dt) : s.loads.platens.top_offset,
                           finish ? (s.time + s.dt) : s.time, gather_with_platens, t0);
    device::read_finish(b_, a.data(), sizeof a);
    if (stepping) take_stepped_sums(s, a);
    if (finish) {  // the step that led here: its bookkeeping, checks and clock (may throw)
      advance_pending_ = false;
      if (prev && !stepping) apply_force_sums(s, a.data() + kPrev);
      if (s.book.finish_step(advance_sums(a.data())))
        throw RunError("device loop: a step on one rank asked to gather contact ghosts");
    }
    t0 = lap(t0, t_.activation);
    // Inverted TET4s of the elements computed in this call, or where the fused pass integrates,
    // of an evaluation it completed before the step without settle() (materialize(): after the
    // step, so named a step late; Solver::step and sync_host settle first).
    if ((stepping ? 0 : a[kInverted]) + (integrates_ && finish && prev && !stepping ? a[kPrev + kInverted] : 0) > 0) {
      download();  // rare: the host finds and names the element
      s.book.report_inverted();
    }
    if (!integrates_) s.loads.gravity.power = a[kGravity];  // (integrating: with the evaluation's sums)
    if (s.layout.halo && cs.enabled()) merge_shared_flags(s);

    // Tet-tet contact: the candidate list rebuilt when flags changed or a node moved half the
    // buffer; the pairs (queued ahead above, or now).
    if (cs.enabled()) contact_forces(s, cs.rebuild_due || a[kMoved] > 0 || a[kWatched] > 0, ahead, t0);

    // Adaptive activation, on the evaluations where a CE6 broke (activate()), for the next
    // evaluation's contact. (Where the fused pass integrates: with the pass's breaks, above.)
    if (!integrates_ && a[kBreaks] > 0) activate(cs, nc, false);
    t0 = lap(t0, t_.activation);
    if (!integrates_) platens_and_pressure(s, s.loads.platens.top_offset, s.time, false, t0);
    // The scalars stay on the device: one rank reads them with the next evaluation's first copy,
    // several ranks with the integration's sums (advance()), and sum them over the ranks in the
    // step's one reduction (take_reduced); or settle() before either.
    forces_pending_ = true;
    elements_pending_ = integrates_;
  }

  // The parts of compute_forces(). (Public where they hold a pass: nvcc's extended lambdas need
  // their enclosing function public.)

  /// The elements' forces (and where the fused pass steps, the step and the powers of the last
  /// forces with the moved state), gravity's start of the sums, or the zeroed unreached nodes.
  void element_forces(const LoopParts& s, bool stepping, const device_pass::KeepAndClear& keep_and_clear,
                      std::chrono::steady_clock::time_point& t0) {
    const Model& m = s.model;
    const int nn = int(x_.size());
    const Vec3* v = v_.data();
    Vec3* f = f_.data();
    const real* mass = mass_.data();
    real* sums = sums_.data();
    const std::uint8_t* own_n = own_node_.data();
    // Gravity starts the sum; without it the TET4 pass assigns each node's first force (the
    // nodes it does not reach are zeroed here), so f is not written twice. (A fused pass that
    // integrates starts each force itself.)
    const Vec3 g = s.loads.gravity.g;
    if (integrates_) {
    } else if (!gravity_) {
      const int* un = unreached_.data();
      Exec::forall(int(unreached_.size()), [=] FDEM_LAMBDA(int k) { f[un[k]] = Vec3{0, 0, 0}; });
    } else {
      Exec::template sum_to<1>(
          nn,
          [=] FDEM_LAMBDA(int n, real* acc) {
            f[n] = mass[n] * g;
            if (own_n[n]) acc[0] += dot(f[n], v[n]);
          },
          sums + kGravity);
    }

    // TET4 and CE6: fused in one pass, or colour by colour (plan_fused_pass); where the fused
    // pass integrates, the last evaluation's, with the step.
    if (stepping) {
      fused_pass<kStep>(m, s.laws.lambda, s.laws.mu, sums, keep_and_clear);
      t0 = lap(t0, t_.ce6);  // (the TET4 and integration columns stay empty)
      // (x and v swapped: the moved state.) The powers of the last forces with it
      // (gravity's: in the pass), and in the same launch the broad phase's watch (timed here, as
      // energy, not as activation)
      contact_pressure_powers(s.contacts.enabled(), s.loads.confinement.enabled,
                              s.contacts.enabled() ? &s.contacts : nullptr);
      t0 = lap(t0, t_.energy);
    } else if (integrates_) {
    } else if (fused_) {
      fused_pass<kForces>(m, s.laws.lambda, s.laws.mu, sums);
      t0 = lap(t0, t_.ce6);  // (the TET4 column stays empty)
    } else {
      colour_forces(m, s.laws.lambda, s.laws.mu, sums, t0);
    }
  }

  /// Where the fused pass stepped: the last evaluation's sums (its contact, platens and pressure
  /// at kPrev; its elements from the pass) to the Solver, from the copy a; an inverted TET4 named
  /// in the state the pass read; the vicinity of the CE6s it broke activated.
  void take_stepped_sums(const LoopParts& s, const std::array<real, kAll>& a) {
    ContactSet& cs = s.contacts;
    const int nc = int(dmg_.size());
    std::array<real, kBad> b;
    for (int k = 0; k < kBad; ++k) b[k] = a[kPrev + k];
    for (int k : {kGravity, kVisc, kInverted, kCoh, kFric, kBreaks}) b[k] = a[k];
    b[kAdded] = 0;
    if (a[kInverted] > 0) {           // rare: the host names the element in the state the pass read (the
      apply_force_sums(s, b.data());  // first copies of x and v, the CE6 states before it),
      std::swap(x_, x2_);             // before the step is counted, as the colour passes do
      std::swap(v_, v2_);
      std::swap(dmg_, dmg_next_);
      std::swap(slip_, slip_next_);
      std::swap(ce6_flag_, ce6_flag_next_);
      download();
      s.book.report_inverted();
    }
    if (a[kBreaks] > 0) {       // the pass broke CE6s: their vicinity joins the candidates now, for
      activate(cs, nc, false);  // this evaluation's contact (with contact, one value more to the host)
      if (cs.enabled()) device::to_host(b_, &b[kAdded], sums_.data() + kAdded, sizeof(real));
    }
    apply_force_sums(s, b.data());
  }

  /// Several ranks: a flag raised on any rank holding a tet reaches the others before the broad
  /// phase looks at the flags. The ranks merge them together, and only when one of them raised a
  /// flag since the last merge (or took flags from its host): one number in the step's reduction
  /// (take_reduced) instead of the flags' exchange and its three copies, on the steps (most) that
  /// raise none. A layout grown since (Solver::grow_contact_ghosts, on every rank at once) brings
  /// its host's flags with no reduction in between: every rank merges then.
  void merge_shared_flags(const LoopParts& s) {
    if ((merge_wanted_ || !flags_merged_) && halo_.merge_flags(*s.layout.halo, active_, x_, v_, s.layout.halo_seconds))
      s.contacts.rebuild_due = true;
    merge_wanted_ = false;
    flags_merged_ = true;
  }

  /// Tet-tet contact: the candidate list rebuilt where `rebuild`; narrow phase, friction and the
  /// deterministic per-node sum, unless they ran `ahead` of the copy on the list as it stands.
  void contact_forces(const LoopParts& s, bool rebuild, bool ahead, std::chrono::steady_clock::time_point& t0) {
    ContactSet& cs = s.contacts;
    if (rebuild) {
      if (integrates_) follow_gather(false);
      rebuild_pairs(s);
      if (integrates_) follow_gather(true);
      ++t_.rebuilds;
    }
    t0 = lap(t0, t_.broad);
    if (rebuild && ahead) {  // the pairs' sums queued ahead go
      real* sums_now = sums_.data();
      Exec::forall(kConPower + 1 - kTouching, [=] FDEM_LAMBDA(int k) { sums_now[kTouching + k] = 0; });
    }
    if (rebuild || !ahead) contact_pairs(s, t0, true);
    std::swap(spring_, next_spring_);  // the springs of the pairs' last pass are now the state
    // The run's report reads the contact set's clocks (friction: in the narrow phase's pass).
    cs.times.broad = t_.broad;
    cs.times.narrow = t_.narrow + t_.contact_sum;
  }

  /// The platens' and the confining pressure's forces at the state in x and v, with the top
  /// platen at top_offset (m) and the pressure's ramp at `time` (s): added to f, or where the
  /// fused pass integrates, held for it. `gather`: the contact pairs' per-node sum in the
  /// platens' launch (where the fused pass integrates). t0: the passes' clock.
  void platens_and_pressure(const LoopParts& s, real top_offset, real time, bool gather,
                            std::chrono::steady_clock::time_point& t0) {
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    Vec3* f = f_.data();
    const PlatenLoad& platens = s.loads.platens;
    const ContactSet& cs = s.contacts;
    real* sums = sums_.data();
    // Platens: each node against the nearer one.
    if (platens.enabled) {
      const int* pn = platen_nodes_.data();
      const real* pk = platen_k_.data();
      Vec3* anchor = anchor_.data();
      Vec3* held = integrates_ ? platen_force_.data() : nullptr;  // (for the pass that steps)
      const real ztop = platens.top_z0 - top_offset, zbot = platens.bottom_z0, mu_p = platens.friction;
      // After the platen nodes, where it comes here (gather), the pairs' per-node sum (after them,
      // so that the order of the platens' sums does not change with the pairs').
      const int npn = int(platen_nodes_.size());
      const int ng = gather && cs.enabled() ? int(gather_node_.size()) : 0;
      const int* gp = gather_ptr_.data();
      const int* gs = gather_slot_.data();
      const Vec3* pf = pair_force_.data();
      Vec3* csum = contact_sum_.data();
      Exec::template sum_to<3>(
          npn + ng,
          [=] FDEM_LAMBDA(int i, real* acc) {
            if (i >= npn) {
              csum[i - npn] = device_pass::pair_forces_at(gp, gs, pf, i - npn);
              return;
            }
            const int n = pn[i];
            bool near_top = false;
            const PlatenEval pe = nearer_platen_force(x[n], ztop, zbot, pk[i], mu_p, anchor[i], near_top);
            if (held)
              held[i] = pe.force;
            else
              f[n] += pe.force;
            acc[near_top ? 0 : 1] += pe.force.z;
            acc[2] += pe.dissipated;
          },
          sums + kTop);
    }
    t0 = lap(t0, t_.platens);

    // Confining pressure (pressure_forces), after the platens: on the hydrostatic path it follows
    // this evaluation's platen reactions. Several ranks sum those over the ranks first and put
    // them back on the device (a reduction of their own; the rest of the
    // evaluation's sums wait for the step's).
    const ConfiningPressure& cf = s.loads.confinement;
    if (cf.enabled && cf.hydrostatic && s.layout.dd.distributed()) {
      device::to_host(b_, reactions_.data(), sums_.data() + kTop, sizeof reactions_);
      s.layout.sum(reactions_.data(), 2);
      device::to_device(b_, sums_.data() + kTop, reactions_.data(), sizeof reactions_);
    }
    if (cf.enabled) pressure_forces(s, x, v, f, time);
    t0 = lap(t0, t_.pressure);
  }

  /// Confining pressure, a follower load: -p a / 3 per node of each lateral face, added to f, and
  /// its power with v into kPressurePower. On the hydrostatic path p follows the platen
  /// reactions in sums_ (kTop, kBottom); on the constant one, its ramp at `time` (s).
  void pressure_forces(const LoopParts& s, const Vec3* x, const Vec3* v, Vec3* f, real time) {
    const ConfiningPressure& cf = s.loads.confinement;
    const bool hydrostatic = cf.hydrostatic;
    const real target = cf.target, ramped = hydrostatic ? target : ramped_speed(time, target, cf.ramp);
    const real area0 = s.model.area0;
    real* sums = sums_.data();
    const int* lf = lat_faces_.data();
    Vec3* lforce = lat_force_.data();
    const std::uint8_t* own_n = own_node_.data();
    Exec::template sum_to<1>(  // each face's force, and its power with the velocities now
        int(lat_force_.size()),
        [=] FDEM_LAMBDA(int i, real* acc) {
          const real axial = hydrostatic ? mean_axial_stress(sums[kTop], sums[kBottom], area0) : 0;
          const real pr = confining_pressure(hydrostatic, target, ramped, axial);
          lforce[i] = face_pressure_force(pr, x[lf[3 * i]], x[lf[3 * i + 1]], x[lf[3 * i + 2]]);
          device_pass::add_face_power(lforce[i], lf + 3 * i, v, own_n, acc[0]);
        },
        sums + kPressurePower);
    if (integrates_) return;  // the pass that steps adds them (fused_pass)
    const int* ln = lat_node_.data();
    const int* lp = lat_ptr_.data();
    const int* lfa = lat_face_.data();
    Exec::forall(int(lat_node_.size()), [=] FDEM_LAMBDA(int k) {
      for (int j = lp[k]; j < lp[k + 1]; ++j) f[ln[k]] += lforce[lfa[j]];
    });
  }

  void settle() override {
    const LoopParts& s = p_;
    if (!forces_pending_) return;
    if (s.layout.dd.distributed()) {  // (every rank at once: monitor rows, output, checks after a reduction)
      // (as many values as a step's reduction, zeros first: the same MPI reduction, so the
      // same order of sums whether a monitor row comes between or not)
      waiting_ = read_sums<kBad>();
      constexpr int k = StepSums::kValues;
      std::array<real, k + std::tuple_size_v<decltype(AdvanceSums::more)>> all{};
      reduction_values(all.data() + k);
      s.layout.sum(all.data(), int(all.size()));
      take_reduced(all.data() + k);
      return;
    }
    complete_forces();
    const std::array<real, kBad> b = read_sums<kBad>();
    apply_force_sums(s, b.data());
    if (integrates_ && b[kInverted] > 0) {  // (completed here: named here)
      download();
      s.book.report_inverted();
    }
  }

  void take_reduced(const real* more) override {
    const LoopParts& s = p_;
    if (forces_pending_) {  // the rank's own sums, the whole model's where they are summed (kWhole)
      std::array<real, kBad> b = waiting_;
      for (int k = 0; k < int(kWhole.size()); ++k) b[kWhole[k]] = more[k];
      if (s.loads.confinement.enabled && s.loads.confinement.hydrostatic)  // summed already (compute_forces)
        b[kTop] = reactions_[0], b[kBottom] = reactions_[1];
      apply_force_sums(s, b.data());
    }
    merge_wanted_ = merge_wanted_ || more[kWhole.size()] > 0;
  }

  void discard_pending() override { forces_pending_ = advance_pending_ = step_pending_ = elements_pending_ = false; }

 private:
  /// The Solver's bookkeeping of a force evaluation from its sums (b: slots [0, kBad)).
  void apply_force_sums(const LoopParts& s, const real* b) {
    forces_pending_ = false;
    if (b[kAdded] > 0) s.contacts.rebuild_due = true;  // for the next evaluation's contact
    ConfiningPressure& cf = s.loads.confinement;
    s.energy.p_contact = b[kConPower];
    s.energy.contact_slip += b[kConDiss];
    s.energy.contact_spring = b[kConStored];
    s.contacts.touching = long(b[kTouching]);
    s.loads.platens.force_top = b[kTop];
    s.loads.platens.force_bottom = b[kBottom];
    if (cf.enabled) {
      cf.pressure = cf.pressure_at(s.time, s.loads.platens.axial_stress(s.model.area0));
      cf.power = b[kPressurePower];
    }
    s.energy.p_viscous = b[kVisc];
    s.energy.p_cohesive = b[kCoh];
    s.energy.p_friction = b[kFric];
    s.energy.platen_friction += b[kPlatenFric];
    if (integrates_) s.loads.gravity.power = b[kGravity];  // (computed with the elements, by the pass)
  }

 public:
  bool advance(real dt, AdvanceSums& out) override {
    const LoopParts& s = p_;
    ++t_.steps;
    if (integrates_) {                   // the next force evaluation's pass moves the nodes
      if (step_pending_) materialize();  // (a step already pending, no evaluation since: never in Solver::step)
      step_dt_ = dt;
      step_pending_ = advance_pending_ = true;
      return false;
    }
    auto t0 = now();
    // Several ranks with contact: the owned nodes a quarter of the contact reach from where the
    // contact ghosts were last gathered (time to gather them again) and half the reach (too
    // late: Solver::step). Prescribed nodes count before their prescription below.
    const bool reach_check = s.layout.halo && s.contacts.enabled() && s.layout.dd.reach > 0;
    integrate_nodes(dt, reach_check ? plan_x_.data() : nullptr, s.layout.dd.reach);
    t0 = lap(t0, t_.integrate);
    if (s.layout.halo) halo_update(s);  // ghosts take their owners' new positions and velocities
    new_powers(s.contacts.enabled(), s.loads.confinement.enabled, s.loads.gravity.enabled);
    if (!s.layout.dd.distributed()) {  // read with the next evaluation's first copy
      advance_pending_ = true;
      lap(t0, t_.energy);
      return false;
    }
    // Several ranks: the integration's sums and the last force evaluation's in one copy; the
    // powers of that evaluation with which the works of the step begin (Solver::step_sums) are
    // the rank's own.
    const std::array<real, kSums> r = read_sums<kSums>();
    lap(t0, t_.energy);
    out = advance_sums(r.data());
    if (forces_pending_) {
      std::copy(r.begin(), r.begin() + kBad, waiting_.begin());
      s.energy.p_contact = r[kConPower];
      if (s.loads.confinement.enabled) s.loads.confinement.power = r[kPressurePower];
    }
    out.n_more = int(out.more.size());
    reduction_values(out.more.data());
    return true;
  }

  /// Several ranks: what this rank adds to the step's reduction (take_reduced): the waiting
  /// evaluation's sums that the whole model sums (zero where none waits: the same on every
  /// rank), and 1 where it activated tets since the last merge or took flags from its host.
  void reduction_values(real* more) const {
    static_assert(kWhole.size() + 1 == std::tuple_size_v<decltype(AdvanceSums::more)>, "the step's reduction");
    for (int k = 0; k < int(kWhole.size()); ++k) more[k] = forces_pending_ ? waiting_[kWhole[k]] : 0;
    more[kWhole.size()] = (forces_pending_ && waiting_[kAdded] > 0) || !flags_merged_ ? 1 : 0;
  }

  /// Central difference of every node with time step dt into sums [kBad, kSums) (cleared first:
  /// non-finite velocities, m v.v, and with px the nodes a quarter and half of `reach` from px;
  /// gravity's power is the caller's), then the prescribed velocities.
  void integrate_nodes(real dt, const Vec3* px, real reach) {
    Vec3* x = x_.data();
    Vec3* v = v_.data();
    const Vec3* f = f_.data();
    const real* mass = mass_.data();
    const std::uint8_t* own_n = own_node_.data();
    clear_sums(kBad, kSums);
    const real lim2 = 0.0625 * reach * reach;
    Exec::template sum_to<5>(  // (acc[2], gravity's power: after the prescription, elsewhere)
        int(x_.size()),
        [=] FDEM_LAMBDA(int n, real* acc) {
          central_difference(x[n], v[n], f[n], 1 / mass[n], dt);  // ghosts too: overwritten below
          if (!own_n[n]) return;
          acc[0] += !finite_value(v[n].x + v[n].y + v[n].z);
          acc[1] += mass[n] * dot(v[n], v[n]);
          if (px) {
            const Vec3 d = x[n] - px[n];
            acc[3] += dot(d, d) >= lim2;
            acc[4] += dot(d, d) >= 4 * lim2;
          }
        },
        sums_.data() + kBad);
    static_assert(kKinetic2 == kBad + 1 && kFar == kBad + 3 && kLost == kBad + 4, "the integration's sums");
    const int* fn = fixed_node_.data();
    const int* fm = fixed_mask_.data();
    const Vec3* fv = fixed_v_.data();
    Exec::forall(int(fixed_node_.size()), [=] FDEM_LAMBDA(int i) {
      const int n = fn[i];
      for (int d = 0; d < 3; ++d)
        if (fm[i] >> d & 1) {
          x[n][d] += dt * (fv[i][d] - v[n][d]);
          v[n][d] = fv[i][d];
        }
    });
  }

  /// The powers of the last contact and pressure forces, and of gravity, with the velocities now
  /// (the work over a step with the mean of the velocities before and after it).
  void new_powers(bool contact, bool pressure, bool gravity) {
    contact_pressure_powers(contact, pressure);
    if (!gravity) return;
    const Vec3 g = g_;
    const real* mass = mass_.data();
    const Vec3* v = v_.data();
    const std::uint8_t* own_n = own_node_.data();
    Exec::template sum_to<1>(
        int(x_.size()),
        [=] FDEM_LAMBDA(int n, real* acc) {
          if (own_n[n]) acc[0] += mass[n] * dot(g, v[n]);
        },
        sums_.data() + kGravityNew);
  }

  /// Where the fused pass integrates, for whatever reads the state before the next step's pass:
  /// the last evaluation completed (complete_forces), and the step advance() left pending done
  /// by the integration's own passes (its sums wait for the next evaluation's copy, as on one
  /// rank).
  void materialize() {
    complete_forces();
    if (!step_pending_) return;
    step_pending_ = false;
    integrate_nodes(step_dt_, nullptr, 0);
    new_powers(step_contact_, step_pressure_, gravity_);
  }

  /// Where the fused pass integrates: the element part of the last evaluation, left to the next
  /// step's pass, done now by the same pass without the step (f: each node's whole force, the
  /// colour passes'), then the activation by its breaks. Its sums go to the evaluation's slots.
  void complete_forces() {
    if (!elements_pending_) return;
    elements_pending_ = false;
    const LoopParts& s = p_;
    {  // the slots of the elements' sums and the activation's count (the last step's pass left
       // its own there): cleared; the sums add to them
      real* sums = sums_.data();
      Exec::forall(kBreaks + 1 - kGravity, [=] FDEM_LAMBDA(int k) {
        sums[kGravity + k] = 0;
        if (k == 0) sums[kAdded] = 0;
      });
    }
    fused_pass<kComplete>(s.model, s.laws.lambda, s.laws.mu, sums_.data());
    activate(s.contacts, int(dmg_.size()), false);
  }

 private:
  /// The integration's sums in slots [kBad, kSums) of r.
  static AdvanceSums advance_sums(const real* r) {
    AdvanceSums out;
    out.bad = r[kBad], out.kinetic2 = r[kKinetic2], out.contact_power = r[kConPowerNew];
    out.pressure_power = r[kPressurePowerNew], out.gravity_power = r[kGravityNew], out.far = r[kFar];
    out.lost = r[kLost];
    return out;
  }

 public:
  MonitorSums measure_sums() override {
    const LoopParts& s = p_;
    materialize();
    const auto t0 = now();
    const Model& m = s.model;
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    const Vec3* X = X_.data();
    MonitorSums out;
    const Vec3 axis = m.axis_point;
    const bool disc = m.line_loaded;
    const int* ln = lateral_nodes_.data();
    const std::uint8_t* own_n = own_node_.data();
    const std::uint8_t* own_t = own_tet_.data();
    const std::uint8_t* own_c = own_ce6_.data();
    const auto lat = Exec::template sum<2>(int(lateral_nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
      const int n = ln[i];
      if (!own_n[n]) return;
      acc[1] += 1;
      Vec3 rr = X[n] - axis;
      rr.z = 0;
      if (disc) rr.y = 0;
      const real r2 = dot(rr, rr);
      if (r2 > 0) acc[0] += dot(x[n] - X[n], rr) / r2;
    });
    out.lateral_ratio = lat[0], out.lateral_nodes = lat[1];
    out.kinetic = 0.5 * kinetic2();
    const int* tn = tet_nodes_.data();
    const Mat3* Xinv = Xinv_.data();
    const real* V0 = V0_.data();
    const real* eta = eta_.data();
    const std::uint8_t* mid = mid_third_.data();
    const real lambda = s.laws.lambda, mu = s.laws.mu;
    const auto te = Exec::template sum<3>(int(V0_.size()), [=] FDEM_LAMBDA(int t, real* acc) {
      if (!own_t[t]) return;
      Vec3 xe[4], ve[4], fe[4];
      for (int i = 0; i < 4; ++i) xe[i] = x[tn[4 * t + i]], ve[i] = v[tn[4 * t + i]];
      const Tet4Eval e = tet4_forces(xe, ve, Xinv[t], V0[t], lambda, mu, eta[t], fe);
      acc[0] += e.strain_energy;
      if (mid[t]) {
        const real vol = dot(cross(xe[1] - xe[0], xe[2] - xe[0]), xe[3] - xe[0]) / 6;
        acc[1] += -0.5 * (e.stress.xx + e.stress.yy) * vol;
        acc[2] += vol;
      }
    });
    out.strain = te[0], out.lateral_stress_volume = te[1], out.middle_volume = te[2];
    const int* cn = ce6_nodes_.data();
    const real* h = ce6_h_.data();
    const Ce6Damage* st = dmg_.data();
    const Ce6Anchors* sl = slip_.data();
    const int* slot = ce6_slot_.data();
    const Ce6Params p = s.laws.ce6;
    // In the model's CE6 order (the host's), so that the sums agree bit for bit.
    const auto ce = Exec::template sum<7>(int(dmg_.size()), [=] FDEM_LAMBDA(int c, real* acc) {
      const int i = slot ? slot[c] : c;
      if (!own_c[i]) return;
      Vec3 xe[6], ve[6], fe[6];
      for (int j = 0; j < 6; ++j) xe[j] = x[cn[6 * i + j]], ve[j] = v[cn[6 * i + j]];
      Ce6Damage copy = st[i];  // measuring must not advance the state
      Ce6Anchors anchors = sl[i];
      const real stored = cohesive6_forces(p, xe, ve, h[i], copy, anchors.a, fe).stored;
      const int mode = st[i].mode;
      if (mode != 0) {
        acc[1] += stored;
        acc[3] += 1;
        acc[4] += mode == 1;
        acc[5] += mode == 2;
        acc[6] += mode == 3;
      } else {
        acc[0] += stored;
        acc[2] += ce6_max_damage(st[i]) > 0;
      }
    });
    out.cohesive_stored = ce[0], out.friction_stored = ce[1], out.damaged = ce[2], out.broken = ce[3];
    out.broken_I = ce[4], out.broken_II = ce[5], out.broken_mixed = ce[6];
    const PlatenLoad& platens = s.loads.platens;
    if (platens.enabled) {
      const int* pn = platen_nodes_.data();
      const real* pk = platen_k_.data();
      const Vec3* anchor = anchor_.data();
      const real ztop = platens.top_z0 - platens.top_offset, zbot = platens.bottom_z0, mu_p = platens.friction;
      out.platen_stored = Exec::template sum<1>(int(platen_nodes_.size()), [=] FDEM_LAMBDA(int i, real* acc) {
        Vec3 a = anchor[i];  // measuring must not move the anchor
        bool near_top = false;
        acc[0] += nearer_platen_force(x[pn[i]], ztop, zbot, pk[i], mu_p, a, near_top).stored;
      })[0];
    }
    if (s.contacts.enabled()) {
      const std::uint8_t* active = active_.data();
      const ContactPair* pairs = pairs_.data();
      out.active_tets = Exec::template sum<1>(
          int(active_.size()), [=] FDEM_LAMBDA(int t, real* acc) { acc[0] += active[t] == 1 && own_t[t]; })[0];
      out.contact_pairs = Exec::template sum<1>(int(pairs_.size()),
                                                [=] FDEM_LAMBDA(int k, real* acc) { acc[0] += own_t[pairs[k].a]; })[0];
    }
    t_.monitor += seconds_since(t0);
    return out;
  }

  double bytes_per_step() const override {
    const double nn = double(x_.size()), nt = double(tet_order_.size()), np = double(pairs_.size());
    const double vec = sizeof(Vec3);
    // TET4 (those this rank computes): colour-order entry, connectivity, X0^-1, V0, eta, the
    // assign mask; x and v of its 4 nodes read, f written (none where the fused pass integrates),
    // and read too where the corner does not assign (gravity: every corner; none where the fused
    // pass integrates, which starts each force itself); fused, its list of CE6s.
    const double read_f = integrates_ ? 0 : gravity_ ? 4 * nt : 4 * nt - assigned_corners_;
    const double tet = nt * (5 * sizeof(int) + sizeof(Mat3) + 2 * sizeof(real) + 1 + (integrates_ ? 2 : 3) * 4 * vec) +
                       read_f * vec + (fused_ ? nt * 4 * sizeof(int) : 0);
    // CE6 (those this rank computes, in the state as it is now): connectivity, h, damage and the
    // own flag read (the break flags: read by activation only where one broke); where it carries force, x and v of 6
    // nodes read and f read and written; where damaged (or broken and carrying force), the
    // damage written (an upper bound: only when it rises) and the anchors read and written.
    const Ce6Damage* st = dmg_.data();
    const Ce6Params p = ce6p_;
    const auto k = Exec::template sum<2>(ce6_coloured_, [=] FDEM_LAMBDA(int i, real* acc) {
      const bool carries = ce6_carries_force(p, st[i]);
      acc[0] += carries;
      acc[1] += carries && ce6_max_damage(st[i]) > 0;
    });
    double ce6 = ce6_coloured_ * (6 * sizeof(int) + sizeof(real) + sizeof(Ce6Damage) + 1) + k[0] * 6 * 4 * vec +
                 k[1] * (sizeof(Ce6Damage) + 2 * sizeof(Ce6Anchors));
    if (fused_) {
      // Fused, each side that computes the CE6: its flags read (own, damaged), and its damage
      // where the flags say damaged or broken; where it carries force, the connectivity, h and
      // 6 nodes' x and v read (its forces go to the tet's own nodes in registers: f is the
      // TET4's write above), and where damaged the anchors read and, by the writer side,
      // damage, anchors and flags written; where not (broken, inert), the writer reads the other
      // copy's damage.
      const std::uint8_t* sides = ce6_sides_.data();
      const std::uint8_t* flags = ce6_flag_.data();
      const auto e = Exec::template sum<4>(ce6_coloured_, [=] FDEM_LAMBDA(int i, real* acc) {
        const bool carries = ce6_carries_force(p, st[i]);
        acc[0] += sides[i];
        acc[1] += carries ? sides[i] : 0;
        acc[2] += carries && ce6_max_damage(st[i]) > 0 ? sides[i] : 0;
        acc[3] += flags[i] & 2 ? sides[i] : 0;
      });
      ce6 = e[0] + e[3] * sizeof(Ce6Damage) + e[1] * (6 * sizeof(int) + sizeof(real) + 6 * 2 * vec) +
            e[2] * sizeof(Ce6Anchors) + k[1] * (sizeof(Ce6Damage) + sizeof(Ce6Anchors) + 1) +
            (ce6_coloured_ - k[0]) * sizeof(Ce6Damage);
    }
    // Contact pairs: the pair, its evaluation written, its spring read and written, 8 node ids and
    // the 8 nodes' x and v, 8 forces written (narrow phase and friction in one pass); the gather
    // reads the forces; the new velocities' power reads the ids, forces and v again.
    const double con = np * (sizeof(ContactPair) + sizeof(ContactEval) + 2 * vec + 2 * 8 * sizeof(int) + 16 * vec +
                             8 * vec + 8 * vec + 16 * vec);
    // Gravity (f written from m and v) or the zeroing of the nodes no TET4 reaches; integration
    // (x, v, f, m; 1/m divided) and the kinetic-energy sum.
    const double start = gravity_ ? nn * (vec + vec + sizeof(real)) : double(unreached_.size()) * (vec + sizeof(int));
    // Where the fused pass integrates, each tet moves its own 4 nodes instead (m read, x and v
    // written to the second copies; its place in the prescribed lists) after adding what contact,
    // platens and pressure hold for it (its flags; where flagged, each node's places, and the sum
    // or force there).
    // (Static flags: 3 places per node of a flagged tet; the gather's nodes: their place, their
    // sum written by the gather and read by the pass; platen and face forces read.) The tet's
    // own x and v are read again for the step.
    const double ng = double(gather_node_.size());
    const double held = nt + double(ext_nodes_) * 3 * sizeof(int) + ng * (sizeof(int) + 2 * vec) +
                        double(platen_nodes_.size() + lat_face_.size()) * vec;
    const double mass_read = mass_from_volume_ ? 0 : sizeof(real);  // (else from V0, read for TET4)
    const double node = integrates_ ? nt * 4 * (4 * vec + mass_read + (fixed_of_.size() ? sizeof(int) : 0)) + held
                                    : start + nn * (5 * vec + sizeof(real));
    return tet + ce6 + con + node;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static Clock::time_point now() { return Clock::now(); }
  static double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }
  /// Adds the time since t0 to `into` (after waiting for the device when timing) and restarts.
  Clock::time_point lap(Clock::time_point t0, double& into) const {
    if (timing_) Exec::synchronize();
    const auto t1 = now();
    into += std::chrono::duration<double>(t1 - t0).count();
    return t1;
  }

 public:  // (nvcc's device lambdas cannot live in private member functions)
  /// Zero sums_[from, to) on the device.
  void clear_sums(int from, int to) {
    real* p = sums_.data();
    Exec::forall(to - from, [=] FDEM_LAMBDA(int k) { p[from + k] = 0; });
  }

  /// The array the passes use for host data h (n elements): h itself on the cpu backend, which
  /// works in place, else a copy in the backend's memory. (The passes write only the state's.)
  template <class T>
  void place(DeviceArray<T>& d, const T* h, std::size_t n) {
    if (b_ == Backend::cpu)
      d.borrow(const_cast<T*>(h), n);
    else
      d.upload(h, n);
  }
  template <class T>
  void place(DeviceArray<T>& d, const std::vector<T>& h) {
    place(d, h.data(), h.size());
  }

  /// The fused pass's lists to the device (the plan made with the loop; the model's
  /// colourings, and so the plan, stay as they are for the loop's life).
  void plan_fused() {
    if (!fused_) return;
    if (plan_.sides.size() > ce6_perm_.size())
      throw RunError("device loop: the fused element pass's plan does not match the model");
    plan_.sides.resize(ce6_perm_.size(), 0);  // the CE6s no colour holds: not computed here
    fused_ce6_.upload(plan_.list);
    ce6_sides_.upload(plan_.sides);
    plan_ = FusedPlan{};
  }

  /// TET4 colour by colour, then CE6 colour by colour (stored in colour order: slot b + k; no two
  /// elements of a colour share a node), each colour one launch; t0: the passes' clock.
  void colour_forces(const Model& m, real lambda, real mu, real* sums, Clock::time_point& t0) {
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    Vec3* f = f_.data();
    const int* tn = tet_nodes_.data();
    const int* torder = tet_order_.data();
    const Mat3* Xinv = Xinv_.data();
    const real* V0 = V0_.data();
    const real* eta = eta_.data();
    const std::uint8_t* assigns = gravity_ ? nullptr : tet_assigns_.data();
    const std::uint8_t* own_t = own_tet_.data();
    for (int c = 0; c < m.tet_colours.colours(); ++c) {
      const int b = m.tet_colours.offsets[c], e = m.tet_colours.offsets[c + 1];
      Exec::template sum_to<2>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int t = torder[b + k];
            const int* q = tn + 4 * t;
            Vec3 xe[4], ve[4], fe[4];
            for (int i = 0; i < 4; ++i) xe[i] = x[q[i]], ve[i] = v[q[i]];
            device_pass::tet4_element(xe, ve, Xinv[t], V0[t], lambda, mu, eta[t], own_t[t], acc, fe);
            device_pass::tet4_start(f, q, assigns ? assigns[t] : 0, fe);
            for (int i = 0; i < 4; ++i) f[q[i]] = fe[i];
          },
          sums + kVisc);
    }
    t0 = lap(t0, t_.tet4);
    const int* cn = ce6_nodes_.data();
    const real* h = ce6_h_.data();
    Ce6Damage* st = dmg_.data();
    Ce6Anchors* sl = slip_.data();
    std::uint8_t* broke = broke_.data();
    const std::uint8_t* own_c = own_ce6_.data();
    const Ce6Params p = ce6p_;
    for (int c = 0; c < m.ce6_colours.colours(); ++c) {
      const int b = m.ce6_colours.offsets[c], e = m.ce6_colours.offsets[c + 1];
      Exec::template sum_to<3>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int i = b + k;
            if (!ce6_carries_force(p, st[i])) return;  // broken, its faces left to contact
            const int* q = cn + 6 * i;
            Vec3 xe[6], ve[6], fe[6];
            for (int j = 0; j < 6; ++j) xe[j] = x[q[j]], ve[j] = v[q[j]];
            device_pass::ce6_element(p, xe, ve, h[i], st[i], sl[i].a, true, own_c[i], acc, broke + i, fe);
            for (int j = 0; j < 6; ++j) f[q[j]] += fe[j];
          },
          sums + kCoh);
    }
    t0 = lap(t0, t_.ce6);
  }

  /// What the fused pass does with each tet's forces (fused_pass).
  enum PassMode { kForces, kStep, kComplete };

  /// TET4 and CE6 forces in one pass over the computed tets: each tet's TET4, then each CE6 on
  /// its faces in colour order, every CE6 evaluated by both of its tets from the damage and
  /// anchors at the start of the pass (dmg_, slip_), each adding only to its own nodes, in the
  /// same order of sums as the colour passes (the same bits). One side, the writer, keeps the
  /// new damage and anchors (dmg_next_, slip_next_: written for every damaged CE6, so the pair
  /// stays current where it matters; undamaged, both copies hold the intact state), its powers
  /// and its break; then the copies swap.
  ///   kForces: f written once per node and never read (without gravity).
  ///   kStep (DeviceLoop::integrates): the evaluation compute_forces left at this state; each
  ///   node's force also takes what contact, platens and pressure put there (held for the pass,
  ///   in the colour passes' order of sums), and the tet moves its nodes by the step advance()
  ///   left pending, into the second copies of x and v (the other tets still read the first),
  ///   with the integration's sums; then x and v swap. No force array is written or read.
  ///   kComplete: the same without the step: f gets each node's whole force.
  ///   before_add: run once before the pass's sums are added (in the same launch; sum_to).
  template <int kMode, class Before = NoEpilogue>
  void fused_pass(const Model& m, real lambda, real mu, real* sums, Before before_add = {}) {
    constexpr bool kOwn = kMode != kForces;  // the pass starts and ends each node's force
    const int nk = int(m.tet_colours.order.size());
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    Vec3* f = f_.data();
    Vec3* x_new = kMode == kStep ? x2_.data() : nullptr;
    Vec3* v_new = kMode == kStep ? v2_.data() : nullptr;
    const device_pass::NodeStep mover{mass_.data(), fixed_of_.size() ? fixed_of_.data() : nullptr, fixed_mask_.data(),
                                      fixed_v_.data(), step_dt_};
    const real* mass = mass_.data();
    const int* tn = tet_nodes_.data();
    const int* torder = tet_order_.data();
    const Mat3* Xinv = Xinv_.data();
    const real* V0 = V0_.data();
    const real* eta = eta_.data();
    const std::uint8_t* assigns = gravity_ ? nullptr : tet_assigns_.data();
    const std::uint8_t* own_t = own_tet_.data();
    const int* list = fused_ce6_.data();
    const int* cn = ce6_nodes_.data();
    const real* h = ce6_h_.data();
    const Ce6Damage* dr = dmg_.data();
    const Ce6Anchors* sr = slip_.data();
    Ce6Damage* dw = dmg_next_.data();
    Ce6Anchors* sw = slip_next_.data();
    const std::uint8_t* flr = ce6_flag_.data();  // own, damaged (upload())
    std::uint8_t* flw = ce6_flag_next_.data();
    std::uint8_t* broke = broke_.data();
    const Ce6Params p = ce6p_;
    const bool gravity = gravity_;
    const Vec3 g = g_;
    // kOwn: each node's mass rho V0 / 4 where every node's is (mass_from_volume_), else read.
    const real rho = node_density_;
    const bool from_volume = kOwn && mass_from_volume_;
    // The forces held for the pass (kOwn): per tet its flags, per node its places.
    const std::uint8_t* ext = kOwn ? ext_tet_.data() : nullptr;
    const int* gof = gather_of_.data();
    const int* pof = platen_of_.data();
    const int* lof = lateral_of_.data();
    const Vec3* csum = contact_sum_.data();
    const Vec3* pforce = platen_force_.data();
    const int* lp = lat_ptr_.data();
    const int* lfa = lat_face_.data();
    const Vec3* lforce = lat_force_.data();
    // The sums: kVisc to kBreaks; kOwn, kGravity before them; kStep, kBad, kKinetic2 and
    // kGravityNew after (base: the element passes' first).
    static_assert(kGravity == kVisc - 1 && kInverted == kVisc + 1 && kCoh == kVisc + 2 && kFric == kVisc + 3 &&
                      kBreaks == kVisc + 4 && kBad == kVisc + 5 && kKinetic2 == kVisc + 6 && kGravityNew == kVisc + 7,
                  "the fused pass sums into consecutive slots");
    constexpr int base = kOwn ? 1 : 0;
    constexpr int kN = kMode == kStep ? 9 : kOwn ? 6 : 5;
    const auto body = [=] FDEM_LAMBDA(int k, real* acc) {
      const int t = torder[k];
      const int* q = tn + 4 * t;
      const real tet_mass = from_volume ? rho * V0[t] / 4 : 0;  // each node's (kOwn)
      Vec3 xe[4], ve[4], fe[4], start[4];
      for (int i = 0; i < 4; ++i) {
        const int n = q[i];
        xe[i] = x[n], ve[i] = v[n];
        if (kOwn) {  // the force starts with gravity (compute_forces' gravity pass), or at zero
          start[i] = gravity ? (from_volume ? tet_mass : mass[n]) * g : Vec3{0, 0, 0};
          if (gravity) acc[0] += dot(start[i], ve[i]);  // (one rank: every node owned)
        }
      }
      device_pass::tet4_element(xe, ve, Xinv[t], V0[t], lambda, mu, eta[t], own_t[t], acc + base, fe);
      if (kOwn)
        for (int i = 0; i < 4; ++i) fe[i] = start[i] + fe[i];
      else
        device_pass::tet4_start(f, q, assigns ? assigns[t] : 0, fe);
      for (int j = 0; j < 4; ++j) {
        const int code = list[4 * k + j];
        if (code < 0) break;
        const int c = code >> 2, side = code >> 1 & 1;
        const bool writer = code & 1;
        const std::uint8_t fl = flr[c];
        Ce6Damage d = fl & 2 ? dr[c] : Ce6Damage{};  // intact: its 32 bytes not read
        if (!ce6_carries_force(p, d)) {              // broken, its faces left to contact: its state is
          // frozen, so once the other copy holds the break too the two are the same
          if (writer && dw[c].mode != d.mode) dw[c] = d, sw[c] = sr[c], flw[c] = fl;
          continue;
        }
        Ce6Anchors an{};
        if (ce6_max_damage(d) > 0) an = sr[c];  // damaged or broken: anchors kept
        const int* cq = cn + 6 * c;
        Vec3 xc[6], vc[6], fc[6];
        for (int i = 0; i < 6; ++i) xc[i] = x[cq[i]], vc[i] = v[cq[i]];
        device_pass::ce6_element(p, xc, vc, h[c], d, an.a, writer, fl & 1, acc + base + 2, broke + c, fc);
        for (int i = 0; i < 3; ++i) {  // constant indices only: the arrays stay in registers
          const int n = side ? cq[3 + i] : cq[i];
          const Vec3 add = side ? fc[3 + i] : fc[i];
          for (int a = 0; a < 4; ++a)
            if (q[a] == n) fe[a] += add;
        }
        if (writer && ce6_max_damage(d) > 0) dw[c] = d, sw[c] = an, flw[c] = std::uint8_t(fl | 2);
      }
      if (kOwn && ext[t]) {  // contact's sum, the platen's force, the pressure's faces
        for (int i = 0; i < 4; ++i) {
          const int n = q[i];
          if (ext[t] & 1) {
            const int gi = gof[n];
            if (gi >= 0) fe[i] += csum[gi];
          }
          if (ext[t] & 2) {
            const int pi = pof[n];
            if (pi >= 0) fe[i] += pforce[pi];
            const int li = lof[n];
            if (li >= 0)
              for (int jj = lp[li]; jj < lp[li + 1]; ++jj) fe[i] += lforce[lfa[jj]];
          }
        }
      }
      if (kMode == kStep) {  // advance()'s sums: m v.v before the prescription, gravity's power after
        for (int i = 0; i < 4; ++i) {
          const int n = q[i];
          Vec3 xn = x[n], vn = v[n];  // read again (from cache): fewer registers held over the CE6s
          const real mn = from_volume ? tet_mass : mass[n];
          mover.move_with(mn, xn, vn, fe[i]);
          acc[6] += !finite_value(vn.x + vn.y + vn.z);
          acc[7] += mn * dot(vn, vn);
          mover.prescribe(n, xn, vn);
          x_new[n] = xn, v_new[n] = vn;
          if (gravity) acc[8] += mn * dot(g, vn);
        }
      } else {
        for (int i = 0; i < 4; ++i) f[q[i]] = fe[i];
      }
    };
    if (blocks_ == 2)  // (the CUDA kernel compiled for two resident blocks: DeviceLoop::blocks_per_sm)
      Exec::template sum_to<kN, 2>(nk, body, sums + kVisc - base, before_add);
    else
      Exec::template sum_to<kN>(nk, body, sums + kVisc - base, before_add);
    std::swap(dmg_, dmg_next_);
    std::swap(slip_, slip_next_);
    std::swap(ce6_flag_, ce6_flag_next_);
    if constexpr (kMode == kStep) {
      std::swap(x_, x2_);
      std::swap(v_, v2_);
      step_pending_ = elements_pending_ = false;
    }
  }

  /// Between the CE6 state in id order (dmg_model_, slip_model_) and in slots (dmg_, slip_):
  /// into the slots when `to_slots`, out of them otherwise (several ranks).
  void ce6_between_orders(bool to_slots) {
    Ce6Damage* dm = dmg_model_.data();
    Ce6Anchors* am = slip_model_.data();
    Ce6Damage* d = dmg_.data();
    Ce6Anchors* a = slip_.data();
    const int* slot = ce6_slot_.data();
    Exec::forall(int(dmg_model_.size()), [=] FDEM_LAMBDA(int i) {
      const int k = slot[i];
      if (to_slots)
        d[k] = dm[i], a[k] = am[i];
      else
        dm[i] = d[k], am[i] = a[k];
    });
  }

 private:
  /// The array of a per-CE6 host array h in the device's slot order: h's own where the slots
  /// are the ids (place()), else a copy reordered.
  template <class T, class H>
  void place_in_slots(DeviceArray<T>& d, const std::vector<H>& h) {
    static_assert(sizeof(H) % sizeof(T) == 0, "whole elements");
    constexpr std::size_t k = sizeof(H) / sizeof(T);
    if (ce6_by_id_)
      place(d, reinterpret_cast<const T*>(h.data()), k * h.size());
    else
      d.upload(reinterpret_cast<const T*>(in_slots(h).data()), k * h.size());
  }
  /// A per-CE6 host array in the device's slot order.
  template <class T>
  std::vector<T> in_slots(const std::vector<T>& by_model) const {
    std::vector<T> out(ce6_perm_.size());
    for (std::size_t k = 0; k < out.size(); ++k) out[k] = by_model[ce6_perm_[k]];
    return out;
  }

  /// sums_[0, N) on the host (one copy).
  template <int N>
  std::array<real, N> read_sums() const {
    static_assert(N <= kAll, "beyond the sums");
    std::array<real, N> out;
    device::to_host(b_, out.data(), sums_.data(), N * sizeof(real));
    return out;
  }

  void upload_pairs(const ContactSet& c) {
    contact_arrays(c, [&](auto& d, const auto& h) { place(d, h); });
    springs_in_place(c);
  }

  /// f(the loop's array, the ContactSet's vector) for each contact array both hold.
  template <class Set, class F>
  void contact_arrays(Set& c, F&& f) {
    f(pairs_, c.pairs), f(spring_, c.spring), f(eval_, c.eval), f(pair_force_, c.pair_force);
    f(gather_node_, c.gather_node), f(gather_ptr_, c.gather_ptr), f(gather_slot_, c.gather_slot);
    f(watch_nodes_, c.watch_nodes), f(watch_x_, c.watch_x);
  }

  /// Cpu backend: the contact pass updates each pair's spring where it reads it (next_spring_
  /// is spring_), which is safe because a pair reads and writes only its own. Not where the
  /// fused pass integrates: that schedule may run the pairs twice in one evaluation, so it keeps
  /// the springs from before the first run apart, in a next_spring_ of the loop's own (one that
  /// still borrows a vector lets go: the vector may have moved).
  void springs_in_place(const ContactSet& c) {
    if (b_ != Backend::cpu) return;
    if (integrates_)
      next_spring_.release();
    else
      place(next_spring_, c.spring);
  }

  /// Cpu backend, after a rebuild made the contact arrays in the loop's own memory: they move
  /// into the ContactSet's vectors, which the loop then works on in place (one copy per rebuild,
  /// none per step, and the contact state held once).
  void contact_in_place(ContactSet& c) {
    if (b_ != Backend::cpu) return;
    contact_arrays(c, [](auto& d, auto& h) {
      if (d.data() != h.data()) h.assign(d.data(), d.data() + d.size());
      d.borrow(h);
    });
    springs_in_place(c);
    pairs_on_host_ = true;
  }

  /// Cpu backend, before a rebuild: the arrays it makes anew let go of the ContactSet's vectors
  /// (the old pairs and springs stay borrowed: the rebuild reads them to carry the springs over).
  /// Those vectors are not read again before the new arrays move in (contact_in_place): freed
  /// now, so that the old and the new are not held together.
  void contact_apart_for_rebuild(ContactSet& c) {
    if (b_ != Backend::cpu) return;
    auto release = [](auto&... a) { (a.release(), ...); };
    release(next_spring_, eval_, pair_force_, gather_node_, gather_ptr_, gather_slot_, watch_nodes_, watch_x_);
    auto free_all = [](auto&... h) { ((std::remove_reference_t<decltype(h)>{}.swap(h)), ...); };
    free_all(c.eval, c.pair_force, c.gather_node, c.gather_ptr, c.gather_slot, c.watch_nodes, c.watch_x);
  }

 public:  // (public: nvcc's device lambdas cannot live in private member functions)
  /// One launch: with `flags` (the CE6 slots), adaptive activation: the vicinity of each CE6 whose
  /// break flag is up (every tet sharing a vertex of its face) joins the contact candidates and
  /// the flag goes down (kAdded counts the tets added, which marks the set dirty with the
  /// evaluation's sums); with `watch` and contact, the broad phase's watch (kMoved: nodes of active
  /// tets that moved half the buffer since the list was built). Flags only rise, each with one
  /// atomic operation (raise_flag), so a tet at the vertices of several breaking CE6s is raised
  /// and counted once, whatever the iterations' order.
  void activate(const ContactSet& cs, int flags, bool watch) {
    const bool on = cs.enabled();
    const int nw = watch && on ? int(watch_nodes_.size()) : 0;
    const int* cn = ce6_nodes_.data();
    const int* nv = node_vertex_.data();
    const int* vptr = vt_ptr_.data();
    const int* vtets = vt_tets_.data();
    std::uint8_t* broke = broke_.data();
    std::uint8_t* active = active_.data();
    const int* wn = watch_nodes_.data();
    const Vec3* wx = watch_x_.data();
    const Vec3* x = x_.data();
    const real lim2 = 0.25 * cs.buffer() * cs.buffer();
    static_assert(kMoved == kAdded + 1, "the activation's and the watch's counts");
    Exec::template sum_to<2>(
        flags + nw,
        [=] FDEM_LAMBDA(int i, real* acc) {
          if (i >= flags) {
            const Vec3 d = x[wn[i - flags]] - wx[i - flags];
            if (dot(d, d) > lim2) acc[1] += 1;
            return;
          }
          if (!broke[i]) return;
          broke[i] = 0;
          if (!on) return;
          for (int j = 0; j < 3; ++j) {
            const int vtx = nv[cn[6 * i + j]];
            for (int k = vptr[vtx]; k < vptr[vtx + 1]; ++k)  // (a tet two broken CE6s share: raised once)
              if (raise_flag(active + vtets[k])) acc[0] += 1;
          }
        },
        sums_.data() + kAdded);
  }

  /// Where the fused pass integrates: `into`, each node of the gather list gets its place in it
  /// (gather_of_) and the tets their flags (ext_tet_: bit 0 where a node is listed, bit 1 as
  /// ext_static_); otherwise the listed nodes leave (before the list changes).
  void follow_gather(bool into) {
    const int* gn = gather_node_.data();
    int* of = gather_of_.data();
    Exec::forall(int(gather_node_.size()), [=] FDEM_LAMBDA(int k) { of[gn[k]] = into ? k : -1; });
    if (!into) return;
    contact_sum_.resize(gather_node_.size());
    const int* tn = tet_nodes_.data();
    const std::uint8_t* fixed = ext_static_.data();
    std::uint8_t* ext = ext_tet_.data();
    Exec::forall(int(ext_tet_.size()), [=] FDEM_LAMBDA(int t) {
      const int* q = tn + 4 * t;
      const bool listed = of[q[0]] >= 0 || of[q[1]] >= 0 || of[q[2]] >= 0 || of[q[3]] >= 0;
      ext[t] = std::uint8_t(fixed[t] | (listed ? 1 : 0));
    });
  }

  /// The contact candidate list (the passes of contact/broad_phase.cpp's find_box_pairs, which
  /// test_broad_phase holds to a brute-force search: bounds, count, scan, fill, sort, runs, pair
  /// test), with the filters (a joining CE6, shared nodes), springs carried over by (a, b), the
  /// gather index and the watch list. Only counts come back to the host.
  void rebuild_pairs(const LoopParts& s) {
    ContactSet& cs = s.contacts;
    contact_apart_for_rebuild(cs);
    CandidateInputs in;
    in.tets = int(V0_.size()), in.nodes = int(x_.size());
    in.x = x_.data(), in.tet_nodes = tet_nodes_.data(), in.active = active_.data();
    in.tet_global = tet_global_.size() > 0 ? tet_global_.data() : nullptr;
    in.own_node = s.layout.distributed() ? own_node_.data() : nullptr;
    in.tet_ce6 = tet_ce6_.data(), in.ce6_tets = ce6_tets_.data(), in.buffer = cs.buffer();
    const BroadPhaseStats st = candidates_.find_pairs(in, next_pairs_);
    candidates_.carry_springs(in, pairs_, spring_, next_pairs_, next_spring_);
    const long grown_before = pairs_.times_grown() + pair_force_.times_grown();
    std::swap(pairs_, next_pairs_);
    std::swap(spring_, next_spring_);
    eval_.resize(st.pairs);
    pair_force_.resize(8 * st.pairs);
    t_.pair_growth += pairs_.times_grown() + pair_force_.times_grown() - grown_before;
    candidates_.gather_index(in, pairs_, gather_node_, gather_ptr_, gather_slot_);
    candidates_.watch_list(in, watch_nodes_, watch_x_);
    cs.rebuild_due = false;
    ++cs.times.rebuilds;
    cs.last_build = st;
    pairs_on_host_ = false;
    if (b_ == Backend::cpu) {  // (CandidateBuild::release_scratch)
      candidates_.release_scratch();
      next_pairs_.release();
      contact_in_place(cs);
    }
  }

  /// Several ranks: ghost nodes take their owners' x and v (HaloPasses::update_nodes).
  void halo_update(const LoopParts& s) { halo_.update_nodes(*s.layout.halo, x_, v_, s.layout.halo_seconds); }

  /// Contact on the candidate list: one launch per pair (the narrow phase, friction, the pair's
  /// forces written once, and their power with the velocities now; its sums to kTouching to
  /// kConPower), then (`gather`) the deterministic per-node sum into f, or where the fused pass
  /// integrates into the held contact_sum_ (there, for pairs queued ahead with platens, in the
  /// platens' launch instead: compute_forces). The springs are read from spring_ and written to
  /// next_spring_, which becomes the state when the caller swaps them: a pass queued ahead of a
  /// rebuild (compute_forces) leaves the springs the rebuild carries over untouched.
  void contact_pairs(const LoopParts& s, Clock::time_point& t0, bool gather) {
    const ContactSet& cs = s.contacts;
    const int np = int(pairs_.size());
    next_spring_.resize(np);
    const ContactPair* pairs = pairs_.data();
    const int* tn = tet_nodes_.data();
    const int* slot = ce6_slot_.data();
    const Ce6Damage* st = dmg_.data();  // after a fused pass: the copy it wrote
    // Where the fused pass integrates, the break flags up now are an earlier evaluation's (its
    // pass computes the elements of the last one): not read.
    const std::uint8_t* fresh = integrates_ ? nullptr : broke_.data();
    const std::uint8_t* own_t = own_tet_.data();
    const std::uint8_t* own_n = own_node_.data();
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    ContactEval* ev = eval_.data();
    Vec3* pf = pair_force_.data();
    const Vec3* spring_in = spring_.data();
    Vec3* spring_out = next_spring_.data();
    const real P = cs.penalty(), mu_rock = cs.friction(), dt = s.dt;
    static_assert(kConDiss == kTouching + 1 && kConStored == kTouching + 2 && kConPower == kTouching + 3,
                  "the contact pass's sums");
    Exec::template sum_to<4>(
        np,
        [=] FDEM_LAMBDA(int k, real* acc) {
          const ContactPair cp = pairs[k];
          int na[4], nb[4];
          for (int i = 0; i < 4; ++i) na[i] = tn[4 * cp.a + i], nb[i] = tn[4 * cp.b + i];
          Vec3 fa[4], fb[4];  // the normal forces, then friction's added
          // A joint broken in this evaluation (its flag still up) still holds its faces.
          const int js = slot && cp.joint >= 0 ? slot[cp.joint] : cp.joint;
          bool pushes = false;  // some force not zero: only then has the pair a power
          if (js >= 0 && (!ce6_broken(st[js]) || (fresh && fresh[js]))) {
            for (int i = 0; i < 4; ++i) fa[i] = fb[i] = Vec3{0, 0, 0};
            ev[k] = ContactEval{{0, 0, 0}, {0, 0, 0}, 0};
            spring_out[k] = Vec3{0, 0, 0};
          } else {
            Vec3 xa[4], xb[4];
            for (int i = 0; i < 4; ++i) xa[i] = x[na[i]], xb[i] = x[nb[i]];
            const ContactEval e = contact_tet_pair(xa, xb, P, fa, fb);
            ev[k] = e;
            for (int i = 0; i < 4; ++i) pushes = pushes || !is_zero(fa[i]) || !is_zero(fb[i]);
            if (!(e.weight > 0)) {
              spring_out[k] = Vec3{0, 0, 0};
            } else {
              pushes = true;
              if (own_t[cp.a]) acc[0] += 1;
              Vec3 va[4], vb[4], ga[4], gb[4];
              for (int i = 0; i < 4; ++i) {
                va[i] = v[na[i]], vb[i] = v[nb[i]];
                ga[i] = gb[i] = Vec3{0, 0, 0};
              }
              const real k_t = contact_tangential_stiffness(xa, xb, P);
              Vec3 spring = spring_in[k];
              const real d = contact_friction(xa, xb, va, vb, e, mu_rock, k_t, dt, spring, ga, gb);
              spring_out[k] = spring;
              if (own_t[cp.a]) {
                acc[1] += d;
                acc[2] += 0.5 * k_t * dot(spring, spring);
              }
              for (int i = 0; i < 4; ++i) fa[i] += ga[i], fb[i] += gb[i];
            }
          }
          Vec3* fp = pf + 8 * k;
          for (int i = 0; i < 4; ++i) fp[i] = fa[i], fp[4 + i] = fb[i];
          // (A pair without force adds -0 to the power, which leaves every sum as it is.)
          if (pushes) device_pass::subtract_pair_power(fa, fb, na, nb, v, own_n, acc[3]);
        },
        sums_.data() + kTouching);
    t0 = lap(t0, t_.narrow);
    if (!gather) return;
    const int* gn = gather_node_.data();
    const int* gp = gather_ptr_.data();
    const int* gs = gather_slot_.data();
    Vec3* f = f_.data();
    Vec3* held = integrates_ ? contact_sum_.data() : nullptr;  // (for the pass that steps)
    Exec::forall(int(gather_node_.size()), [=] FDEM_LAMBDA(int k) {
      const Vec3 sum = device_pass::pair_forces_at(gp, gs, pf, k);
      if (held)
        held[k] = sum;
      else
        f[gn[k]] += sum;
    });
    t0 = lap(t0, t_.contact_sum);
  }

  /// The powers of the last contact pair forces (-sum f.v, ContactSet::power) and confining
  /// pressure forces with the velocities now, added to kConPowerNew and kPressurePowerNew in
  /// one launch (the pairs, then the faces); with `watch`, the broad phase's watch too (the
  /// watched nodes after them: those that moved half of watch->buffer() since the list was
  /// built, counted into kWatched; where the fused pass steps, this saves the watch a launch).
  void contact_pressure_powers(bool contact, bool pressure, const ContactSet* watch = nullptr) {
    const int np = contact ? int(pairs_.size()) : 0, nf = pressure ? int(lat_force_.size()) : 0;
    const int nw = watch ? int(watch_nodes_.size()) : 0;
    const int* wn = watch_nodes_.data();
    const Vec3* wx = watch_x_.data();
    const Vec3* x = x_.data();
    const real lim2 = watch ? 0.25 * watch->buffer() * watch->buffer() : 0;
    const Vec3* v = v_.data();
    const int* tn = tet_nodes_.data();
    const ContactPair* pairs = pairs_.data();
    const Vec3* pf = pair_force_.data();
    const int* lf = lat_faces_.data();
    const Vec3* lforce = lat_force_.data();
    const std::uint8_t* own_n = own_node_.data();
    static_assert(kPressurePowerNew == kConPowerNew + 1 && kWatched == kConPowerNew + 2, "the new powers' slots");
    Exec::template sum_to<3>(
        np + nf + nw,
        [=] FDEM_LAMBDA(int k, real* acc) {
          if (k >= np + nf) {
            const int i = k - np - nf;
            const Vec3 d = x[wn[i]] - wx[i];
            if (dot(d, d) > lim2) acc[2] += 1;
            return;
          }
          if (k >= np) {
            const int i = k - np;
            device_pass::add_face_power(lforce[i], lf + 3 * i, v, own_n, acc[1]);
            return;
          }
          const Vec3* fp = pf + 8 * k;
          int na[4], nb[4];
          Vec3 fa[4], fb[4];
          bool pushes = false;  // (a pair without force adds -0: skipped, the same sum)
          for (int i = 0; i < 4; ++i) {
            fa[i] = fp[i], fb[i] = fp[4 + i];
            pushes = pushes || !is_zero(fa[i]) || !is_zero(fb[i]);
          }
          if (!pushes) return;
          for (int i = 0; i < 4; ++i) na[i] = tn[4 * pairs[k].a + i], nb[i] = tn[4 * pairs[k].b + i];
          device_pass::subtract_pair_power(fa, fb, na, nb, v, own_n, acc[0]);
        },
        sums_.data() + kConPowerNew);
  }

 private:
  LoopParts p_;  // the run the loop steps
  Backend b_;
  bool constants_ = false, timing_ = false;
  // The last force evaluation's scalars are in sums_ [0, kBad) and not yet in the Solver.
  bool forces_pending_ = false;
  // One rank: a step's integration sums are on the device, its bookkeeping not yet done.
  bool advance_pending_ = false;
  bool pairs_on_host_ = true;  // the host ContactSet holds the current pair list and indices
  // The candidate list's build (its scratch kept between builds on a GPU) and what it reads.
  CandidateBuild<Exec> candidates_;
  DeviceArray<long> tet_global_;  // several ranks with contact: pairs in global order (rebuild_pairs)
  DeviceArray<int> tet_ce6_, ce6_tets_;
  // Several ranks: the halo exchanges (HaloPasses).
  HaloPasses<Exec> halo_;
  bool direct_mpi_;            // device buffers straight to MPI (partition/halo.hpp), fixed at construction
  bool flags_merged_ = false;  // false from an upload of the host's flags to the next merge
  bool merge_wanted_ = false;  // several ranks: a rank raised a flag (the step's reduction said)
  // Several ranks: the last force evaluation's sums on this rank, read with the integration's and
  // waiting for the step's reduction (take_reduced); on the hydrostatic path, its platen
  // reactions summed over the ranks (compute_forces).
  std::array<real, kBad> waiting_{};
  std::array<real, 2> reactions_{};
  // The sums that the whole model sums over the ranks (the others are each rank's own).
  static constexpr std::array<int, 9> kWhole = {kTop,  kBottom,  kPlatenFric, kVisc,    kCoh,
                                                kFric, kConDiss, kConStored,  kTouching};
  DeviceArray<ContactPair> next_pairs_;
  DeviceArray<Vec3> next_spring_;
  DeviceTimes t_;
  DeviceArray<int> tet_nodes_, tet_order_, ce6_nodes_, ce6_slot_, platen_nodes_, fixed_node_, fixed_mask_, lat_faces_,
      lat_ptr_, lat_face_, lat_node_, node_vertex_, vt_ptr_, vt_tets_, watch_nodes_, gather_node_, gather_ptr_,
      gather_slot_, lateral_nodes_;
  DeviceArray<Mat3> Xinv_;
  DeviceArray<real> V0_, eta_, ce6_h_, mass_, platen_k_, sums_;
  DeviceArray<Vec3> X_, plan_x_, x_, v_, f_, anchor_, fixed_v_, lat_force_, watch_x_, spring_, pair_force_;
  // CE6 arrays (nodes, h, damage, anchors, flags) are in slot order: slot k holds model CE6
  // ce6_perm_[k]; ce6_slot_ maps back.
  DeviceArray<Ce6Damage> dmg_;
  DeviceArray<Ce6Anchors> slip_;
  // The fused element pass (plan_fused): per computed tet (launch order) its CE6 entries, the
  // computed sides of each CE6 (the traffic model), and the copies of the damage and anchors it
  // writes while reading dmg_ and slip_ (swapped after it).
  bool fused_ = false;
  bool integrates_ = false;        // the fused pass integrates too (FusedPlan::integrate)
  bool mass_from_volume_ = false;  // every node's mass node_density_ V0 / 4 of its one tet, to the bit
  real node_density_ = 0;          // kg/m^3 (mass scaling included)
  int blocks_ = 1;                 // resident blocks per multiprocessor of the fused pass's kernels
  FusedPlan plan_;                 // until the first upload
  DeviceArray<int> fused_ce6_;
  DeviceArray<std::uint8_t> ce6_sides_;
  DeviceArray<Ce6Damage> dmg_next_;
  // Per CE6 slot, for the fused pass: bit 0 its own flag, bit 1 a damage state other than the
  // intact one (the pass reads dmg_ only there); two copies, as the damage's.
  DeviceArray<std::uint8_t> ce6_flag_, ce6_flag_next_;
  DeviceArray<Ce6Anchors> slip_next_;
  // Where the fused pass integrates (integrates_): the step advance() left to it (step_pending_,
  // step_dt_); the last evaluation's element part left to that pass (elements_pending_); the
  // second copies of x and v it writes (swapped after it); each node's place in the prescribed
  // lists (empty without prescribed nodes), and what materialize() needs. The forces that
  // contact, platens and pressure put on a node wait for the pass in arrays of their own:
  // per node its place in the gather list (gather_of_, -1: none; the pair forces' sum in
  // contact_sum_), in the platen nodes (platen_of_; platen_force_) and in the pressure's node
  // list (lateral_of_; lat_force_ by lat_ptr_), read only for the tets flagged in ext_tet_
  // (bit 0: a node in the gather list, bit 1: on a platen or a lateral face; ext_static_).
  bool step_pending_ = false, step_contact_ = false, step_pressure_ = false, elements_pending_ = false;
  long ext_nodes_ = 0;  // nodes of the tets ext_static_ flags (the traffic model)
  real step_dt_ = 0;
  DeviceArray<Vec3> x2_, v2_, contact_sum_, platen_force_;
  DeviceArray<int> fixed_of_, gather_of_, platen_of_, lateral_of_;
  DeviceArray<std::uint8_t> ext_tet_, ext_static_;
  // Upload and download only: the host's layout and order. Kept between copies, so that a
  // copy allocates nothing (104 B per CE6 more device memory held; the peak is the same as
  // allocating it for each copy).
  DeviceArray<Ce6Damage> dmg_model_;  // the CE6 state in id order, for the copies (slots not by id)
  DeviceArray<Ce6Anchors> slip_model_;
  bool ce6_by_id_ = false;  // CE6 slot k is CE6 k (one rank): no slot map, no reordered copies
  std::vector<int> ce6_perm_;
  int ce6_coloured_ = 0;  // slots [0, ce6_coloured_) are in the colours (computed on this rank)
  Ce6Params ce6p_{};
  DeviceArray<std::uint8_t> broke_, active_, mid_third_, own_node_, own_tet_, own_ce6_, tet_assigns_;
  DeviceArray<int> unreached_;
  double assigned_corners_ = 0;  // set bits of tet_assigns_
  bool gravity_ = false;
  Vec3 g_{0, 0, 0};  // m/s^2
  DeviceArray<ContactPair> pairs_;
  DeviceArray<ContactEval> eval_;
};

}  // namespace fdem
