#pragma once
// Tet-tet contact in the device loop, on any Exec (core/forall.hpp): adaptive activation, the
// broad phase's watch, the candidate list's build (solver/candidate_build.hpp), the pairs'
// narrow phase and friction (physics/contact.hpp), and the deterministic per-node sum of their
// forces. ContactSet (solver/contact_set.hpp) is the host copy of this state.
#include <cstdint>
#include <type_traits>
#include <utility>

#include "core/forall.hpp"
#include "physics/cohesive6.hpp"
#include "physics/contact.hpp"
#include "solver/candidate_build.hpp"
#include "solver/device_loop.hpp"
#include "solver/loop_sums.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

namespace device_pass {
/// A contact pair's power: -f.v of its forces fa (on nodes na) and fb (on nb), subtracted from
/// acc node by node, owned nodes only.
FDEM_HD void subtract_pair_power(const Vec3 (&fa)[4], const Vec3 (&fb)[4], const int (&na)[4], const int (&nb)[4],
                                 const Vec3* v, const std::uint8_t* own_n, real& acc) {
  for (int i = 0; i < 4; ++i) {
    if (own_n[na[i]]) acc -= dot(fa[i], v[na[i]]);
    if (own_n[nb[i]]) acc -= dot(fb[i], v[nb[i]]);
  }
}
}  // namespace device_pass

/// A pair's Coulomb coefficient: its two tets' joint's where both lie on one joint
/// (Model::tet_joint), else the rock's.
struct PairFriction {
  const std::uint8_t* tet_joint;  // null: no joints
  const real* joint;              // per joint
  real rock;
  FDEM_HD real of(int a, int b) const {
    if (!tet_joint) return rock;
    const int ja = tet_joint[a];
    return ja != 0 && ja == tet_joint[b] ? joint[ja - 1] : rock;
  }
};

/// What the pairs' pass reads besides the contact state.
struct PairInputs {
  const int* tet_nodes;          // 4 per tet
  const int* ce6_slot;           // per CE6 id its slot (null: the slots are the ids)
  const Ce6Damage* damage;       // per CE6 slot
  const std::uint8_t* fresh;     // per CE6 slot, its break flag still up (null: not read)
  const std::uint8_t* own_tet;   // per tet, 1 where this rank owns it
  const std::uint8_t* own_node;  // per node, the same
  const Vec3* x;                 // m
  const Vec3* v;                 // m/s
  real dt;                       // s
};

template <class Exec>
class ContactPasses : SumSlots {
 public:
  /// `held`: the fused pass integrates, and the pairs' per-node sum waits for it in an array of
  /// its own (contact_sum_), each node knowing its place (gather_of_).
  void set_backend(Backend b, bool held) {
    b_ = b, held_ = held;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(node_vertex_, vt_ptr_, vt_tets_, face_ce6_, ce6_tets_, slot_faces_, tet_global_, watch_nodes_, gather_node_,
        gather_ptr_, gather_slot_, gather_of_, tet_joint_, joint_friction_);
    set(plan_x_, watch_x_, history_, next_history_, pair_force_, contact_sum_, active_, pairs_, next_pairs_, eval_);
    candidates_.set_backend(b);
  }

  /// The constants: activation's vertex -> tets lists, the candidate filters (the CE6s on each
  /// tet's faces, the tets of each CE6, whether CE6s weld), the faces of each CE6 slot (`slot_ce6`: slot -> CE6 id),
  /// and on several ranks the tets' global ids and the positions the contact ghosts were gathered at.
  void place(const LoopParts& s, const std::vector<int>& slot_ce6) {
    const Model& m = s.model;
    const ContactSet& c = s.contacts;
    fdem::place(b_, node_vertex_, m.node_vertex);
    fdem::place(b_, vt_ptr_, c.vertex_tet_ptr());
    fdem::place(b_, vt_tets_, c.vertex_tets());
    fdem::place(b_, face_ce6_, reinterpret_cast<const int*>(c.face_ce6().data()), 4 * c.face_ce6().size());
    fdem::place(b_, ce6_tets_, reinterpret_cast<const int*>(m.ce6_tets.data()), 2 * m.ce6_tets.size());
    slot_faces_.upload(slot_faces(c, m, slot_ce6));
    welds_ = every_node_private(m, s.layout);
    if (!m.tet_joint.empty()) {  // (a scene without joints reads no joint bytes)
      fdem::place(b_, tet_joint_, m.tet_joint);
      joint_friction_.upload(s.laws.joint_friction);
    } else {
      tet_joint_.release();
    }
    if (s.layout.dd.distributed()) {
      fdem::place(b_, plan_x_, c.plan_x());
      fdem::place(b_, tet_global_, s.layout.dd.tet_global);
    }
    if (held_) gather_of_.upload(std::vector<int>(m.X.size(), -1));
  }

