#pragma once
// The element passes of the device loop, on any Exec (core/forall.hpp): TET4 and CE6 forces,
// colour by colour or fused in one pass over the tets (plan_fused_pass), which may also step
// the nodes. This part owns the elements' constants and the CE6 state (damage, anchors, break
// flags) in slot order.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "core/forall.hpp"
#include "loads/gravity.hpp"
#include "loads/prescribed.hpp"
#include "loads/surface_loads.hpp"
#include "model/laws.hpp"
#include "physics/cohesive6.hpp"
#include "physics/tet4.hpp"
#include "solver/device_loop.hpp"
#include "solver/loop_sums.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

namespace device_pass {
/// A TET4's forces on its nodes at xe, ve (fe), the inverted count into acc[1] and, for an owned
/// tet, its viscous power into acc[0]: the element of both schedules' TET4 passes.
FDEM_HD void tet4_element(const Vec3 (&xe)[4], const Vec3 (&ve)[4], const Mat3& Xinv, real V0, real lambda, real mu,
                          real eta, const Sym3* S0, bool own, real* acc, Vec3 (&fe)[4]) {
  const Tet4Eval ev = tet4_forces(xe, ve, Xinv, V0, lambda, mu, eta, fe, S0);
  if (!(ev.J > 0) && mu > 0) acc[1] += 1;  // (an excavated tet has no stiffness and may fold)
  if (own) acc[0] += ev.viscous_power;
}
/// A TET4's first force at its corners: assigned where `first` has the corner's bit, else added.
FDEM_HD void tet4_start(const Vec3* f, const int* q, int first, Vec3 (&fe)[4]) {
  for (int i = 0; i < 4; ++i) fe[i] = (first >> i & 1 ? Vec3{0, 0, 0} : f[q[i]]) + fe[i];
}
/// A CE6 that carries force, on its nodes at xe, ve (fe), with its damage d and anchors a
/// updated. Where `counts` (the one evaluation of it that keeps its results): its power into
/// acc[0] (intact) or acc[1] (broken) when owned, and a break into acc[2] and its flag.
FDEM_HD void ce6_element(const Ce6Params& p, real strength, const Ce6Prestress* pre, const Vec3 (&xe)[6],
                         const Vec3 (&ve)[6], real h, Ce6Damage& d, Vec3 (&a)[3], bool counts, bool own, real* acc,
                         std::uint8_t* broke, Vec3 (&fe)[6]) {
  const bool was_broken = ce6_broken(d);
  const Ce6Eval ev = cohesive6_forces(p, xe, ve, h, d, a, fe, strength, pre);
  if (!counts) return;
  if (own && was_broken) acc[1] += ev.power;  // constant indices: acc stays in registers
  if (own && !was_broken) acc[0] += ev.power;
  if (!was_broken && ce6_broken(d)) *broke = 1, acc[2] += 1;
}
/// The TET4 laws a pass reads: one for every tet, or (several materials) each tet's material's.
struct Tet4Laws {
  Tet4Law one;
  const Tet4Law* table;    // null: every tet has `one`
  const std::uint8_t* of;  // per tet, its entry in table
  const real* stiffness;   // per tet, its factor on E (heterogeneous rock); null: 1
  const Sym3* in_situ;     // per tet, its in-situ stress (Model::tet_initial_stress); null: none
  FDEM_HD_INLINE Tet4Law at(int t) const {
    Tet4Law l = of ? table[of[t]] : one;
    if (stiffness) l.lambda *= stiffness[t], l.mu *= stiffness[t];
    return l;
  }
  FDEM_HD_INLINE const Sym3* in_situ_of(int t) const { return in_situ ? in_situ + t : nullptr; }
};
/// The CE6 laws a pass reads: one for every CE6, or each CE6's (Model::ce6_law), by slot; and
/// in a heterogeneous rock each CE6's strength factor (Model::ce6_strength).
struct Ce6Laws {
  Ce6Params one;
  const Ce6Params* table;       // null: every CE6 has `one`
  const std::uint8_t* of;       // per CE6 slot, its entry in table
  const real* strength;         // per CE6 slot, its factor; null: 1
  const Ce6Prestress* in_situ;  // per CE6 slot, its in-situ offsets (Model::ce6_prestress); null: none
  FDEM_HD_INLINE const Ce6Params& at(int slot) const { return of ? table[of[slot]] : one; }
  FDEM_HD_INLINE real strength_of(int slot) const { return strength ? strength[slot] : real(1); }
  FDEM_HD_INLINE const Ce6Prestress* in_situ_of(int slot) const { return in_situ ? in_situ + slot : nullptr; }
};
}  // namespace device_pass

/// What the element passes read of the node state and write to, besides their own state.
struct ElementInputs {
  const Vec3* x;                   // m
  const Vec3* v;                   // m/s
  Vec3* f;                         // N, per node
  const real* mass;                // kg, per node
  const std::uint8_t* own_tet;     // per tet, 1 where this rank owns it
  bool gravity;                    // gravity (and an excavation's forces) start each node's force
  Vec3 g;                          // m/s^2
  device_pass::NodePushes pushes;  // an excavation's forces, N per node
  real* sums;                      // the loop's sums (SumSlots)
};

