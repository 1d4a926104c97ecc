#pragma once
// DeviceLoopImpl<Exec>: the device loop (device_loop.hpp) for one Exec. Included by
// device_loop.cpp (CpuExec, the cpu backend; HostExec, the debug backend) and by
// cuda/device_loop.cu (CudaExec), so the passes are one source. The loop holds the node state
// and the step's sums, and orders the passes of its parts: the elements
// (solver/element_passes.hpp), contact (solver/contact_passes.hpp), the loads (src/loads)
// and the halo (solver/halo_passes.hpp). Lambdas capture raw pointers and small views by value
// (a device lambda cannot read `this`).
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <limits>
#include <tuple>
#include <utility>

#include "core/forall.hpp"
#include "physics/integrate.hpp"
#include "solver/contact_passes.hpp"
#include "solver/device_loop.hpp"
#include "solver/element_passes.hpp"
#include "solver/halo_passes.hpp"
#include "solver/loop_sums.hpp"
#include "solver/pass_support.hpp"

namespace fdem {

template <class Exec>
class DeviceLoopImpl final : public DeviceLoop, SumSlots {
  using Elements = ElementPasses<Exec>;

 public:
  /// `plan`: the fused pass's (plan_fused_pass), or empty for the colour passes.
  DeviceLoopImpl(Backend b, const LoopParts& parts, bool direct_mpi, FusedPlan plan)
      : p_(parts),
        b_(b),
        direct_mpi_(direct_mpi),
        schedule_(plan.list.empty() ? ElementSchedule::colour
                  : plan.integrate  ? ElementSchedule::fused_with_step
                                    : ElementSchedule::fused) {
    elements_.set_backend(b, std::move(plan));
    contact_.set_backend(b, integrates());
    parts.loads.each([&](auto& load) { load.set_backend(b); });
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(X_, x_, v_, f_, x2_, v2_, mass_, sums_, own_node_, own_tet_, mid_third_, ext_tet_, ext_static_, unreached_,
        lateral_nodes_);
    halo_.set_backend(b, direct_mpi);
    sums_.resize(kAll);
    clear_sums(0, kAll);  // a slot a schedule never writes (kWatched) reads 0
  }

  Backend backend() const override { return b_; }
  bool fused() const override { return elements_.fused(); }
  bool integrates() const override { return schedule_ == ElementSchedule::fused_with_step; }
  int blocks_per_sm() const override { return elements_.blocks_per_sm(); }
  bool halo_passes_device_buffers() const override { return direct_mpi_; }
  void set_timing(bool on) override { clock_.timing = on; }
  const DeviceTimes& times() const override { return t_; }

  void upload() override {
    const auto t0 = Clock::now();
    if (!constants_) {
      place_constants(p_);
      constants_ = true;
    }
    upload_state(p_);
    t_.copies += seconds_since(t0);
  }

  // The parts of upload(). (Public where they hold a pass: nvcc's extended lambdas need their
  // enclosing function public.)

  /// The model's constants, this rank's layout (ownership, first touch, the halo) and the
  /// loads' constants.
  void place_constants(const LoopParts& s) {
    const Model& m = s.model;
    place(b_, mass_, m.mass);  // (1/m: divided where needed, no array read for it)
    elements_.place(m, s.layout, s.laws);
    place(b_, X_, m.X);
    place(b_, lateral_nodes_, m.lateral_nodes);
    place(b_, own_node_, s.layout.own_node);
    place(b_, own_tet_, s.layout.own_tet);
    place(b_, unreached_, s.layout.unreached_nodes);
    // The fused pass integrates (make_device_loop: one rank, every node a tet's).
    if (integrates() && (s.layout.halo || s.layout.dd.distributed() || !s.layout.unreached_nodes.empty()))
      throw RunError("device loop: the fused pass cannot integrate this run (several ranks or nodes outside the tets)");
    if (s.layout.halo) halo_.plan(*s.layout.halo, s.layout.dd);
    mid_third_.upload(middle_third_tets(m));
    s.loads.each([&](auto& load) { load.place(m, integrates()); });
    if (s.contacts.enabled()) contact_.place(s, elements_.ce6_order());
    place_held_flags(s, s.loads.surface.loaded_nodes());
  }

  /// Where the fused pass integrates: the tets with a node on a platen or a lateral face
  /// (`lateral_nodes`: the pressure's nodes), whose forces the pass reads from the loads.
  void place_held_flags(const LoopParts& s, const std::vector<int>& lateral_nodes) {
    if (!integrates()) return;
    const std::vector<std::uint8_t> ext = tets_on_loads(s, lateral_nodes);
    ext_nodes_ = 4 * long(std::count(ext.begin(), ext.end(), 2));
    ext_static_.upload(ext);
    ext_tet_.upload(ext);
  }