  /// Contact's state: flags, pairs, their histories, forces and indices; the gather list followed anew.
  void upload_state(const ContactSet& c) {
    fdem::place(b_, active_, c.tet_flags);
    // Every node out of the old gather list (on the cpu backend the list this loop borrowed may
    // have been overwritten by a checkpoint's).
    if (held_) {
      int* of = gather_of_.data();
      Exec::forall(int(gather_of_.size()), [=] FDEM_LAMBDA(int n) { of[n] = -1; });
    }
    contact_arrays(c, [&](auto& d, const auto& h) { fdem::place(b_, d, h); });
    history_in_place(c);
    pairs_on_host_ = true;
    if (held_) follow_gather(true);
  }

  void download_state(ContactSet& c) {
    active_.download(c.tet_flags);
    c.recount_active();
    history_.download(c.history);
    eval_.download(c.eval);
    pair_force_.download(c.pair_force);
    if (pairs_on_host_) return;  // else built on the device since the last copy
    pairs_.download(c.pairs);
    gather_node_.download(c.gather_node);
    gather_ptr_.download(c.gather_ptr);
    gather_slot_.download(c.gather_slot);
    watch_nodes_.download(c.watch_nodes);
    watch_x_.download(c.watch_x);
    pairs_on_host_ = true;
  }

  /// The bonded-neighbour rule's inputs (contact/bonded.hpp) over the loop's arrays.
  BondInputs bond_inputs(const int* tet_nodes) const {
    BondInputs b;
    b.tet_nodes = tet_nodes, b.node_vertex = node_vertex_.data();
    b.star_ptr = vt_ptr_.data(), b.star_tets = vt_tets_.data();
    b.face_ce6 = face_ce6_.data(), b.ce6_tets = ce6_tets_.data();
    b.flags = welds_ ? active_.data() : nullptr;
    return b;
  }

  /// Whether every node of the whole model belongs to one tet (CE6s on every internal face).
  /// Only then do CE6s weld (contact/bonded.hpp). Where some tets share nodes, a rank may own
  /// a node of a tet whose partner's vertex star it does not hold, and could not decide a weld
  /// as one rank does; there only shared nodes bond, on every rank count alike.
  static bool every_node_private(const Model& m, const RankLayout& layout) {
    std::vector<int> tets_at(m.X.size(), 0);  // (an owned node's tets are all held here)
    for (const auto& q : m.tet_nodes)
      for (int n : q) ++tets_at[n];
    real shared = 0;
    for (std::size_t n = 0; n < tets_at.size(); ++n) shared += layout.own_node[n] && tets_at[n] > 1;
    layout.sum(&shared, 1);
    return shared == 0;
  }

  /// Per CE6 slot, the faces of its two tets it lies on, as 4 tet + face.
  static std::vector<int> slot_faces(const ContactSet& c, const Model& m, const std::vector<int>& slot_ce6) {
    std::vector<int> out(2 * slot_ce6.size());
    for (std::size_t k = 0; k < slot_ce6.size(); ++k)
      for (int j = 0; j < 2; ++j) {
        const int t = m.ce6_tets[slot_ce6[k]][j];
        for (int i = 0; i < 4; ++i)
          if (c.face_ce6()[t][i] == slot_ce6[k]) out[2 * k + j] = 4 * t + i;
      }
    return out;
  }

  DeviceArray<std::uint8_t>& active() { return active_; }
  long pairs() const { return long(pairs_.size()); }
  long gathered_nodes() const { return long(gather_node_.size()); }
  /// Per node its place in the gather list (-1: none), where the sum is held.
  const int* gather_place() const { return gather_of_.data(); }
  const Vec3* held_sum() const { return contact_sum_.data(); }