/// The TET4 arrays both element schedules read: connectivity (4 per tet), the computed tets in
/// colour order, X0^-1, V0 (m^3), eta (Pa s), and which corners assign their first force
/// (null with gravity, which starts every force).
struct Tet4Arrays {
  const int* nodes;
  const int* order;
  const Mat3* Xinv;
  const real* V0;
  const real* eta;
  const std::uint8_t* assigns;
};

/// Where the fused pass integrates: the forces that contact, the platens and the pressure left
/// for it per node, read only for the tets flagged in `ext` (bit 0: a node in the gather list,
/// bit 1: on a platen or a lateral face).
struct HeldForces {
  const std::uint8_t* ext;
  const int* gather_of;  // per node its place in the gather list, -1: none
  const Vec3* contact_sum;
  const int* platen_of;  // per node its place among the platen nodes, -1: none
  const Vec3* platen_force;
  device_pass::HeldFaceForces pressure;
  /// What tet t's nodes q hold, added to their forces fe in the colour passes' order of sums:
  /// contact's sum, the platen's force, the pressure's faces.
  FDEM_HD_INLINE void add(int t, const int* q, Vec3 (&fe)[4]) const {
    if (!ext[t]) return;
    for (int i = 0; i < 4; ++i) {
      const int n = q[i];
      if (ext[t] & 1) {
        const int gi = gather_of[n];
        if (gi >= 0) fe[i] += contact_sum[gi];
      }
      if (ext[t] & 2) {
        const int pi = platen_of[n];
        if (pi >= 0) fe[i] += platen_force[pi];
        pressure.add(n, fe[i]);
      }
    }
  }
};

/// Where the fused pass steps: the second copies of x and v it writes, and each node's step.
struct FusedStep {
  Vec3* x_new;
  Vec3* v_new;
  device_pass::NodeStep mover;
  /// Tet nodes q moved by their forces fe from x, v into the second copies, with the
  /// integration's sums into acc[0] (non-finite velocities), acc[1] (m v.v after the
  /// prescription) and acc[2] (gravity's power after it, with the excavation's forces `np`).
  /// Masses: mass[n], or (null) tet_mass.
  FDEM_HD_INLINE void move(const int* q, const Vec3 (&fe)[4], const Vec3* x, const Vec3* v, const real* mass,
                           real tet_mass, bool gravity, Vec3 g, const device_pass::NodePushes& np, real* acc) const {
    for (int i = 0; i < 4; ++i) {
      const int n = q[i];
      Vec3 xn = x[n], vn = v[n];  // read again (from cache): fewer registers held over the CE6s
      const real mn = mass ? mass[n] : tet_mass;
      mover.move_with(mn, xn, vn, fe[i]);
      acc[0] += !finite_value(vn.x + vn.y + vn.z);
      mover.prescribe(n, mn, xn, vn);
      acc[1] += mn * dot(vn, vn);
      x_new[n] = xn, v_new[n] = vn;
      if (gravity) acc[2] += mn * dot(g, vn) + dot(np.at(n), vn);
    }
  }
};

namespace device_pass {
/// The fused pass's CE6s: per computed tet (launch order) up to four entries
/// (slot << 2 | side << 1 | writer, -1 after the last), the CE6 arrays in slot order, the state
/// the pass reads (d_read, a_read, flag_read: bit 0 own, bit 1 damaged) and the copies the
/// writer side writes.
struct FusedCe6s {
  const int* list;
  const int* nodes;
  const real* h;
  const Ce6Damage* d_read;
  const Ce6Anchors* a_read;
  Ce6Damage* d_write;
  Ce6Anchors* a_write;
  const std::uint8_t* flag_read;
  std::uint8_t* flag_write;
  std::uint8_t* broke;
  Ce6Laws laws;
  /// Each CE6 on tet k's faces (nodes q) in colour order, evaluated from the state at the start
  /// of the pass, its forces on the tet's own nodes added to fe; the writer side keeps the new
  /// state, its powers and its break (acc[0] to acc[2]: ce6_element's).
  FDEM_HD_INLINE void add(int k, const int* q, const Vec3* x, const Vec3* v, real* acc, Vec3 (&fe)[4]) const {
    for (int j = 0; j < 4; ++j) {
      const int code = list[4 * k + j];
      if (code < 0) break;
      const int c = code >> 2, side = code >> 1 & 1;
      const bool writer = code & 1;
      const std::uint8_t fl = flag_read[c];
      const Ce6Params& p = laws.at(c);
      Ce6Damage d = fl & 2 ? d_read[c] : Ce6Damage{};  // intact: its 32 bytes not read
      if (!ce6_carries_force(p, d)) {                  // broken, its faces left to contact: its state is
        // frozen, so once the other copy holds the break too the two are the same
        if (writer && d_write[c].mode != d.mode) d_write[c] = d, a_write[c] = a_read[c], flag_write[c] = fl;
        continue;
      }
      Ce6Anchors an{};
      if (ce6_max_damage(d) > 0) an = a_read[c];  // damaged or broken: anchors kept
      const int* cq = nodes + 6 * c;
      Vec3 xc[6], vc[6], fc[6];
      for (int i = 0; i < 6; ++i) xc[i] = x[cq[i]], vc[i] = v[cq[i]];
      ce6_element(p, laws.strength_of(c), laws.in_situ_of(c), xc, vc, h[c], d, an.a, writer, fl & 1, acc, broke + c,
                  fc);
      for (int i = 0; i < 3; ++i) {  // constant indices only: the arrays stay in registers
        const int n = side ? cq[3 + i] : cq[i];
        const Vec3 add = side ? fc[3 + i] : fc[i];
        for (int a = 0; a < 4; ++a)
          if (q[a] == n) fe[a] += add;
      }
      if (writer && ce6_max_damage(d) > 0) d_write[c] = d, a_write[c] = an, flag_write[c] = std::uint8_t(fl | 2);
    }
  }
};
}  // namespace device_pass