  /// Where the fused pass integrates, after the gather list changed: each tet's flags, bit 0
  /// where a node is in the list, bit 1 as ext_static_.
  void refresh_held_flags() {
    const int* tn = elements_.tet_nodes();
    const int* of = contact_.gather_place();
    const std::uint8_t* fixed = ext_static_.data();
    std::uint8_t* ext = ext_tet_.data();
    Exec::forall(int(ext_tet_.size()), [=] FDEM_LAMBDA(int t) {
      const int* q = tn + 4 * t;
      const bool listed = of[q[0]] >= 0 || of[q[1]] >= 0 || of[q[2]] >= 0 || of[q[3]] >= 0;
      ext[t] = std::uint8_t(fixed[t] | (listed ? 1 : 0));
    });
  }

  /// The evolving state, host to loop (on the cpu backend borrowed, in place).
  void upload_state(const LoopParts& s) {
    discard_pending();  // the host copy, its scalars included, is the state
    place(b_, x_, s.x);
    place(b_, v_, s.v);
    place(b_, f_, s.f);
    if (integrates()) own_copy(x2_, s.x.size()), own_copy(v2_, s.v.size());
    elements_.upload_state(s.ce6, s.ce6_broke, s.layout.own_ce6);
    s.loads.each([&](auto& load) { load.upload_state(); });
    if (!s.contacts.enabled()) return;
    contact_.upload_state(s.contacts);
    flags_merged_ = false;
    if (integrates()) refresh_held_flags();
  }

  void download() override {
    const LoopParts& s = p_;
    complete_forces();
    const auto t0 = Clock::now();
    x_.download(s.x);
    v_.download(s.v);
    f_.download(s.f);
    elements_.download_state(s.ce6, s.ce6_broke);
    s.loads.each([&](auto& load) { load.download_state(); });
    if (s.contacts.enabled()) contact_.download_state(s.contacts);
    t_.copies += seconds_since(t0);
  }

  void poison_host() override { poison_host_state(p_, waiting_.force_sums, integrates()); }

  real kinetic2() override {
    complete_forces();
    const Vec3* v = v_.data();
    const real* mass = mass_.data();
    const std::uint8_t* own_n = own_node_.data();
    return Exec::template sum<1>(int(v_.size()), [=] FDEM_LAMBDA(int n, real* acc) {
      if (own_n[n]) acc[0] += mass[n] * dot(v[n], v[n]);
    })[0];
  }

  // A step's sums stay on the device (sums_, SumSlots). They come to the host once per step on
  // one rank, with the step's first copy, and twice on several ranks (docs/device-loop.md, "Sums
  // and the step's one copy").

  /// A step, its passes in order: the integration (where the fused pass integrates: that pass,
  /// with the elements), the powers with the new velocities, then the forces at the new state.
  /// The step's bookkeeping (StepBookkeeping::finish_step) runs at its first copy to the host: on
  /// one rank the copy inside the forces, on several ranks the integration's own.
  bool step(real dt) override {
    const LoopParts& s = p_;
    ++t_.steps;
    clock_.restart();
    if (integrates()) {  // one rank: the fused pass takes the step
      forces_with_step(true, dt);
      return false;
    }
    // Several ranks with contact: the owned nodes a quarter of the contact reach from where the
    // contact ghosts were last gathered (time to gather them again) and half the reach (too
    // late: Solver::finish_step). Prescribed nodes count before their prescription.
    const bool reach_check = s.layout.halo && s.contacts.enabled() && s.layout.dd.reach > 0;
    integrate_nodes(dt, reach_check ? contact_.plan_x() : nullptr, s.layout.dd.reach);
    clock_.lap(t_.integrate);
    if (s.layout.halo) halo_.update_nodes(*s.layout.halo, x_, v_, s.layout.halo_seconds);  // ghosts: their owners'
    new_powers(s.contacts.enabled(), s.loads.surface.enabled, s.loads.gravity.enabled);
    if (!s.layout.dd.distributed()) {  // the sums wait for the first copy of the forces
      clock_.lap(t_.energy);
      eval_ahead_ = dt;  // (the forces at the new state, before the clock moves on)
      forces(true);
      eval_ahead_ = 0;
      return false;
    }
    // Several ranks: the step's reduction first (finish_step), then contact ghosts if it asks.
    if (s.book.finish_step(ranks_step_sums())) return true;
    clock_.restart();  // (the reduction's wait is no pass's time)
    forces(false);
    return false;
  }

  void evaluate() override {
    clock_.restart();
    if (integrates())
      forces_with_step(false, 0);
    else
      forces(false);
  }