  /// One launch: over `flags` CE6 slots, adaptive activation: the vicinity of each CE6 whose
  /// break flag is up (every tet sharing a vertex of its face, ce6_nodes: 6 per slot) joins the
  /// candidates, its two faces are released from the welds (contact/bonded.hpp), and the flag
  /// goes down (kAdded counts the tets added and faces released, which marks the set dirty
  /// with the evaluation's sums); with
  /// `watch` and contact, the broad phase's watch (kMoved: nodes of active tets that moved half
  /// the buffer since the list was built). Flags only rise, each with one atomic operation
  /// (raise_bits), so a tet at the vertices of several breaking CE6s is raised and counted
  /// once, whatever the iterations' order.
  void activate(const ContactSet& cs, int flags, bool with_watch, const int* ce6_nodes, std::uint8_t* broke,
                const Vec3* x, real* sums) {
    const bool on = cs.enabled();
    const int nw = with_watch && on ? int(watch_nodes_.size()) : 0;
    const int* cn = ce6_nodes;
    const int* nv = node_vertex_.data();
    const int* vptr = vt_ptr_.data();
    const int* vtets = vt_tets_.data();
    const int* faces = slot_faces_.data();
    std::uint8_t* active = active_.data();
    const Watch moved = watch(cs.buffer());
    static_assert(kMoved == kAdded + 1, "the activation's and the watch's counts");
    Exec::template sum_to<2>(
        flags + nw,
        [=] FDEM_LAMBDA(int i, real* acc) {
          if (i >= flags) {
            if (moved.moved(i - flags, x)) acc[1] += 1;
            return;
          }
          if (!broke[i]) return;
          broke[i] = 0;
          if (!on) return;
          for (int j = 0; j < 3; ++j) {
            const int vtx = nv[cn[6 * i + j]];
            for (int k = vptr[vtx]; k < vptr[vtx + 1]; ++k)  // (a tet two broken CE6s share: raised once)
              if (raise_bits(active + vtets[k], TetFlag::kCandidate)) acc[0] += 1;
          }
          for (int j = 0; j < 2; ++j)
            if (raise_bits(active + faces[2 * i + j] / 4, TetFlag::face_released(faces[2 * i + j] % 4))) acc[0] += 1;
        },
        sums + kAdded);
  }

  /// Held sums: `into`, each node of the gather list gets its place in it (gather_of_);
  /// otherwise the listed nodes leave (before the list changes).
  void follow_gather(bool into) {
    const int* gn = gather_node_.data();
    int* of = gather_of_.data();
    Exec::forall(int(gather_node_.size()), [=] FDEM_LAMBDA(int k) { of[gn[k]] = into ? k : -1; });
    if (into) contact_sum_.resize(gather_node_.size());
  }

  /// The candidate list (the passes of contact/broad_phase.cpp's find_box_pairs, which
  /// test_broad_phase holds to a brute-force search), with the filters (a joining CE6, shared
  /// nodes), histories carried over by (a, b), the gather index and the watch list. Only counts
  /// come back to the host. `own_node`: null on one rank.
  void rebuild(ContactSet& cs, int tets, int nodes, const Vec3* x, const int* tet_nodes, const std::uint8_t* own_node,
               DeviceTimes& t) {
    apart_for_rebuild(cs);
    CandidateInputs in;
    in.tets = tets, in.nodes = nodes;
    in.x = x, in.tet_nodes = tet_nodes, in.flags = active_.data();
    in.tet_global = tet_global_.size() > 0 ? tet_global_.data() : nullptr;
    in.own_node = own_node;
    in.vertices = int(vt_ptr_.size()) - 1;
    in.bond = bond_inputs(tet_nodes);
    in.buffer = cs.buffer();
    const BroadPhaseStats st = candidates_.find_pairs(in, next_pairs_);
    candidates_.carry_history(in, pairs_, history_, next_pairs_, next_history_);
    const long grown_before = pairs_.times_grown() + pair_force_.times_grown();
    std::swap(pairs_, next_pairs_);
    std::swap(history_, next_history_);
    eval_.resize(st.pairs);
    pair_force_.resize(8 * st.pairs);
    t.pair_growth += pairs_.times_grown() + pair_force_.times_grown() - grown_before;
    candidates_.gather_index(in, pairs_, gather_node_, gather_ptr_, gather_slot_);
    candidates_.watch_list(in, watch_nodes_, watch_x_);
    cs.rebuild_due = false;
    ++cs.times.rebuilds;
    cs.last_build = st;
    pairs_on_host_ = false;
    if (b_ == Backend::cpu) {  // (CandidateBuild::release_scratch)
      candidates_.release_scratch();
      next_pairs_.release();
      in_place(cs);
    }
  }