template <class Exec>
class ElementPasses : SumSlots {
 public:
  /// What the fused pass does with each tet's forces (fused_pass).
  enum PassMode { kForces, kStep, kComplete };

  /// `plan`: the fused pass's (plan_fused_pass), or empty for the colour passes.
  void set_backend(Backend b, FusedPlan plan) {
    b_ = b;
    fused_ = !plan.list.empty();
    blocks_ = fused_ ? plan.blocks_per_sm : 1;
    plan_ = std::move(plan);
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(tet_nodes_, tet_order_, ce6_nodes_, ce6_slot_, fused_ce6_, Xinv_, V0_, eta_, ce6_h_, tet4_table_, ce6_table_,
        tet_material_, ce6_law_, ce6_strength_, tet_stiffness_, tet_in_situ_, ce6_in_situ_);
    set(dmg_, slip_, dmg_next_, slip_next_, dmg_model_, slip_model_, ce6_flag_, ce6_flag_next_, ce6_sides_, broke_,
        own_ce6_, tet_assigns_);
  }
  bool fused() const { return fused_; }
  int blocks_per_sm() const { return blocks_; }

  /// The elements' constants: connectivity, colour order, the CE6 slots, the shape constants,
  /// the laws, this rank's CE6s and first touches, and the fused pass's lists.
  void place(const Model& m, const RankLayout& layout, const ElementLaws& laws) {
    fdem::place(b_, tet_nodes_, reinterpret_cast<const int*>(m.tet_nodes.data()), 4 * m.tet_nodes.size());
    fdem::place(b_, tet_order_, m.tet_colours.order);
    place_slots(m);
    place_laws(m, laws);
    const real density = laws.tet4[0].density;
    place_in_slots(ce6_nodes_, m.ce6_nodes);
    fdem::place(b_, Xinv_, m.tet_Xinv);
    fdem::place(b_, V0_, m.tet_V0);
    fdem::place(b_, eta_, m.tet_eta);
    place_in_slots(ce6_h_, m.ce6_h);
    place_in_slots(own_ce6_, layout.own_ce6);
    fdem::place(b_, tet_assigns_, layout.tet_assigns);
    assigned_corners_ = 0;
    for (std::uint8_t a : layout.tet_assigns) assigned_corners_ += (a & 1) + (a >> 1 & 1) + (a >> 2 & 1) + (a >> 3 & 1);
    // Every node's mass a quarter of its one tet's, rho V0 / 4 (model/build.cpp), to the bit:
    // then the fused pass computes it from V0, which it reads anyway, instead of reading it.
    std::vector<int> tets_of(m.X.size(), 0);
    mass_from_volume_ = true;
    for (std::size_t t = 0; t < m.tet_nodes.size() && mass_from_volume_; ++t)
      for (int n : m.tet_nodes[t]) {
        mass_from_volume_ = mass_from_volume_ && ++tets_of[n] == 1 && m.mass[n] == density * m.tet_V0[t] / 4;
        if (!mass_from_volume_) break;
      }
    node_density_ = mass_from_volume_ ? density : 0;
    plan_fused();
  }

  /// The CE6 state: the host's arrays where the slots are the ids (in place on the cpu
  /// backend), else uploaded in id order and put into slots on the device; the fused pass's
  /// second copies; the break flags.
  void upload_state(const Ce6States& ce6, const std::vector<std::uint8_t>& broke,
                    const std::vector<std::uint8_t>& own_ce6) {
    if (ce6_by_id_) {
      fdem::place(b_, dmg_, ce6.damage);
      fdem::place(b_, slip_, ce6.anchors);
    } else {
      dmg_model_.upload(ce6.damage);
      slip_model_.upload(ce6.anchors);
      dmg_.resize(ce6.size());
      slip_.resize(ce6.size());
      between_orders(true);
    }
    if (fused_) second_copies(ce6, own_ce6);
    place_in_slots(broke_, broke);
  }

  /// The CE6 state to the host, in id order (where the slots are not the ids, gathered into it
  /// on the device first).
  void download_state(Ce6States& ce6, std::vector<std::uint8_t>& broke) {
    if (ce6_by_id_) {
      dmg_.download(ce6.damage);
      slip_.download(ce6.anchors);
      broke_.download(broke);
      return;
    }
    dmg_model_.resize(dmg_.size());
    slip_model_.resize(dmg_.size());
    between_orders(false);
    dmg_model_.download(ce6.damage);
    slip_model_.download(ce6.anchors);
    std::vector<std::uint8_t> b;
    broke_.download(b);
    for (std::size_t k = 0; k < b.size(); ++k) broke[ce6_perm_[k]] = b[k];
  }