  /// The forces at the state by the colour or the fused schedule, its passes in order.
  /// `finish`: one rank, the step's sums wait on the device: its bookkeeping runs at this
  /// evaluation's copy.
  void forces(bool finish) {
    const LoopParts& s = p_;
    // The last evaluation's scalars, kept at kPrev where they wait: they come with this
    // evaluation's copy. An evaluation without a step before it brings them first.
    if (waiting_.force_sums && !finish) settle();
    const bool prev = waiting_.force_sums;
    const KeepAndClear keep_and_clear{sums_.data(), prev, kBad};
    Exec::forall(1, [=] FDEM_LAMBDA(int) { keep_and_clear(); });
    element_forces(s, false, 0, keep_and_clear);
    // The broad phase's watch: has a node of an active tet moved half the buffer? (A count.)
    ContactSet& cs = s.contacts;
    if (cs.enabled()) activate(0, true);
    clock_.lap(t_.activation);
    const std::array<real, kAll> a = read_sums<kAll>();  // the step's one copy
    if (finish) finish_step_at_copy(s, a, prev, false);
    clock_.lap(t_.activation);
    name_inverted(s, a[kInverted]);
    s.loads.gravity.power = a[kGravity];
    if (s.layout.halo && cs.enabled()) merge_shared_flags(s);
    // Tet-tet contact: the candidate list rebuilt when flags changed or a node moved half the
    // buffer; the pairs, friction and their per-node sum.
    if (cs.enabled()) contact_forces(s, cs.rebuild_due || a[kMoved] > 0, false);
    // Adaptive activation, on the evaluations where a CE6 broke, for the next one's contact.
    if (a[kBreaks] > 0) activate(elements_.ce6_slots(), false);
    clock_.lap(t_.activation);
    platens_and_pressure(s, s.loads.platens.top_offset, s.time, false);
    // The scalars stay on the device: one rank reads them with the next step's copy, several
    // ranks with the integration's sums (ranks_step_sums()), and sum them over the ranks in the
    // step's one reduction (take_reduced); or settle() before either.
    waiting_.force_sums = true;
  }

  /// Where the fused pass integrates (one rank): the step of dt (0: none), then the forces at
  /// the state it leads to, its passes in order. The element part of an evaluation waits for the
  /// next step: that step's pass computes the elements at the state the last evaluation left,
  /// adds the forces contact, platens and pressure put there, and moves its nodes (fused_pass,
  /// kStep). Where a read of the state completed them since (complete_forces), the step is the
  /// integration's own passes. `finish` as forces().
  void forces_with_step(bool finish, real dt) {
    const LoopParts& s = p_;
    if (waiting_.force_sums && !finish) settle();
    const bool prev = waiting_.force_sums;
    const bool stepping = dt > 0 && waiting_.elements;
    if (dt > 0 && !stepping) {
      integrate_nodes(dt, nullptr, 0);
      new_powers(s.contacts.enabled(), s.loads.surface.enabled, s.loads.gravity.enabled);
      clock_.lap(t_.integrate);
    }
    // The last evaluation's scalars kept at kPrev, then the slots cleared: where the fused pass
    // steps, in its launch (before it adds its sums).
    const KeepAndClear keep_and_clear{sums_.data(), prev, stepping ? kSums : kBad};
    if (!stepping) Exec::forall(1, [=] FDEM_LAMBDA(int) { keep_and_clear(); });
    element_forces(s, stepping, dt, keep_and_clear);  // (the watch with the new powers)
    ContactSet& cs = s.contacts;
    if (cs.enabled() && !stepping) activate(0, true);
    clock_.lap(t_.activation);
    // The step's one copy to the host, with the rest of the evaluation queued behind it so that
    // the device works while the host decides: contact's pairs on the list as it stands, the
    // platens and the pressure at the travel and time the step leads to. A rebuild runs the pairs
    // again (docs/device-loop.md, "Auto: the step in the fused pass").
    std::array<real, kAll> a;
    device::read_start(b_, sums_.data(), sizeof a);
    const bool ahead = cs.enabled() && !cs.rebuild_due;
    // The per-node sum of the pairs' forces queued ahead goes into the platens' launch (both write
    // forces held for the pass: their order changes no sum); after a rebuild, its own launch.
    const bool gather_with_platens = ahead && s.loads.platens.enabled;
    if (ahead) contact_pairs(s, !gather_with_platens);
    platens_and_pressure(s, finish ? s.loads.platens.top_offset_after(s.dt) : s.loads.platens.top_offset,
                         finish ? (s.time + s.dt) : s.time, gather_with_platens);
    device::read_finish(b_, a.data(), sizeof a);
    if (stepping) take_stepped_sums(s, a);
    if (finish) finish_step_at_copy(s, a, prev, stepping);
    clock_.lap(t_.activation);
    // Inverted TET4s of an evaluation completed before the step without settle() (by a download)
    // are named now, a step late. (The pass's own: in take_stepped_sums.)
    name_inverted(s, stepping ? 0 : a[kInverted] + (finish && prev ? a[kPrev + kInverted] : 0));
    // Tet-tet contact: the candidate list rebuilt when flags changed or a node moved half the
    // buffer; the pairs again after a rebuild, else those queued ahead. (Activation by the
    // pass's breaks: in take_stepped_sums.)
    if (cs.enabled()) contact_forces(s, cs.rebuild_due || a[kMoved] > 0 || a[kWatched] > 0, ahead);
    clock_.lap(t_.activation);
    waiting_.force_sums = true;
    waiting_.elements = true;
  }

  /// One rank, at the step's copy `a`: the last evaluation's scalars to the Solver (unless the
  /// fused pass `stepped` and took them), then the step's bookkeeping and checks (may throw).
  void finish_step_at_copy(const LoopParts& s, const std::array<real, kAll>& a, bool prev, bool stepped) {
    if (prev && !stepped) apply_force_sums(s, ForceSums::from_slots(a.data() + kPrev));
    if (s.book.finish_step(advance_sums_from(a.data())))
      throw RunError("device loop: a step on one rank asked to gather contact ghosts");
  }