  /// One launch over the candidate list: the narrow phase, friction, the pair's forces written
  /// once, their contact energy and their power with the velocities now (its sums to kTouching
  /// to kConPower). The histories are read from history_ and written to next_history_, which
  /// become the state at history_settled(): a pass run ahead of a rebuild leaves the histories
  /// it carries over as they were.
  void pairs(const ContactSet& cs, const PairInputs& in, real* sums) {
    const int np = int(pairs_.size());
    next_history_.resize(np);
    const ContactPair* pairs = pairs_.data();
    ContactEval* ev = eval_.data();
    Vec3* pf = pair_force_.data();
    const PairHistory* history_in = history_.data();
    PairHistory* history_out = next_history_.data();
    const real P = cs.penalty(), mu_rock = cs.friction();
    const ContactLaw law = cs.law();
    const PairFriction friction{tet_joint_.size() ? tet_joint_.data() : nullptr, joint_friction_.data(), mu_rock};
    static_assert(kConDiss == kTouching + 1 && kConStored == kTouching + 2 && kConEnergy == kTouching + 3 &&
                      kConPower == kTouching + 4,
                  "the contact pass's sums");
    Exec::template sum_to<5>(
        np,
        [=] FDEM_LAMBDA(int k, real* acc) {
          const ContactPair cp = pairs[k];
          int na[4], nb[4];
          for (int i = 0; i < 4; ++i) na[i] = in.tet_nodes[4 * cp.a + i], nb[i] = in.tet_nodes[4 * cp.b + i];
          Vec3 fa[4], fb[4];  // the normal forces, then friction's added
          // A joint broken in this evaluation (its flag still up) still holds its faces.
          const int js = in.ce6_slot && cp.joint >= 0 ? in.ce6_slot[cp.joint] : cp.joint;
          bool pushes = false;  // some force not zero: only then has the pair a power
          if (js >= 0 && (!ce6_broken(in.damage[js]) || (in.fresh && in.fresh[js]))) {
            for (int i = 0; i < 4; ++i) fa[i] = fb[i] = Vec3{0, 0, 0};
            ev[k] = ContactEval{{0, 0, 0}, {0, 0, 0}, 0, 0, 0};
            history_out[k] = new_pair_history();  // its first evaluation after the break sets its zero
          } else {
            Vec3 xa[4], xb[4];
            for (int i = 0; i < 4; ++i) xa[i] = in.x[na[i]], xb[i] = in.x[nb[i]];
            PairHistory h = history_in[k];
            const ContactEval e = contact_tet_pair(law, xa, xb, P, fa, fb, h.overlap_zero);
            ev[k] = e;
            h.overlap_zero = next_overlap_zero(h.overlap_zero, e);
            for (int i = 0; i < 4; ++i) pushes = pushes || !is_zero(fa[i]) || !is_zero(fb[i]);
            if (!(e.weight > 0)) {
              h.spring = Vec3{0, 0, 0};
            } else {
              pushes = true;
              if (in.own_tet[cp.a]) acc[0] += 1, acc[3] += e.energy;
              Vec3 va[4], vb[4], ga[4], gb[4];
              for (int i = 0; i < 4; ++i) {
                va[i] = in.v[na[i]], vb[i] = in.v[nb[i]];
                ga[i] = gb[i] = Vec3{0, 0, 0};
              }
              const real k_t = contact_tangential_stiffness(xa, xb, P);
              const real d = contact_friction(xa, xb, va, vb, e, friction.of(cp.a, cp.b), k_t, in.dt, h.spring, ga, gb);
              if (in.own_tet[cp.a]) {
                acc[1] += d;
                acc[2] += 0.5 * k_t * dot(h.spring, h.spring);
              }
              for (int i = 0; i < 4; ++i) fa[i] += ga[i], fb[i] += gb[i];
            }
            history_out[k] = h;
          }
          Vec3* fp = pf + 8 * k;
          for (int i = 0; i < 4; ++i) fp[i] = fa[i], fp[4 + i] = fb[i];
          // (A pair without force adds -0 to the power, which leaves every sum as it is.)
          if (pushes) device_pass::subtract_pair_power(fa, fb, na, nb, in.v, in.own_node, acc[4]);
        },
        sums + kTouching);
  }