  int ce6_slots() const { return int(dmg_.size()); }
  const int* tet_nodes() const { return tet_nodes_.data(); }
  int tets() const { return int(V0_.size()); }
  int computed_tets() const { return int(tet_order_.size()); }
  const int* ce6_nodes() const { return ce6_nodes_.data(); }
  const int* ce6_slot() const { return ce6_slot_.data(); }
  /// Per CE6 slot, the CE6's id in the model.
  const std::vector<int>& ce6_order() const { return ce6_perm_; }
  const Ce6Damage* damage() const { return dmg_.data(); }
  std::uint8_t* broke() { return broke_.data(); }
  Tet4Arrays tet4_arrays(bool gravity) const {
    return Tet4Arrays{tet_nodes_.data(), tet_order_.data(), Xinv_.data(),
                      V0_.data(),        eta_.data(),       gravity ? nullptr : tet_assigns_.data()};
  }
  /// Each node's mass is rho V0 / 4 of its one tet (the fused pass computes it).
  bool mass_from_volume() const { return mass_from_volume_; }

  /// The laws the passes read: one table entry each where the scene has one material.
  device_pass::Tet4Laws tet4_laws() const {
    return device_pass::Tet4Laws{tet4_one_, tet4_table_.data(), tet_material_.size() ? tet_material_.data() : nullptr,
                                 tet_stiffness_.size() ? tet_stiffness_.data() : nullptr,
                                 tet_in_situ_.size() ? tet_in_situ_.data() : nullptr};
  }
  device_pass::Ce6Laws ce6_laws() const {
    return device_pass::Ce6Laws{ce6_one_, ce6_table_.data(), ce6_law_.size() ? ce6_law_.data() : nullptr,
                                ce6_strength_.size() ? ce6_strength_.data() : nullptr,
                                ce6_in_situ_.size() ? ce6_in_situ_.data() : nullptr};
  }