  /// `inverted` > 0: rare, a TET4 inverted in the elements computed; the host finds and names it.
  void name_inverted(const LoopParts& s, real inverted) {
    if (!(inverted > 0)) return;
    download();
    s.book.report_inverted();
  }

  // The parts of forces(). (Public where they hold a pass: nvcc's extended lambdas need
  // their enclosing function public.)

  /// The elements' forces by the schedule: colour by colour or fused, after the start of each
  /// node's force; where the fused pass integrates, the last evaluation's elements with the step
  /// of dt (`stepping`), else nothing (they wait for that pass).
  void element_forces(const LoopParts& s, bool stepping, real dt, const KeepAndClear& keep_and_clear) {
    switch (schedule_) {
      case ElementSchedule::colour:
        start_forces();
        elements_.colour_forces(s.model, element_inputs(s), clock_, t_);
        break;
      case ElementSchedule::fused:
        start_forces();
        elements_.template fused_pass<Elements::kForces>(element_inputs(s), HeldForces{}, FusedStep{});
        clock_.lap(t_.ce6);  // (the TET4 column stays empty)
        break;
      case ElementSchedule::fused_with_step:
        if (stepping) step_in_fused_pass(s, dt, keep_and_clear);
        break;
    }
  }

  /// The start of each node's force: gravity's, with its power; without gravity, zero at the
  /// nodes no TET4 reaches (the TET4 pass assigns each other node's first force, so f is not
  /// written twice).
  void start_forces() {
    Vec3* f = f_.data();
    const GravityLoad& gravity = p_.loads.gravity;
    if (gravity.enabled) {
      gravity.start_forces<Exec>(int(x_.size()), mass_.data(), v_.data(), own_node_.data(), f, sums_.data(),
                                 p_.time + eval_ahead_);
      return;
    }
    const int* un = unreached_.data();
    Exec::forall(int(unreached_.size()), [=] FDEM_LAMBDA(int k) { f[un[k]] = Vec3{0, 0, 0}; });
  }

  /// The fused pass that integrates: the last evaluation's elements at the state it left, the
  /// forces held for each node, and the step of dt, into the second copies of x and v (then
  /// swapped: the moved state). Then, in one launch, the powers of the last forces with the new
  /// velocities (gravity's: in the pass) and the broad phase's watch (timed as energy).
  void step_in_fused_pass(const LoopParts& s, real dt, const KeepAndClear& keep_and_clear) {
    elements_.template fused_pass<Elements::kStep>(element_inputs(s), held_forces(), fused_step(dt), keep_and_clear);
    std::swap(x_, x2_);
    std::swap(v_, v2_);
    s.loads.prescribed.reaction_power<Exec>(v_.data(), own_node_.data(), dt, sums_.data() + kReactionPower);
    waiting_.elements = false;
    clock_.lap(t_.ce6);  // (the TET4 and integration columns stay empty)
    contact_pressure_powers(s.contacts.enabled(), s.loads.surface.enabled, s.contacts.enabled());
    clock_.lap(t_.energy);
  }

  /// What the element passes read of the node state.
  ElementInputs element_inputs(const LoopParts& s) {
    const GravityLoad& gravity = s.loads.gravity;
    return ElementInputs{x_.data(),       v_.data(),       f_.data(), mass_.data(),
                         own_tet_.data(), gravity.enabled, gravity.g, gravity.pushes(s.time + eval_ahead_),
                         sums_.data()};
  }
  /// The forces held for the fused pass that integrates.
  HeldForces held_forces() const {
    const Loads& l = p_.loads;
    return HeldForces{ext_tet_.data(),        contact_.gather_place(), contact_.held_sum(),
                      l.platens.held_place(), l.platens.held_force(),  l.surface.held()};
  }
  /// The step of dt (s) the fused pass takes: into the second copies of x and v.
  FusedStep fused_step(real dt) {
    return FusedStep{x2_.data(), v2_.data(), p_.loads.prescribed.node_step(mass_.data(), p_.time, dt)};
  }

  /// Where the fused pass stepped: the last evaluation's sums (its contact, platens and pressure
  /// at kPrev; its elements from the pass) to the Solver, from the copy a; an inverted TET4 named
  /// in the state the pass read; the vicinity of the CE6s it broke activated.
  void take_stepped_sums(const LoopParts& s, const std::array<real, kAll>& a) {
    std::array<real, kBad> b;
    for (int k = 0; k < kBad; ++k) b[k] = a[kPrev + k];
    for (int k : {kGravity, kVisc, kInverted, kCoh, kFric, kBreaks}) b[k] = a[k];
    b[kAdded] = 0;
    // Rare: an inverted TET4. The host names the element in the state the pass read (the first
    // copies of x and v, the CE6 states before it), before the step is counted, as the colour
    // passes do.
    if (a[kInverted] > 0) {
      apply_force_sums(s, ForceSums::from_slots(b.data()));
      std::swap(x_, x2_);
      std::swap(v_, v2_);
      elements_.back_to_read_state();
      download();
      s.book.report_inverted();
    }
    // The pass broke CE6s: their vicinity joins the candidates now, for this evaluation's contact
    // (with contact, one value more to the host).
    if (a[kBreaks] > 0) {
      activate(elements_.ce6_slots(), false);
      if (s.contacts.enabled()) device::to_host(b_, &b[kAdded], sums_.data() + kAdded, sizeof(real));
    }
    apply_force_sums(s, ForceSums::from_slots(b.data()));
  }