  /// The histories of the pairs' last pass are now the state.
  void history_settled() { std::swap(history_, next_history_); }

  /// The sum of the pair forces at gather node k.
  struct Gather {
    const int* ptr;
    const int* slot;
    const Vec3* pair_force;
    FDEM_HD Vec3 at(int k) const {
      Vec3 sum{0, 0, 0};
      for (int j = ptr[k]; j < ptr[k + 1]; ++j) sum += pair_force[slot[j]];
      return sum;
    }
  };
  Gather gather() const { return Gather{gather_ptr_.data(), gather_slot_.data(), pair_force_.data()}; }

  /// The deterministic per-node sum of the pairs' forces: added to f, or held for the fused pass.
  void add_forces(Vec3* f) {
    const int* gn = gather_node_.data();
    const Gather g = gather();
    Vec3* held = held_ ? contact_sum_.data() : nullptr;
    Exec::forall(int(gather_node_.size()), [=] FDEM_LAMBDA(int k) {
      const Vec3 sum = g.at(k);
      if (held)
        held[k] = sum;
      else
        f[gn[k]] += sum;
    });
  }
  /// The per-node sum held for the fused pass, where a launch the loop shares writes it.
  Vec3* held_sum_out() { return contact_sum_.data(); }

  /// The power of pair k's last forces with the velocities v (-sum f.v, ContactSet::power).
  struct Power {
    const int* tet_nodes;
    const ContactPair* pairs;
    const Vec3* pair_force;
    FDEM_HD void subtract(int k, const Vec3* v, const std::uint8_t* own_n, real& acc) const {
      const Vec3* fp = pair_force + 8 * k;
      int na[4], nb[4];
      Vec3 fa[4], fb[4];
      bool pushes = false;  // (a pair without force adds -0: skipped, the same sum)
      for (int i = 0; i < 4; ++i) {
        fa[i] = fp[i], fb[i] = fp[4 + i];
        pushes = pushes || !is_zero(fa[i]) || !is_zero(fb[i]);
      }
      if (!pushes) return;
      for (int i = 0; i < 4; ++i) na[i] = tet_nodes[4 * pairs[k].a + i], nb[i] = tet_nodes[4 * pairs[k].b + i];
      device_pass::subtract_pair_power(fa, fb, na, nb, v, own_n, acc);
    }
  };
  Power power(const int* tet_nodes) const { return Power{tet_nodes, pairs_.data(), pair_force_.data()}; }

  /// The broad phase's watch: has watched node i moved half the buffer since the list was built?
  struct Watch {
    const int* node;
    const Vec3* at;
    real lim2;  // m^2, a quarter of the buffer squared
    FDEM_HD bool moved(int i, const Vec3* x) const {
      const Vec3 d = x[node[i]] - at[i];
      return dot(d, d) > lim2;
    }
  };
  Watch watch(real buffer) const { return Watch{watch_nodes_.data(), watch_x_.data(), 0.25 * buffer * buffer}; }
  int watched() const { return int(watch_nodes_.size()); }

  /// A monitor row's counts: this rank's active tets and pairs.
  void measure(const std::uint8_t* own_t, MonitorSums& out) const {
    const std::uint8_t* active = active_.data();
    const ContactPair* pairs = pairs_.data();
    out.active_tets = Exec::template sum<1>(int(active_.size()), [=] FDEM_LAMBDA(int t, real* acc) {
      acc[0] += TetFlag::candidate(active[t]) && own_t[t];
    })[0];
    out.contact_pairs = Exec::template sum<1>(int(pairs_.size()),
                                              [=] FDEM_LAMBDA(int k, real* acc) { acc[0] += own_t[pairs[k].a]; })[0];
  }

  /// Several ranks: the positions the contact ghosts were gathered at.
  const Vec3* plan_x() const { return plan_x_.data(); }

  /// Bytes a step's pairs read and write: the pair, its evaluation written, its history read and
  /// written, 8 node ids and the 8 nodes' x and v, 8 forces written (narrow phase and friction
  /// in one pass); the gather reads the forces; the new velocities' power reads the ids, forces
  /// and v again.
  double bytes_per_step() const {
    const double vec = sizeof(Vec3);
    return double(pairs_.size()) * (sizeof(ContactPair) + sizeof(ContactEval) + 2 * sizeof(PairHistory) +
                                    2 * 8 * sizeof(int) + 16 * vec + 8 * vec + 8 * vec + 16 * vec);
  }