  /// TET4 colour by colour, then CE6 colour by colour (stored in colour order: slot b + k; no
  /// two elements of a colour share a node), each colour one launch; laps into `tet4`, `ce6`.
  void colour_forces(const Model& m, const ElementInputs& in, PassClock<Exec>& clock, DeviceTimes& t) {
    const Tet4Arrays tets = tet4_arrays(in.gravity);
    const device_pass::Tet4Laws tl = tet4_laws();
    for (int c = 0; c < m.tet_colours.colours(); ++c) {
      const int b = m.tet_colours.offsets[c], e = m.tet_colours.offsets[c + 1];
      Exec::template sum_to<2>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int t = tets.order[b + k];
            const int* q = tets.nodes + 4 * t;
            Vec3 xe[4], ve[4], fe[4];
            for (int i = 0; i < 4; ++i) xe[i] = in.x[q[i]], ve[i] = in.v[q[i]];
            const Tet4Law law = tl.at(t);
            device_pass::tet4_element(xe, ve, tets.Xinv[t], tets.V0[t], law.lambda, law.mu, tets.eta[t],
                                      tl.in_situ_of(t), in.own_tet[t], acc, fe);
            device_pass::tet4_start(in.f, q, tets.assigns ? tets.assigns[t] : 0, fe);
            for (int i = 0; i < 4; ++i) in.f[q[i]] = fe[i];
          },
          in.sums + kVisc);
    }
    clock.lap(t.tet4);
    const int* cn = ce6_nodes_.data();
    const real* h = ce6_h_.data();
    Ce6Damage* st = dmg_.data();
    Ce6Anchors* sl = slip_.data();
    std::uint8_t* broke = broke_.data();
    const std::uint8_t* own_c = own_ce6_.data();
    const device_pass::Ce6Laws cl = ce6_laws();
    for (int c = 0; c < m.ce6_colours.colours(); ++c) {
      const int b = m.ce6_colours.offsets[c], e = m.ce6_colours.offsets[c + 1];
      Exec::template sum_to<3>(
          e - b,
          [=] FDEM_LAMBDA(int k, real* acc) {
            const int i = b + k;
            const Ce6Params& p = cl.at(i);
            if (!ce6_carries_force(p, st[i])) return;  // broken, its faces left to contact
            const int* q = cn + 6 * i;
            Vec3 xe[6], ve[6], fe[6];
            for (int j = 0; j < 6; ++j) xe[j] = in.x[q[j]], ve[j] = in.v[q[j]];
            device_pass::ce6_element(p, cl.strength_of(i), cl.in_situ_of(i), xe, ve, h[i], st[i], sl[i].a, true,
                                     own_c[i], acc, broke + i, fe);
            for (int j = 0; j < 6; ++j) in.f[q[j]] += fe[j];
          },
          in.sums + kCoh);
    }
    clock.lap(t.ce6);
  }

  /// TET4 and CE6 forces in one pass over the computed tets: each tet's TET4, then each CE6 on
  /// its faces in colour order, every CE6 evaluated by both of its tets from the damage and
  /// anchors at the start of the pass (dmg_, slip_), each adding only to its own nodes, in the
  /// same order of sums as the colour passes (the same bits). One side, the writer, keeps the
  /// new damage and anchors (dmg_next_, slip_next_: written for every damaged CE6, so the pair
  /// stays current where it matters; undamaged, both copies hold the intact state), its powers
  /// and its break; then the copies swap.
  ///   kForces: f written once per node and never read (without gravity).
  ///   kStep (DeviceLoop::integrates): each node's force also takes what contact, platens and
  ///   pressure hold for it (in the colour passes' order of sums), and the tet moves its nodes
  ///   by `step` into its second copies of x and v (the other tets still read the first), with
  ///   the integration's sums. The caller swaps x and v after it. No force array is written.
  ///   kComplete: the same without the step: f gets each node's whole force.
  ///   before_add: run once before the pass's sums are added (in the same launch; sum_to).
  template <int kMode, class Before = NoEpilogue>
  void fused_pass(const ElementInputs& in, const HeldForces& held, const FusedStep& step, Before before_add = {}) {
    constexpr bool kOwn = kMode != kForces;  // the pass starts and ends each node's force
    const Vec3* x = in.x;
    const Vec3* v = in.v;
    Vec3* f = in.f;
    const real* mass = in.mass;
    const Tet4Arrays tets = tet4_arrays(in.gravity);
    const std::uint8_t* own_t = in.own_tet;
    const bool gravity = in.gravity;
    const Vec3 g = in.g;
    const device_pass::NodePushes pushes = in.pushes;
    const device_pass::Tet4Laws tl = tet4_laws();
    const device_pass::FusedCe6s ce6s = fused_ce6s();
    // kOwn: each node's mass rho V0 / 4 where every node's is (mass_from_volume_), else read.
    const real rho = node_density_;
    const bool from_volume = kOwn && mass_from_volume_;
    // The sums: kVisc to kBreaks; kOwn, kGravity before them; kStep, kBad, kKinetic2 and
    // kGravityNew after (base: the element passes' first).
    static_assert(kGravity == kVisc - 1 && kInverted == kVisc + 1 && kCoh == kVisc + 2 && kFric == kVisc + 3 &&
                      kBreaks == kVisc + 4 && kBad == kVisc + 5 && kKinetic2 == kVisc + 6 && kGravityNew == kVisc + 7,
                  "the fused pass sums into consecutive slots");
    constexpr int base = kOwn ? 1 : 0;
    constexpr int kN = kMode == kStep ? 9 : kOwn ? 6 : 5;
    const auto body = [=] FDEM_LAMBDA(int k, real* acc) {
      const int t = tets.order[k];
      const int* q = tets.nodes + 4 * t;
      const real tet_mass = from_volume ? rho * tets.V0[t] / 4 : 0;  // each node's (kOwn)
      Vec3 xe[4], ve[4], fe[4], start[4];
      for (int i = 0; i < 4; ++i) {
        const int n = q[i];
        xe[i] = x[n], ve[i] = v[n];
        if (kOwn) {  // the force starts with gravity (GravityLoad::start_forces), or at zero
          start[i] = gravity ? gravity_force(from_volume ? tet_mass : mass[n], g) + pushes.at(n) : Vec3{0, 0, 0};
          if (gravity) acc[0] += dot(start[i], ve[i]);  // (one rank: every node owned)
        }
      }
      const Tet4Law law = tl.at(t);
      device_pass::tet4_element(xe, ve, tets.Xinv[t], tets.V0[t], law.lambda, law.mu, tets.eta[t], tl.in_situ_of(t),
                                own_t[t], acc + base, fe);
      if (kOwn)
        for (int i = 0; i < 4; ++i) fe[i] = start[i] + fe[i];
      else
        device_pass::tet4_start(f, q, tets.assigns ? tets.assigns[t] : 0, fe);
      ce6s.add(k, q, x, v, acc + base + 2, fe);
      if (kOwn) held.add(t, q, fe);  // contact's sum, the platen's force, the pressure's faces
      if (kMode == kStep)            // the integration's sums: acc[6] to acc[8]
        step.move(q, fe, x, v, from_volume ? nullptr : mass, tet_mass, gravity, g, pushes, acc + 6);
      else
        for (int i = 0; i < 4; ++i) f[q[i]] = fe[i];
    };
    const int nk = int(tet_order_.size());
    if (blocks_ == 2)  // (the CUDA kernel compiled for two resident blocks: DeviceLoop::blocks_per_sm)
      Exec::template sum_to<kN, 2>(nk, body, in.sums + kVisc - base, before_add);
    else
      Exec::template sum_to<kN>(nk, body, in.sums + kVisc - base, before_add);
    std::swap(dmg_, dmg_next_);
    std::swap(slip_, slip_next_);
    std::swap(ce6_flag_, ce6_flag_next_);
  }

  /// The fused pass's CE6 arrays: it reads dmg_, slip_ and ce6_flag_ and writes the next copies.
  device_pass::FusedCe6s fused_ce6s() {
    return device_pass::FusedCe6s{fused_ce6_.data(),     ce6_nodes_.data(), ce6_h_.data(),     dmg_.data(),
                                  slip_.data(),          dmg_next_.data(),  slip_next_.data(), ce6_flag_.data(),
                                  ce6_flag_next_.data(), broke_.data(),     ce6_laws()};
  }

  /// After a kStep pass found an inverted TET4: the CE6 state it read is the state again, so
  /// that the host names the element in the state the pass read.
  void back_to_read_state() {
    std::swap(dmg_, dmg_next_);
    std::swap(slip_, slip_next_);
    std::swap(ce6_flag_, ce6_flag_next_);
  }

  /// A monitor row's element sums at x, v: the TET4 strain energy, the middle third's lateral
  /// stress by volume (`mid`: per tet), and the CE6s' stored energies and counts, in the
  /// model's CE6 order (the host's), so that the sums agree bit for bit.
  void measure(const Vec3* x, const Vec3* v, const std::uint8_t* own_t, const std::uint8_t* mid,
               MonitorSums& out) const {
    const Tet4Arrays tets = tet4_arrays(true);
    const device_pass::Tet4Laws tl = tet4_laws();
    const auto te = Exec::template sum<3>(int(V0_.size()), [=] FDEM_LAMBDA(int t, real* acc) {
      if (!own_t[t]) return;
      Vec3 xe[4], ve[4], fe[4];
      for (int i = 0; i < 4; ++i) xe[i] = x[tets.nodes[4 * t + i]], ve[i] = v[tets.nodes[4 * t + i]];
      const Tet4Law law = tl.at(t);
      const Tet4Eval e =
          tet4_forces(xe, ve, tets.Xinv[t], tets.V0[t], law.lambda, law.mu, tets.eta[t], fe, tl.in_situ_of(t));
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
    const std::uint8_t* own_c = own_ce6_.data();
    const device_pass::Ce6Laws cl = ce6_laws();
    const auto ce = Exec::template sum<9>(int(dmg_.size()), [=] FDEM_LAMBDA(int c, real* acc) {
      const int i = slot ? slot[c] : c;
      if (!own_c[i]) return;
      Vec3 xe[6], ve[6], fe[6];
      for (int j = 0; j < 6; ++j) xe[j] = x[cn[6 * i + j]], ve[j] = v[cn[6 * i + j]];
      Ce6Damage copy = st[i];  // measuring must not advance the state
      Ce6Anchors anchors = sl[i];
      const Ce6Params& p = cl.at(i);
      const real stored =
          cohesive6_forces(p, xe, ve, h[i], copy, anchors.a, fe, cl.strength_of(i), cl.in_situ_of(i)).stored;
      const int mode = st[i].mode;
      if (mode == kCe6Excavated) return;
      if (mode != 0) {
        acc[1] += stored;
        if (p.joint) {
          acc[8] += 1;
        } else {
          acc[3] += 1;
          acc[4] += mode == 1;
          acc[5] += mode == 2;
          acc[6] += mode == 3;
        }
      } else {
        acc[0] += stored;
        const real damaged = ce6_max_damage(st[i]) > 0;
        if (p.joint)
          acc[7] += damaged;
        else
          acc[2] += damaged;
      }
    });
    out.cohesive_stored = ce[0], out.friction_stored = ce[1], out.damaged = ce[2], out.broken = ce[3];
    out.broken_I = ce[4], out.broken_II = ce[5], out.broken_mixed = ce[6];
    out.joint_damaged = ce[7], out.joint_broken = ce[8];
  }

  /// Bytes the element passes read and write in a step (DeviceLoop::bytes_per_step), in the CE6
  /// state as it is now; the node traffic of the fused pass that steps is the loop's.
  double bytes_per_step(bool gravity, bool integrates) const;

 private:
  /// CE6 arrays in colour order (the CE6s no colour holds, on several ranks, after them), so
  /// that a colour's launch reads them contiguously. CE6 ids are colour order (model/build.cpp):
  /// on one rank the slots are the ids, and the per-CE6 arrays are the host's (in place on the
  /// cpu backend); no slot map then.
  void place_slots(const Model& m) {
    const std::size_t nce = m.ce6_nodes.size();
    ce6_perm_ = m.ce6_colours.order;
    std::vector<int> slot(nce, -1);
    for (std::size_t k = 0; k < ce6_perm_.size(); ++k) slot[ce6_perm_[k]] = int(k);
    for (std::size_t i = 0; i < nce; ++i)
      if (slot[i] < 0) slot[i] = int(ce6_perm_.size()), ce6_perm_.push_back(int(i));
    if (ce6_perm_.size() != nce)  // the rank-file loader refuses such a colouring
      throw RunError("device loop: the CE6 colouring lists a CE6 more than once");
    ce6_by_id_ = true;
    for (std::size_t k = 0; k < nce; ++k) ce6_by_id_ = ce6_by_id_ && ce6_perm_[k] == int(k);
    if (ce6_by_id_)
      ce6_slot_.release();
    else
      ce6_slot_.upload(slot);
    ce6_coloured_ = int(m.ce6_colours.order.size());
  }

  /// The laws: where the scene has several, the tables and per tet its material, per CE6 slot
  /// its law (one byte each); else the one law, passed by value.
  void place_laws(const Model& m, const ElementLaws& laws) {
    tet4_one_ = laws.tet4[0];
    ce6_one_ = laws.ce6[0];
    if (laws.tet4.size() > 1) {
      tet4_table_.upload(laws.tet4);
      fdem::place(b_, tet_material_, m.tet_material);
    } else {
      tet4_table_.release(), tet_material_.release();
    }
    if (laws.ce6.size() > 1) {
      ce6_table_.upload(laws.ce6);
      place_in_slots(ce6_law_, m.ce6_law);
    } else {
      ce6_table_.release(), ce6_law_.release();
    }
    if (!m.ce6_strength.empty())
      place_in_slots(ce6_strength_, m.ce6_strength);
    else
      ce6_strength_.release();
    if (!m.tet_stiffness.empty())
      fdem::place(b_, tet_stiffness_, m.tet_stiffness);
    else
      tet_stiffness_.release();
    if (!m.tet_initial_stress.empty())
      fdem::place(b_, tet_in_situ_, m.tet_initial_stress);
    else
      tet_in_situ_.release();
    if (!m.ce6_prestress.empty())
      place_in_slots(ce6_in_situ_, m.ce6_prestress);
    else
      ce6_in_situ_.release();
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

 public:  // (nvcc's device lambdas cannot live in private member functions)
  /// The fused pass reads one copy of the CE6 state and writes the other: both start current.
  /// Per slot its flags: bit 0 the own flag, bit 1 a damage state other than the intact one (to
  /// the bit), so that the pass reads the 32 bytes only there; both copies.
  void second_copies(const Ce6States& ce6, const std::vector<std::uint8_t>& own_ce6) {
    own_copy(dmg_next_, dmg_.size());
    own_copy(slip_next_, slip_.size());
    const Ce6Damage* d = dmg_.data();
    const Ce6Anchors* a = slip_.data();
    Ce6Damage* dn = dmg_next_.data();
    Ce6Anchors* an = slip_next_.data();
    Exec::forall(int(dmg_.size()), [=] FDEM_LAMBDA(int k) { dn[k] = d[k], an[k] = a[k]; });
    const Ce6Damage intact{};
    std::vector<std::uint8_t> fl(ce6_perm_.size());
    for (std::size_t k = 0; k < fl.size(); ++k) {
      const Ce6Damage& dk = ce6.damage[ce6_perm_[k]];
      fl[k] = std::uint8_t((own_ce6[ce6_perm_[k]] ? 1 : 0) | (std::memcmp(&dk, &intact, sizeof dk) ? 2 : 0));
    }
    ce6_flag_.upload(fl);
    ce6_flag_next_.upload(fl);
  }

  /// Between the CE6 state in id order (dmg_model_, slip_model_) and in slots (dmg_, slip_):
  /// into the slots when `to_slots`, out of them otherwise (several ranks).
  void between_orders(bool to_slots) {
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

  /// CE6s computed on this rank that carry force, and of those the damaged ones (the traffic
  /// model); with `fused`, the same counted per computed side and the flagged ones.
  std::array<real, 2> carrying() const {
    const Ce6Damage* st = dmg_.data();
    const device_pass::Ce6Laws cl = ce6_laws();
    return Exec::template sum<2>(ce6_coloured_, [=] FDEM_LAMBDA(int i, real* acc) {
      const bool carries = ce6_carries_force(cl.at(i), st[i]);
      acc[0] += carries;
      acc[1] += carries && ce6_max_damage(st[i]) > 0;
    });
  }
  std::array<real, 4> carrying_sides() const {
    const Ce6Damage* st = dmg_.data();
    const device_pass::Ce6Laws cl = ce6_laws();
    const std::uint8_t* sides = ce6_sides_.data();
    const std::uint8_t* flags = ce6_flag_.data();
    return Exec::template sum<4>(ce6_coloured_, [=] FDEM_LAMBDA(int i, real* acc) {
      const bool carries = ce6_carries_force(cl.at(i), st[i]);
      acc[0] += sides[i];
      acc[1] += carries ? sides[i] : 0;
      acc[2] += carries && ce6_max_damage(st[i]) > 0 ? sides[i] : 0;
      acc[3] += flags[i] & 2 ? sides[i] : 0;
    });
  }

 private:
  /// The array of a per-CE6 host array h in the device's slot order: h's own where the slots
  /// are the ids (place()), else a copy reordered.
  template <class T, class H>
  void place_in_slots(DeviceArray<T>& d, const std::vector<H>& h) {
    static_assert(sizeof(H) % sizeof(T) == 0, "whole elements");
    constexpr std::size_t k = sizeof(H) / sizeof(T);
    if (ce6_by_id_) {
      fdem::place(b_, d, reinterpret_cast<const T*>(h.data()), k * h.size());
      return;
    }
    std::vector<H> ordered(ce6_perm_.size());
    for (std::size_t i = 0; i < ordered.size(); ++i) ordered[i] = h[ce6_perm_[i]];
    d.upload(reinterpret_cast<const T*>(ordered.data()), k * h.size());
  }

  Backend b_ = Backend::cpu;
  bool fused_ = false;
  int blocks_ = 1;  // resident blocks per multiprocessor of the fused pass's kernels
  FusedPlan plan_;  // until place()
  DeviceArray<int> tet_nodes_, tet_order_, ce6_nodes_, ce6_slot_, fused_ce6_;
  DeviceArray<Mat3> Xinv_;
  DeviceArray<real> V0_, eta_, ce6_h_;
  DeviceArray<std::uint8_t> tet_assigns_, own_ce6_, broke_;
  double assigned_corners_ = 0;  // set bits of tet_assigns_
  // CE6 arrays (nodes, h, damage, anchors, flags) are in slot order: slot k holds model CE6
  // ce6_perm_[k]; ce6_slot_ maps back.
  DeviceArray<Ce6Damage> dmg_;
  DeviceArray<Ce6Anchors> slip_;
  // The fused pass (plan_fused): per computed tet (launch order) its CE6 entries, the computed
  // sides of each CE6 (the traffic model), and the copies of the damage, anchors and flags it
  // writes while reading dmg_, slip_ and ce6_flag_ (swapped after it).
  DeviceArray<std::uint8_t> ce6_sides_;
  DeviceArray<Ce6Damage> dmg_next_;
  DeviceArray<Ce6Anchors> slip_next_;
  DeviceArray<std::uint8_t> ce6_flag_, ce6_flag_next_;
  bool mass_from_volume_ = false;  // every node's mass node_density_ V0 / 4 of its one tet, to the bit
  real node_density_ = 0;          // kg/m^3 (mass scaling included)
  // Upload and download only: the host's layout and order. Kept between copies, so that a copy
  // allocates nothing.
  DeviceArray<Ce6Damage> dmg_model_;  // the CE6 state in id order (slots not by id)
  DeviceArray<Ce6Anchors> slip_model_;
  bool ce6_by_id_ = false;  // CE6 slot k is CE6 k (one rank): no slot map, no reordered copies
  std::vector<int> ce6_perm_;
  int ce6_coloured_ = 0;  // slots [0, ce6_coloured_) are in the colours (computed on this rank)
  // The laws (place_laws): the one law, or the tables with per tet and per CE6 slot an entry.
  Tet4Law tet4_one_{};
  Ce6Params ce6_one_{};
  DeviceArray<Tet4Law> tet4_table_;
  DeviceArray<Ce6Params> ce6_table_;
  DeviceArray<std::uint8_t> tet_material_, ce6_law_;
  DeviceArray<real> ce6_strength_;         // Model::ce6_strength in slots (heterogeneous rock only)
  DeviceArray<real> tet_stiffness_;        // Model::tet_stiffness (heterogeneous E only)
  DeviceArray<Sym3> tet_in_situ_;          // Model::tet_initial_stress (in-situ stress only)
  DeviceArray<Ce6Prestress> ce6_in_situ_;  // Model::ce6_prestress in slots (in-situ stress only)
};

template <class Exec>
double ElementPasses<Exec>::bytes_per_step(bool gravity, bool integrates) const {
  const double nt = double(tet_order_.size());
  const double vec = sizeof(Vec3);
  // TET4 (those this rank computes): colour-order entry, connectivity, X0^-1, V0, eta, the
  // assign mask; x and v of its 4 nodes read, f written (none where the fused pass integrates),
  // and read too where the corner does not assign (gravity: every corner; none where the fused
  // pass integrates, which starts each force itself); fused, its list of CE6s.
  const double read_f = integrates ? 0 : gravity ? 4 * nt : 4 * nt - assigned_corners_;
  // The material byte (several materials) and the factor on E (heterogeneous E), read by each tet.
  const double laws = (tet_material_.size() ? 1 : 0) + (tet_stiffness_.size() ? sizeof(real) : 0) +
                      (tet_in_situ_.size() ? sizeof(Sym3) : 0);
  const double tet =
      nt * (5 * sizeof(int) + sizeof(Mat3) + 2 * sizeof(real) + 1 + laws + (integrates ? 2 : 3) * 4 * vec) +
      read_f * vec + (fused_ ? nt * 4 * sizeof(int) : 0);
  // CE6 (those this rank computes, in the state as it is now): connectivity, h, damage and the
  // own flag read (the break flags: read by activation only where one broke); where it carries
  // force, x and v of 6 nodes read and f read and written; where damaged (or broken and
  // carrying force), the damage written (an upper bound: only when it rises) and the anchors
  // read and written.
  const auto k = carrying();
  // The law byte (several laws) and the strength factor (heterogeneous rock), read by each CE6.
  const double law = (ce6_law_.size() ? 1 : 0) + (ce6_strength_.size() ? sizeof(real) : 0);
  // The in-situ offsets (in-situ stress), read where the CE6 carries force.
  const double in_situ = ce6_in_situ_.size() ? sizeof(Ce6Prestress) : 0;
  double ce6 = ce6_coloured_ * (6 * sizeof(int) + sizeof(real) + sizeof(Ce6Damage) + 1 + law) +
               k[0] * (6 * 4 * vec + in_situ) + k[1] * (sizeof(Ce6Damage) + 2 * sizeof(Ce6Anchors));
  if (fused_) {
    // Fused, each side that computes the CE6: its flags read (own, damaged), and its damage
    // where the flags say damaged or broken; where it carries force, the connectivity, h and
    // 6 nodes' x and v read (its forces go to the tet's own nodes in registers: f is the
    // TET4's write above), and where damaged the anchors read and, by the writer side,
    // damage, anchors and flags written; where not (broken, inert), the writer reads the other
    // copy's damage.
    const auto e = carrying_sides();
    ce6 = e[0] * (1 + law) + e[3] * sizeof(Ce6Damage) +
          e[1] * (6 * sizeof(int) + sizeof(real) + 6 * 2 * vec + in_situ) + e[2] * sizeof(Ce6Anchors) +
          k[1] * (sizeof(Ce6Damage) + sizeof(Ce6Anchors) + 1) + (ce6_coloured_ - k[0]) * sizeof(Ce6Damage);
  }
  return tet + ce6;
}

}  // namespace fdem