  /// Several ranks: a flag raised on any rank holding a tet reaches the others before the broad
  /// phase looks at the flags. The ranks merge them together, and only when one of them raised a
  /// flag since the last merge (or took flags from its host): one number in the step's reduction
  /// (take_reduced) instead of the flags' exchange and its three copies, on the steps (most) that
  /// raise none. A layout grown since (Solver::grow_contact_ghosts, on every rank at once) brings
  /// its host's flags with no reduction in between: every rank merges then.
  void merge_shared_flags(const LoopParts& s) {
    if ((merge_wanted_ || !flags_merged_) &&
        halo_.merge_flags(*s.layout.halo, contact_.active(), x_, v_, s.layout.halo_seconds))
      s.contacts.rebuild_due = true;
    merge_wanted_ = false;
    flags_merged_ = true;
  }

  /// Adaptive activation over `flags` CE6 slots and, with `watch`, the broad phase's watch
  /// (ContactPasses::activate).
  void activate(int flags, bool watch) {
    contact_.activate(p_.contacts, flags, watch, elements_.ce6_nodes(), elements_.broke(), x_.data(), sums_.data());
  }

  /// Tet-tet contact: the candidate list rebuilt where `rebuild`; narrow phase, friction and the
  /// deterministic per-node sum, unless they ran `ahead` of the copy on the list as it stands.
  void contact_forces(const LoopParts& s, bool rebuild, bool ahead) {
    ContactSet& cs = s.contacts;
    if (rebuild) {
      if (integrates()) contact_.follow_gather(false);
      contact_.rebuild(cs, elements_.tets(), int(x_.size()), x_.data(), elements_.tet_nodes(),
                       s.layout.distributed() ? own_node_.data() : nullptr, t_);
      if (integrates()) contact_.follow_gather(true), refresh_held_flags();
      ++t_.rebuilds;
    }
    clock_.lap(t_.broad);
    if (rebuild && ahead) clear_sums(kTouching, kConPower + 1);  // the pairs' sums queued ahead go
    if (rebuild || !ahead) contact_pairs(s, true);
    contact_.history_settled();
    // The run's report reads the contact set's clocks (friction: in the narrow phase's pass).
    cs.times.broad = t_.broad;
    cs.times.narrow = t_.narrow + t_.contact_sum;
  }

  /// Contact on the candidate list (ContactPasses::pairs), then (`gather`) the deterministic
  /// per-node sum into f, or where the fused pass integrates into the held sum (there, for pairs
  /// queued ahead with platens, in the platens' launch instead: forces()).
  void contact_pairs(const LoopParts& s, bool gather) {
    // Where the fused pass integrates, the break flags up now are an earlier evaluation's (its
    // pass computes the elements of the last one): not read.
    const PairInputs in{elements_.tet_nodes(),
                        elements_.ce6_slot(),
                        elements_.damage(),
                        integrates() ? nullptr : elements_.broke(),
                        own_tet_.data(),
                        own_node_.data(),
                        x_.data(),
                        v_.data(),
                        s.dt};
    contact_.pairs(s.contacts, in, sums_.data());
    clock_.lap(t_.narrow);
    if (!gather) return;
    contact_.add_forces(f_.data());
    clock_.lap(t_.contact_sum);
  }

  /// The platens' and the confining pressure's forces at the state in x and v, with the top
  /// platen at top_offset (m) and the pressure's ramp at `time` (s): added to f, or where the
  /// fused pass integrates, held for it. `gather`: the contact pairs' per-node sum in the
  /// platens' launch (where the fused pass integrates).
  void platens_and_pressure(const LoopParts& s, real top_offset, real time, bool gather) {
    const Vec3* x = x_.data();
    real* sums = sums_.data();
    PlatenLoad& platens = s.loads.platens;
    if (platens.enabled) {
      const auto platen = platens.forces(top_offset, integrates(), f_.data());
      // After the platen nodes, where it comes here (gather), the pairs' per-node sum (after them,
      // so that the order of the platens' sums does not change with the pairs').
      const int npn = platens.nodes();
      const int ng = gather && s.contacts.enabled() ? int(contact_.gathered_nodes()) : 0;
      const auto pairs = contact_.gather();
      Vec3* held = contact_.held_sum_out();
      Exec::template sum_to<3>(
          npn + ng,
          [=] FDEM_LAMBDA(int i, real* acc) {
            if (i >= npn)
              held[i - npn] = pairs.at(i - npn);
            else
              platen.apply(i, x, acc);
          },
          sums + kTop);
    }
    clock_.lap(t_.platens);
    // Confining pressure, after the platens: on the hydrostatic path it follows this
    // evaluation's platen reactions. Several ranks sum those over the ranks first and put them
    // back on the device (a reduction of their own; the rest of the evaluation's sums wait for
    // the step's).
    SurfaceLoads& cf = s.loads.surface;
    if (cf.enabled && cf.hydrostatic && s.layout.dd.distributed()) {
      device::to_host(b_, reactions_.data(), sums + kTop, sizeof reactions_);
      s.layout.sum(reactions_.data(), 2);
      device::to_device(b_, sums + kTop, reactions_.data(), sizeof reactions_);
    }
    if (cf.enabled) cf.forces<Exec>(s.model.area0, time, x, v_.data(), own_node_.data(), f_.data(), sums);
    clock_.lap(t_.pressure);
  }