 private:
  /// f(the loop's array, the ContactSet's vector) for each contact array both hold.
  template <class Set, class F>
  void contact_arrays(Set& c, F&& f) {
    f(pairs_, c.pairs), f(history_, c.history), f(eval_, c.eval), f(pair_force_, c.pair_force);
    f(gather_node_, c.gather_node), f(gather_ptr_, c.gather_ptr), f(gather_slot_, c.gather_slot);
    f(watch_nodes_, c.watch_nodes), f(watch_x_, c.watch_x);
  }

  /// Cpu backend: the pairs' pass updates each pair's history where it reads it (next_history_
  /// is history_), which is safe because a pair reads and writes only its own. Not where the
  /// fused pass integrates: that schedule may run the pairs twice in one evaluation, so it keeps
  /// the histories from before the first run apart, in a next_history_ of the loop's own (one that
  /// still borrows a vector lets go: the vector may have moved).
  void history_in_place(const ContactSet& c) {
    if (b_ != Backend::cpu) return;
    if (held_)
      next_history_.release();
    else
      fdem::place(b_, next_history_, c.history);
  }

  /// Cpu backend, after a rebuild made the contact arrays in the loop's own memory: they move
  /// into the ContactSet's vectors, which the loop then works on in place (one copy per rebuild,
  /// none per step, and the contact state held once).
  void in_place(ContactSet& c) {
    contact_arrays(c, [](auto& d, auto& h) {
      if (d.data() != h.data()) h.assign(d.data(), d.data() + d.size());
      d.borrow(h);
    });
    history_in_place(c);
    pairs_on_host_ = true;
  }

  /// Cpu backend, before a rebuild: the arrays it makes anew let go of the ContactSet's vectors
  /// (the old pairs and histories stay borrowed: the rebuild reads them to carry them over).
  /// Those vectors are not read again before the new arrays move in (in_place): freed now, so
  /// that the old and the new are not held together.
  void apart_for_rebuild(ContactSet& c) {
    if (b_ != Backend::cpu) return;
    auto release = [](auto&... a) { (a.release(), ...); };
    release(next_history_, eval_, pair_force_, gather_node_, gather_ptr_, gather_slot_, watch_nodes_, watch_x_);
    auto free_all = [](auto&... h) { ((std::remove_reference_t<decltype(h)>{}.swap(h)), ...); };
    free_all(c.eval, c.pair_force, c.gather_node, c.gather_ptr, c.gather_slot, c.watch_nodes, c.watch_x);
  }

  Backend b_ = Backend::cpu;
  bool held_ = false;
  bool pairs_on_host_ = true;  // the host ContactSet holds the current pair list and indices
  // The candidate list's build (its scratch kept between builds on a GPU) and what it reads.
  CandidateBuild<Exec> candidates_;
  DeviceArray<long> tet_global_;  // several ranks: pairs in global order
  DeviceArray<int> node_vertex_, vt_ptr_, vt_tets_, face_ce6_, ce6_tets_;
  DeviceArray<int> slot_faces_;  // per CE6 slot, its two tets' faces (4 tet + face)
  bool welds_ = false;           // CE6s weld (every_node_private)
  DeviceArray<Vec3> plan_x_;
  DeviceArray<std::uint8_t> active_;
  DeviceArray<std::uint8_t> tet_joint_;  // Model::tet_joint (where the scene has joints)
  DeviceArray<real> joint_friction_;     // ElementLaws::joint_friction
  DeviceArray<ContactPair> pairs_, next_pairs_;
  DeviceArray<PairHistory> history_, next_history_;
  DeviceArray<Vec3> pair_force_;
  DeviceArray<ContactEval> eval_;
  DeviceArray<int> gather_node_, gather_ptr_, gather_slot_, watch_nodes_;
  DeviceArray<Vec3> watch_x_;
  // Where the fused pass integrates: per node its place in the gather list (-1: none) and the
  // pairs' sum held there.
  DeviceArray<int> gather_of_;
  DeviceArray<Vec3> contact_sum_;
};

}  // namespace fdem