  void settle() override {
    const LoopParts& s = p_;
    if (!waiting_.force_sums) return;
    if (s.layout.dd.distributed()) {  // (every rank at once: monitor rows, output, checks after a reduction)
      // (as many values as a step's reduction, zeros first: the same MPI reduction, so the
      // same order of sums whether a monitor row comes between or not)
      rank_sums_ = read_sums<kBad>();
      constexpr int k = StepSums::kValues;
      std::array<real, k + std::tuple_size_v<decltype(AdvanceSums::more)>> all{};
      reduction_values(all.data() + k);
      s.layout.sum(all.data(), int(all.size()));
      take_reduced(all.data() + k);
      return;
    }
    complete_forces();
    const std::array<real, kBad> b = read_sums<kBad>();
    apply_force_sums(s, ForceSums::from_slots(b.data()));
    if (integrates() && b[kInverted] > 0) {  // (completed here: named here)
      download();
      s.book.report_inverted();
    }
  }

  void take_reduced(const real* more) override {
    const LoopParts& s = p_;
    if (waiting_.force_sums) {  // the rank's own sums, the whole model's where they are summed (kWhole)
      std::array<real, kBad> b = rank_sums_;
      for (int k = 0; k < int(kWhole.size()); ++k) b[kWhole[k]] = more[k];
      if (s.loads.surface.enabled && s.loads.surface.hydrostatic)  // summed already (platens_and_pressure)
        b[kTop] = reactions_[0], b[kBottom] = reactions_[1];
      apply_force_sums(s, ForceSums::from_slots(b.data()));
    }
    merge_wanted_ = merge_wanted_ || more[kWhole.size()] > 0;
  }

  void discard_pending() override { waiting_ = Waiting{}; }

 private:
  /// The Solver's bookkeeping of a force evaluation from its sums.
  void apply_force_sums(const LoopParts& s, const ForceSums& b) {
    waiting_.force_sums = false;
    if (b.candidates_changed > 0) s.contacts.rebuild_due = true;  // for the next evaluation's contact
    SurfaceLoads& cf = s.loads.surface;
    s.energy.p_contact = b.contact_power;
    s.energy.contact_slip += b.contact_slip;
    s.energy.contact_spring = b.contact_spring;
    s.energy.contact_stored = b.contact_energy;
    s.contacts.touching = long(b.touching);
    s.loads.platens.force_top = b.platen_top;
    s.loads.platens.force_bottom = b.platen_bottom;
    if (cf.enabled) {
      cf.pressure = cf.pressure_at(s.time, s.loads.platens.axial_stress(s.model.area0));
      cf.power = b.pressure_power;
    }
    s.energy.p_viscous = b.viscous_power;
    s.energy.p_cohesive = b.cohesive_power;
    s.energy.p_friction = b.friction_power;
    s.energy.platen_friction += b.platen_friction;
    if (integrates()) s.loads.gravity.power = b.gravity_power;  // (computed with the elements, by the pass)
  }

 public:
  /// Several ranks: the integration's sums and the last force evaluation's in one copy, for the
  /// step's reduction. The powers of that evaluation with which the works of the step begin
  /// (Solver::step_sums) are the rank's own.
  AdvanceSums ranks_step_sums() {
    const LoopParts& s = p_;
    const std::array<real, kSums> r = read_sums<kSums>();
    clock_.lap(t_.energy);
    AdvanceSums out = advance_sums_from(r.data());
    if (waiting_.force_sums) {
      std::copy(r.begin(), r.begin() + kBad, rank_sums_.begin());
      s.energy.p_contact = r[kConPower];
      if (s.loads.surface.enabled) s.loads.surface.power = r[kPressurePower];
    }
    out.n_more = int(out.more.size());
    reduction_values(out.more.data());
    return out;
  }

  /// Several ranks: what this rank adds to the step's reduction (take_reduced): the waiting
  /// evaluation's sums that the whole model sums (zero where none waits: the same on every
  /// rank), and 1 where it activated tets since the last merge or took flags from its host.
  void reduction_values(real* more) const {
    static_assert(kWhole.size() + 1 == std::tuple_size_v<decltype(AdvanceSums::more)>, "the step's reduction");
    for (int k = 0; k < int(kWhole.size()); ++k) more[k] = waiting_.force_sums ? rank_sums_[kWhole[k]] : 0;
    more[kWhole.size()] = (waiting_.force_sums && rank_sums_[kAdded] > 0) || !flags_merged_ ? 1 : 0;
  }

  /// Central difference of every node with time step dt into sums [kBad, kSums) (cleared first:
  /// non-finite velocities, m v.v after the prescription, and with px the nodes a quarter and half of `reach` from px;
  /// gravity's power is the caller's), then the prescribed velocities.
  void integrate_nodes(real dt, const Vec3* px, real reach) {
    Vec3* x = x_.data();
    Vec3* v = v_.data();
    const Vec3* f = f_.data();
    const real* mass = mass_.data();
    const std::uint8_t* own_n = own_node_.data();
    clear_sums(kBad, kSums);
    const real lim2 = 0.0625 * reach * reach;
    static_assert(kKinetic2 == kBad + 1 && kFar == kBad + 3 && kLost == kBad + 4, "the integration's sums");
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
    PrescribedVelocities& prescribed = p_.loads.prescribed;
    if (!prescribed.on()) return;
    prescribed.apply<Exec>(x, v, mass, p_.time, dt);
    prescribed.reaction_power<Exec>(v, own_n, dt, sums_.data() + kReactionPower);
    prescribed.kinetic_change<Exec>(v, mass, own_n, dt, sums_.data() + kKinetic2);
  }

  /// The powers of the last contact and pressure forces, and of gravity, with the velocities now
  /// (the work over a step with the mean of the velocities before and after it).
  void new_powers(bool contact, bool pressure, bool gravity) {
    contact_pressure_powers(contact, pressure, false);
    if (gravity)
      p_.loads.gravity.new_power<Exec>(int(x_.size()), mass_.data(), v_.data(), own_node_.data(), sums_.data(),
                                       p_.time);
  }

  /// The powers of the last contact pair forces (-sum f.v) and confining pressure forces with
  /// the velocities now, added to kConPowerNew and kPressurePowerNew in one launch (the pairs,
  /// then the faces); with `watch`, the broad phase's watch too (the watched nodes after them,
  /// counted into kWatched; where the fused pass steps, this saves the watch a launch).
  void contact_pressure_powers(bool contact, bool pressure, bool watch) {
    SurfaceLoads& cf = p_.loads.surface;
    const int np = contact ? int(contact_.pairs()) : 0, nf = pressure ? cf.face_count() : 0;
    const int nw = watch ? contact_.watched() : 0;
    const auto pair = contact_.power(elements_.tet_nodes());
    const auto face = cf.new_power(p_.dt);
    const auto moved = contact_.watch(p_.contacts.buffer());
    const Vec3* x = x_.data();
    const Vec3* v = v_.data();
    const std::uint8_t* own_n = own_node_.data();
    static_assert(kPressurePowerNew == kConPowerNew + 1 && kWatched == kConPowerNew + 2, "the new powers' slots");
    Exec::template sum_to<3>(
        np + nf + nw,
        [=] FDEM_LAMBDA(int k, real* acc) {
          if (k >= np + nf) {
            if (moved.moved(k - np - nf, x)) acc[2] += 1;
          } else if (k >= np) {
            face.add(k - np, v, own_n, acc[1]);
          } else {
            pair.subtract(k, v, own_n, acc[0]);
          }
        },
        sums_.data() + kConPowerNew);
  }

  /// Where the fused pass integrates: the element part of the last evaluation, left to the next
  /// step's pass, done now by the same pass without the step (f: each node's whole force, the
  /// colour passes'), then the activation by its breaks. Its sums go to the evaluation's slots.
  void complete_forces() {
    if (!waiting_.elements) return;
    waiting_.elements = false;
    {  // the slots of the elements' sums and the activation's count (the last step's pass left
       // its own there): cleared; the sums add to them
      real* sums = sums_.data();
      Exec::forall(kBreaks + 1 - kGravity, [=] FDEM_LAMBDA(int k) {
        sums[kGravity + k] = 0;
        if (k == 0) sums[kAdded] = 0;
      });
    }
    elements_.template fused_pass<Elements::kComplete>(element_inputs(p_), held_forces(), FusedStep{});
    activate(elements_.ce6_slots(), false);
  }

  MonitorSums measure_sums() override {
    const LoopParts& s = p_;
    complete_forces();
    const auto t0 = Clock::now();
    MonitorSums out;
    lateral_strain(s.model, out);
    out.kinetic = 0.5 * kinetic2();
    elements_.measure(x_.data(), v_.data(), own_tet_.data(), mid_third_.data(), out);
    if (s.loads.platens.enabled) out.platen_stored = s.loads.platens.stored<Exec>(x_.data());
    if (s.contacts.enabled()) contact_.measure(own_tet_.data(), out);
    t_.monitor += seconds_since(t0);
    return out;
  }

  /// The owned lateral nodes' radial displacement over their radius, summed, and their count
  /// (a disc: radial in x only).
  void lateral_strain(const Model& m, MonitorSums& out) const {
    const Vec3* x = x_.data();
    const Vec3* X = X_.data();
    const Vec3 axis = m.axis_point;
    const bool disc = m.line_loaded;
    const int* ln = lateral_nodes_.data();
    const std::uint8_t* own_n = own_node_.data();
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
  }

  double bytes_per_step() const override {
    const double nn = double(x_.size()), nt = double(elements_.computed_tets());
    const double vec = sizeof(Vec3);
    // Gravity (f written from m and v) or the zeroing of the nodes no TET4 reaches; integration
    // (x, v, f, m; 1/m divided) and the kinetic-energy sum.
    const Loads& loads = p_.loads;
    const double start =
        loads.gravity.enabled ? nn * (vec + vec + sizeof(real)) : double(unreached_.size()) * (vec + sizeof(int));
    // Where the fused pass integrates, each tet moves its own 4 nodes instead (m read, x and v
    // written to the second copies; its place in the prescribed lists) after adding what contact,
    // platens and pressure hold for it (its flags; where flagged, each node's places, and the sum
    // or force there). (Static flags: 3 places per node of a flagged tet; the gather's nodes:
    // their place, their sum written by the gather and read by the pass; platen and face forces
    // read.) The tet's own x and v are read again for the step.
    const double ng = double(contact_.gathered_nodes());
    const double held = nt + double(ext_nodes_) * 3 * sizeof(int) + ng * (sizeof(int) + 2 * vec) +
                        double(loads.platens.nodes() + loads.surface.node_face_entries()) * vec;
    const double mass_read = elements_.mass_from_volume() ? 0 : sizeof(real);  // (else from V0, read for TET4)
    const double node = integrates()
                            ? nt * 4 * (4 * vec + mass_read + (loads.prescribed.per_node() ? sizeof(int) : 0)) + held
                            : start + nn * (5 * vec + sizeof(real));
    return elements_.bytes_per_step(loads.gravity.enabled, integrates()) + contact_.bytes_per_step() + node;
  }

 private:
  using Clock = std::chrono::steady_clock;
  static double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

 public:  // (nvcc's device lambdas cannot live in private member functions)
  /// Zero sums_[from, to) on the device.
  void clear_sums(int from, int to) {
    real* p = sums_.data();
    Exec::forall(to - from, [=] FDEM_LAMBDA(int k) { p[from + k] = 0; });
  }

 private:
  /// sums_[0, N) on the host (one copy).
  template <int N>
  std::array<real, N> read_sums() const {
    static_assert(N <= kAll, "beyond the sums");
    std::array<real, N> out;
    device::to_host(b_, out.data(), sums_.data(), N * sizeof(real));
    return out;
  }

  LoopParts p_;  // the run the loop steps
  Backend b_;
  bool direct_mpi_;  // device buffers straight to MPI (partition/halo.hpp), fixed at construction
  // The element passes' schedule (make_device_loop): colour by colour, fused in one pass over
  // the tets, or fused with the step (one rank; DeviceLoop::integrates). The other passes
  // follow it where the held forces and the step left to the pass need them.
  enum class ElementSchedule { colour, fused, fused_with_step };
  ElementSchedule schedule_;
  bool constants_ = false;
  PassClock<Exec> clock_;
  DeviceTimes t_;
  // The parts.
  Elements elements_;
  ContactPasses<Exec> contact_;
  HaloPasses<Exec> halo_;  // several ranks
  // The node state and this rank's layout.
  DeviceArray<Vec3> X_, x_, v_, f_;
  DeviceArray<real> mass_;  // kg
  DeviceArray<std::uint8_t> own_node_, own_tet_, mid_third_;
  DeviceArray<int> unreached_, lateral_nodes_;
  // The step's sums (SumSlots). Several ranks: the last force evaluation's sums on this rank,
  // read with the integration's and waiting for the step's reduction (take_reduced); on the
  // hydrostatic path, its platen reactions summed over the ranks (platens_and_pressure).
  DeviceArray<real> sums_;
  std::array<real, kBad> rank_sums_{};
  std::array<real, 2> reactions_{};
  // What waits between the loop's calls: sums on the device that the Solver has not taken, and,
  // where the fused pass integrates (integrates()), work left to the next step's pass (which
  // writes the second copies of x and v, swapped after it).
  struct Waiting {
    bool force_sums = false;  // the last force evaluation's scalars, sums_ [0, kBad)
    bool elements = false;    // the last evaluation's element part, left to the next step's pass
  } waiting_;
  // s: how far ahead of the clock the state is whose forces are being evaluated (one rank's
  // colour step evaluates the new state before its bookkeeping moves the clock on).
  real eval_ahead_ = 0;
  bool flags_merged_ = false;  // false from an upload of the host's flags to the next merge
  bool merge_wanted_ = false;  // several ranks: a rank raised a flag (the step's reduction said)
  // The forces that contact, platens and pressure put on a node wait for the fused pass in
  // arrays of their parts, read only for the tets flagged in ext_tet_ (bit 0: a node in the
  // gather list, bit 1: on a platen or a lateral face; ext_static_).
  long ext_nodes_ = 0;  // nodes of the tets ext_static_ flags (the traffic model)
  DeviceArray<Vec3> x2_, v2_;
  DeviceArray<std::uint8_t> ext_tet_, ext_static_;
};

}  // namespace fdem
