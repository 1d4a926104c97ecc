#include "solver/solver.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/gather.hpp"
#include "io/checkpoint.hpp"
#include "model/initial_stress.hpp"
#include "model/laws.hpp"
#include "partition/grow.hpp"
#include "partition/halo.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"

namespace fdem {

Solver::Solver(const Scene& scene, Model model, Decomposition dd, MPI_Comm comm)
    : scene_(scene), model_(std::move(model)) {
  layout_.comm = comm;
  setup(std::move(dd));
  model_fp_ = whole_model_fingerprint();  // (before an excavation stage changes a tet's stiffness)
  backend_ = scene_.solver.backend;
  dev_ = make_device_loop(backend_, loop_parts());
  compute_forces();
  // The host copy holds the whole state (forces and contact pairs included), and the first step
  // starts from it: code may set velocities or prescriptions before it, as on a new state.
  sync_host();
  host_changed();
}

LoopParts Solver::loop_parts() {
  return LoopParts{scene_,  model_,    laws_,           layout_,  dt_,    state.time, state.x, state.v,
                   state.f, state.ce6, state.ce6_broke, contacts, loads_, energy_,    *this};
}

void Solver::setup(Decomposition dd) {
  set_up_layout(std::move(dd), false);
  const SolverSettings& sol = scene_.solver;
  stable_ = stable_step_bound(model_, scene_, laws_, loads_.platens.k, layout_);
  stable_.dt = sol.time_step_safety * stable_.dt;
  dt_ = sol.time_step > 0 ? sol.time_step : stable_.dt;
  check_step_count();

  real volume = 0;
  for (std::size_t t = 0; t < model_.tet_V0.size(); ++t) volume += layout_.own_tet[t] * model_.tet_V0[t];
  layout_.sum(&volume, 1);
  // The noise floor: a thousandth of the elastic energy at the tensile strength, the least of
  // the materials'.
  real energy_density = 1e300;  // J/m^3
  for (const Material& mat : scene_.materials)
    energy_density = std::min(energy_density, mat.tensile_strength * mat.tensile_strength / (2 * mat.youngs_modulus));
  energy_.floor = 1e-3 * energy_density * volume;
  energy_.in_situ = in_situ_energy();
  energy_.cohesive_start = in_situ_cohesive_energy();
}

void Solver::set_up_layout(Decomposition dd, bool keep_state) {
  const SolverSettings& sol = scene_.solver;
  if (sol.threads > 0) omp_set_num_threads(sol.threads);
  laws_ = make_element_laws(scene_);
  if (!keep_state) state.start(model_.X, model_.ce6_nodes.size());
  layout_.set_up(model_, std::move(dd), scene_.contact.enabled());
  contacts = ContactSet(model_, scene_);
  if (layout_.distributed()) {
    contacts.set_ownership(&layout_.own_tet, layout_.dd.reach);
    if (!keep_state) contacts.set_plan(model_.X);  // (a growth sets it from the positions reached)
  }

  check_law_indices();
  break_frictional_joints();
  place_initial_stress(scene_, laws_, model_);
  locate_history_points();
  // The loads' automatic ramps last ten transits of the slowest P wave (the longest transit).
  real wave_speed = 1e300;
  for (const Tet4Law& l : laws_.tet4) wave_speed = std::min(wave_speed, std::sqrt((l.lambda + 2 * l.mu) / l.density));
  loads_ = make_loads(scene_, model_, wave_speed);
  remove_excavated();  // (after a growth: the stages done so far)
}

real Solver::in_situ_cohesive_energy() const {
  const Model& m = model_;
  real sum = 0;
  for (std::size_t c = 0; c < m.ce6_prestress.size(); ++c) {
    if (!layout_.own_ce6[c] || ce6_broken(state.ce6.damage[c])) continue;
    Vec3 x[6], v[6] = {}, f[6];
    for (int i = 0; i < 6; ++i) x[i] = m.X[m.ce6_nodes[c][i]];
    Ce6Damage intact{};
    Vec3 anchors[3] = {};
    const real strength = m.ce6_strength.empty() ? real(1) : m.ce6_strength[c];
    sum +=
        cohesive6_forces(laws_.ce6[m.ce6_law[c]], x, v, m.ce6_h[c], intact, anchors, f, strength, &m.ce6_prestress[c])
            .stored;
  }
  layout_.sum(&sum, 1);
  return sum;
}

real Solver::in_situ_energy() const {
  const Model& m = model_;
  real sum = 0;
  for (std::size_t t = 0; t < m.tet_initial_stress.size(); ++t) {
    if (!layout_.own_tet[t]) continue;
    const Sym3& s = m.tet_initial_stress[t];
    const Tet4Law l = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    if (!(l.mu > 0)) continue;  // (removed by an excavation)
    const real ss = s.xx * s.xx + s.yy * s.yy + s.zz * s.zz + 2 * (s.yz * s.yz + s.xz * s.xz + s.xy * s.xy);
    const real tr = s.xx + s.yy + s.zz;
    sum += m.tet_V0[t] * (ss - l.lambda / (3 * l.lambda + 2 * l.mu) * tr * tr) / (4 * l.mu);
  }
  layout_.sum(&sum, 1);
  return sum;
}

void Solver::check_law_indices() const {
  const Model& m = model_;
  bool ok = m.tet_material.size() == m.tet_nodes.size() && m.ce6_law.size() == m.ce6_nodes.size();
  for (std::uint8_t k : m.tet_material) ok = ok && k < laws_.tet4.size();
  for (std::uint8_t k : m.ce6_law) ok = ok && k < laws_.ce6.size();
  ok = ok && (m.ce6_strength.empty() || m.ce6_strength.size() == m.ce6_nodes.size());
  ok = ok && (m.tet_stiffness.empty() || m.tet_stiffness.size() == m.tet_nodes.size());
  for (std::size_t t = 0; t < m.tet_stiffness.size(); ++t)  // (0: an excavation stage's)
    ok = ok && m.tet_stiffness[t] < 1e6 && (m.tet_stiffness[t] > 0 || stage_of(t) != 0);
  for (std::size_t t = 0; t < m.tet_stage.size(); ++t) ok = ok && m.tet_stage[t] <= scene_.excavation.size();
  ok = ok && (m.tet_joint.empty() || m.tet_joint.size() == m.tet_nodes.size());
  for (std::uint8_t j : m.tet_joint) ok = ok && j <= laws_.joint_friction.size();
  if (ok)  // (rank files: drawn at the partition, perhaps with another law than this scene's)
    for (std::size_t c = 0; c < m.ce6_strength.size(); ++c) {
      if (laws_.joint_of_law(m.ce6_law[c]) >= 0) continue;  // (a joint draws no factor: 1)
      const real s = m.ce6_strength[c];
      if (!(s > 0) || !(s < largest_strength_factor(laws_.ce6[m.ce6_law[c]], m.ce6_h[c])))
        throw InputError(m.source + ": CE6 " + std::to_string(c + 1) + " has strength factor " + fmt(s, 4) +
                         ", beyond what this scene's cohesive law takes at its size. Fix: run fdem partition "
                         "again with this scene, or narrow the heterogeneity");
    }
  if (!ok)
    throw InputError(m.source + ": the model's materials do not match the scene's " +
                     std::to_string(laws_.tet4.size()) + " materials and " + std::to_string(laws_.ce6.size()) +
                     " CE6 laws. Fix: build the model (or run fdem partition) again with this scene");
}

void Solver::break_frictional_joints() {
  for (std::size_t c = 0; c < model_.ce6_law.size(); ++c) {
    const int j = laws_.joint_of_law(model_.ce6_law[c]);
    if (j < 0 || !laws_.joint_frictional[j]) continue;
    Ce6Damage& d = state.ce6.damage[c];
    d.D[0] = d.D[1] = d.D[2] = 1;
    d.mode = kCe6NeverBonded;
    contacts.activate_ce6(model_, int(c));
  }
}

void Solver::grow_contact_ghosts() {
  const double t0 = MPI_Wtime();
  sync_host();
  const GhostStateNow now{state.x, state.v, state.ce6.damage, state.ce6.anchors, contacts.tet_flags};
  // The model, then the state, grow in place; the loop, which reads their arrays, is not used
  // again before relayout() or restart_device() replaces it.
  const GhostGrowth g = fdem::grow_contact_ghosts(layout_.comm, model_, layout_.dd, now);
  ++growth_.count;
  growth_.step = state.step;
  if (g.added_total == 0) {
    ++growth_.unchanged;  // no rank lacked a tet: the layout stays
  } else {
    // The layout is set up for the grown model. The state of the nodes and the CE6s stays and
    // takes the ghosts' appended; the contact pairs, the bulk of the rest, move over. The
    // loads' state, a few arrays, goes through a checkpoint's payload.
    state.append(g.added);
    if (state.x.size() != model_.X.size() || state.ce6.size() != model_.ce6_nodes.size())
      throw RunError("contact ghosts: the grown model has " + std::to_string(model_.X.size()) + " nodes and " +
                     std::to_string(model_.ce6_nodes.size()) + " CE6s, the state " + std::to_string(state.x.size()) +
                     " and " + std::to_string(state.ce6.size()));
    ContactSet moved = std::move(contacts);
    CheckpointOut kept_loads;
    loads_.save(kept_loads);
    relayout(std::move(layout_.dd), true);
    CheckpointIn in(kept_loads.payload(), "the loads' state before the contact ghosts grew");
    loads_.load(in, true);
    in.finish();
    contacts.carry_from(std::move(moved), g.added.active);
    growth_.tets += g.added_total;
    grown_ = true;
  }
  contacts.set_plan(state.x);  // the reach counts from here
  restart_device();            // (a loop of its own: the step's deferred sums start afresh on every rank)
  growth_.seconds += MPI_Wtime() - t0;
}

void Solver::adopt_layout(RankModel rm) {
  model_ = std::move(rm.model);
  relayout(std::move(rm.dd), false);
}

void Solver::relayout(Decomposition dd, bool keep_state) {
  dev_.reset();
  layout_.halo.reset();                                         // (it refers to the model's connectivity)
  std::vector<NodePush> push = std::move(loads_.gravity.push);  // (the ghosts' nodes appended: none)
  const real relax_start = loads_.gravity.relax_start, relax_time = loads_.gravity.relax_time;
  set_up_layout(std::move(dd), keep_state);
  loads_.gravity.relax_start = relax_start, loads_.gravity.relax_time = relax_time;
  if (!push.empty()) push.resize(model_.X.size()), loads_.gravity.push = std::move(push);
}

void Solver::restart_device() {
  dev_ = make_device_loop(backend_, loop_parts());
  dev_->upload();
  device_current_ = true;
  host_current_ = true;
}

void Solver::sync_host() const {
  // The scalars of the last force evaluation come with the state: completing the bookkeeping
  // of the step already taken does not change the solver's state either.
  if (!dev_) return;  // (between two layouts, a failed growth: the host copy is the state)
  dev_->settle();
  if (host_current_) return;
  // The host copy is a cache of the device state: bringing it up to date does not change the
  // solver's state, so it is allowed on a const solver.
  dev_->download();
  host_current_ = true;
}

void Solver::report_inverted() const {
  sync_host();
  const Model& m = model_;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (removed_tet(t)) continue;  // (no stiffness: it may fold, as the device's count allows)
    Vec3 xe[4], ve[4], fe[4];
    gather(state.x, m.tet_nodes[t], xe);
    gather(state.v, m.tet_nodes[t], ve);
    const Tet4Law l = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    const Tet4Eval r =
        tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], l.lambda, l.mu, m.tet_eta[t], fe, m.initial_stress_of(t));
    if (!(r.J > 0))
      throw RunError("step " + std::to_string(state.step) + " (t = " + fmt(state.time, 3) + " s): TET4 #" +
                     std::to_string(model_.tet_input[t] + 1) + " inverted (J = " + fmt(r.J, 3) +
                     "). The run is unstable. " + instability_advice());
  }
  throw RunError("step " + std::to_string(state.step) + ": a TET4 inverted on the device but not in the host copy");
}

void Solver::prescribe(int node, int mask, Vec3 velocity) {
  // The state first: the host copy brought up to date (the element part of an evaluation left
  // to the fused pass completed), before its velocities and the lists change (on the cpu
  // backend the loop borrows the lists).
  sync_host();
  loads_.prescribed.set(node, mask, velocity, state.time);
  for (int d = 0; d < 3; ++d)
    if (mask >> d & 1) state.v[node][d] = velocity[d];
  host_changed();
}

void Solver::compute_forces() {
  upload_if_changed();
  dev_->evaluate();
  host_current_ = false;  // the forces (and after a growth of the contact ghosts, more) changed there
}

void Solver::upload_if_changed() {
  if (device_current_) return;
  dev_->upload();
  device_current_ = true;
}

void Solver::check_finite(long bad_nodes) const {
  if (bad_nodes == 0) return;
  int first = -1;  // (a prescribed node counted as bad has had its velocity reset: then none here)
  for (std::size_t n = 0; n < state.v.size(); ++n)
    if (layout_.own_node[n] && !std::isfinite(state.v[n].x + state.v[n].y + state.v[n].z)) {
      first = int(n);
      break;
    }
  if (first < 0)
    throw RunError("step " + std::to_string(state.step) + " (t = " + fmt(state.time, 3) + " s): the velocity of " +
                   std::to_string(bad_nodes) + " node(s) is no longer finite" +
                   (layout_.dd.distributed() ? " (on another rank)" : "") + ". The run is unstable. " +
                   instability_advice());
  throw RunError("step " + std::to_string(state.step) + " (t = " + fmt(state.time, 3) + " s): the velocity of " +
                 std::to_string(bad_nodes) + " node(s) is no longer finite (first: node " +
                 std::to_string((layout_.dd.distributed() ? layout_.dd.node_global[first] : long(first)) + 1) +
                 " at reference position " + fmt(model_.X[first].x, 3) + ", " + fmt(model_.X[first].y, 3) + ", " +
                 fmt(model_.X[first].z, 3) + " m). The run is unstable. " + instability_advice());
}

Solver::EndSteps Solver::end_steps() const {
  const EndCondition& end = scene_.solver.end;
  EndSteps e{INFINITY, ""};
  if (end.steps > 0) e = {real(end.steps), "solver.end.steps"};
  if (end.time > 0 && end.time / dt_ < e.steps) e = {end.time / dt_, "solver.end.time"};
  if (end.axial_strain > 0 && scene_.platens.enabled) {
    const real n = end.axial_strain * model_.height0 / scene_.platens.velocity / dt_;  // (a time, then steps)
    if (n < e.steps) e = {n, "solver.end.axial_strain"};
  }
  return e;
}

void Solver::check_step_count() const {
  const std::string file = scene_.file.empty() ? "the scene" : scene_.file;
  if (!(dt_ > 0) || !std::isfinite(dt_))
    throw InputError(file + ": the time step is " + fmt(dt_) +
                     " s: the material (youngs_modulus, density, the penalties), solver.mass_scaling or mesh.scale "
                     "lie beyond what double precision resolves. Fix: give them in SI units (Pa, kg/m^3, m) at a "
                     "rock's scale");
  const SolverSettings& sol = scene_.solver;
  const real bound = stable_bound();
  if (sol.time_step > SolverSettings::kMaxSafety * bound)
    throw TimeStepBeyondBound(
        file + ": solver.time_step: " + fmt(sol.time_step, 6) + " s is " + fmt(sol.time_step / bound, 3) +
        " x the stable-step bound " + fmt(bound, 3) + " s (limited by " + stable_.limit + "); beyond " +
        fmt(SolverSettings::kMaxSafety) +
        " x it no run is stable (the limit of time_step_safety). Fix: lower solver.time_step, or set it "
        "to 0 for the bound times solver.time_step_safety");
  // Beyond 1e12 steps (weeks at the fastest step rates) a run would not finish: a slip of units.
  const EndSteps e = end_steps();
  if (e.steps > 1e12 && std::isfinite(e.steps))
    throw InputError(file + ": " + e.key + " takes " + fmt(e.steps, 3) + " steps of " + fmt(dt_, 3) +
                     " s, more than a run can make (1e12). Fix: check the units of " + e.key +
                     ", solver.time_step and solver.time_step_safety, and of the material and mesh.scale");
}

void Solver::check_runaway(real ke) const {
  // Velocities the caller prescribes (tests) may change at any time: no check then.
  energy_.check_runaway(ke, loads_.prescribed.set_by_caller(), where(), [&] { return instability_advice(); });
}

std::string Solver::where() const {
  return "step " + std::to_string(state.step) + " (t = " + fmt(state.time, 3) + " s)";
}

std::string Solver::instability_advice() const {
  return fdem::instability_advice(scene_, stable_, dt_, energy_, contacts.touching);
}

void Solver::step() {
  const real dt = dt_;
  if (!scene_.excavation.empty()) excavate_due();
  upload_if_changed();
  if (state.step == 0) {  // velocities given as initial conditions bring their own energy
    real ke = 0.5 * dev_->kinetic2();
    layout_.sum(&ke, 1);
    energy_.initial_kinetic = ke;
  }
  // The platen speed over [t, t+dt], for the works of the interval (finish_step).
  PlatenLoad& platens = loads_.platens;
  platens.step_speed = platens.enabled ? ramped_speed(state.time + 0.5 * dt, platens.speed, platens.ramp) : 0;
  host_current_ = false;
  // The loop takes the step, calls finish_step with its sums at its first copy to the host, and
  // evaluates the forces at the new state. Several ranks: where a node is a quarter of the
  // contact reach from where the contact ghosts were gathered (on any rank), every rank gathers
  // them again first, and the forces come after.
  if (dev_->step(dt)) {
    grow_contact_ghosts();
    compute_forces();
  }
  if (backend_ == Backend::debug) dev_->poison_host();
}

StepSums Solver::step_sums(const AdvanceSums& a) const {
  // The works over the step of the forces at t, with the mean of the velocities before and after.
  const real dt = dt_;
  StepSums st;
  st.bad = a.bad, st.ke = a.kinetic2, st.far = a.far, st.lost = a.lost;
  st.n_more = a.n_more, st.more = a.more;
  if (contacts.enabled()) st.w_con = 0.5 * dt * (energy_.p_contact + a.contact_power);
  if (loads_.surface.enabled) st.w_pre = 0.5 * dt * (loads_.surface.power + a.pressure_power);
  if (loads_.gravity.enabled) st.w_grav = 0.5 * dt * (loads_.gravity.power + a.gravity_power);
  st.w_kin = dt * a.reaction_power;  // (the reaction acts over the step it was found in)
  return st;
}

bool Solver::finish_step(const AdvanceSums& a) {
  const real dt = dt_, speed = loads_.platens.step_speed;
  const StepSums st = step_sums(a);
  // The step's reduction over the ranks; a device loop's values ride with it (its force
  // evaluation's sums, which it hands to the Solver now, before the energies below read them:
  // one reduction a step).
  StepSums all = st;  // this rank's, then the whole model's
  if (layout_.dd.distributed()) {
    std::array<real, StepSums::kValues + std::tuple_size_v<decltype(st.more)>> packed{};
    int k = 0;
    all.for_each([&](real& v) { packed[k++] = v; });
    std::copy(st.more.begin(), st.more.begin() + st.n_more, packed.begin() + k);
    layout_.sum(packed.data(), k + st.n_more);
    k = 0;
    all.for_each([&](real& v) { v = packed[k++]; });
    if (st.n_more > 0) dev_->take_reduced(packed.data() + k);
  }
  // Energies of the interval [t, t+dt] from the forces at t.
  energy_.add_step_works(dt, loads_.platens.force_top, speed);
  if (all.bad > 0 || all.lost > 0) sync_host();
  check_finite(long(all.bad));
  if (all.lost > 0) {  // every rank stops, each with the fix; those with the node name it
    const real moved = max_over_ranks(layout_.comm, contacts.farthest_move(model_, state.x).moved);
    contacts.check_reach(model_, state.x);
    throw RunError("tet-tet contact across ranks: a node on another rank has moved " + fmt(moved, 3) +
                   " m since the contact ghosts were last gathered, half the contact reach " +
                   fmt(layout_.dd.reach, 3) + " m or more (that rank names its tet). " +
                   ContactSet::reach_fix(layout_.dd.reach, moved));
  }
  // for the runaway check of every step (the loop is memory-bound: this is free)
  energy_.contact += all.w_con;
  energy_.external += all.w_pre + all.w_grav + all.w_kin;
  // After every work of this step is counted (pressure and gravity just above).
  check_runaway(0.5 * all.ke);
  loads_.platens.top_offset = loads_.platens.top_offset_after(dt);
  state.time += dt;
  ++state.step;
  return all.far > 0;
}

void Solver::condition_columns(Monitors& r) {
  if (scene_.conditions.empty()) return;
  loads_.prescribed.download_state();
  loads_.surface.download_state();
  const bool ranks = layout_.dd.distributed();
  const std::vector<std::uint8_t> owned = ranks ? layout_.dd.node_owned : std::vector<std::uint8_t>{};
  std::vector<real> sums = loads_.prescribed.condition_sums(owned);
  const std::vector<real> faces = loads_.surface.condition_sums(owned);
  for (std::size_t k = 0; k < sums.size(); ++k) sums[k] += faces[k];  // (each condition is one load's)
  if (ranks) layout_.sum(sums.data(), int(sums.size()));
  r.condition_columns = int(sums.size());
  energy_.inflow = 0;
  for (std::size_t c = 0; c < sums.size() / 4; ++c) energy_.inflow += std::max(sums[4 * c + 3], real(0));
  std::copy(sums.begin(), sums.end(), r.conditions.begin());
}

Monitors Solver::measure() {
  dev_->settle();  // the platen reactions and energies of the forces on the device
  const Model& m = model_;
  Monitors r;
  r.step = state.step;
  r.time = state.time;
  loads_.monitor(m, r);
  // This rank's sums: on the device where the state is (no copy of the state to the host).
  upload_if_changed();
  condition_columns(r);  // (after the upload: a host copy changed since is the state)
  history_columns(r);
  MonitorSums sums = dev_->measure_sums();
  if (layout_.dd.distributed()) {  // the whole model's sums: one reduction per monitor row
    std::vector<real> all;
    sums.for_each([&](real& v) { all.push_back(v); });
    layout_.sum(all.data(), int(all.size()));
    std::size_t k = 0;
    sums.for_each([&](real& v) { v = all[k++]; });
  }
  const real lat = sums.lateral_ratio, n_lateral = sums.lateral_nodes, ke = sums.kinetic, se = sums.strain;
  const real lat_sv = sums.lateral_stress_volume, lat_v = sums.middle_volume;
  // (The CE6s' stored energy counts from the in-situ state, as the strain energy does.)
  const real coh_stored = sums.cohesive_stored - energy_.cohesive_start, pl_stored = sums.platen_stored;
  const long damaged = long(sums.damaged), broken = long(sums.broken), b1 = long(sums.broken_I),
             b2 = long(sums.broken_II), b3 = long(sums.broken_mixed);
  r.lateral_strain = n_lateral > 0 ? -lat / n_lateral : 0;
  r.volumetric_strain = r.axial_strain + 2 * r.lateral_strain;
  if (state.step == 0) energy_.initial_kinetic = ke;
  r.lateral_stress = lat_v > 0 ? lat_sv / lat_v : 0;
  r.damaged = damaged;
  r.broken = broken;
  r.broken_I = b1;
  r.broken_II = b2;
  r.broken_mixed = b3;
  r.joint_damaged = long(sums.joint_damaged);
  r.joint_broken = long(sums.joint_broken);
  r.kinetic = ke;
  r.strain = se;
  r.cohesive_stored = coh_stored;
  r.cohesive_dissipated = energy_.cohesive - coh_stored;
  r.friction = energy_.friction;  // friction-spring energy of broken faces is counted with their work
  r.viscous = energy_.viscous;
  r.platen_stored = pl_stored;
  r.platen_friction = energy_.platen_friction;
  r.external_work = energy_.external;
  r.contact_friction = energy_.contact_slip + energy_.contact_spring;
  r.contact = energy_.contact - r.contact_friction;
  r.contact_stored = energy_.contact_stored;
  r.active_tets = long(sums.active_tets);
  r.contact_pairs = long(sums.contact_pairs);
  r.contacts = contacts.touching;
  // (sums.friction_stored, the friction-spring energy of broken faces, is counted with their work)
  const real accounted = energy_.accounted(ke, se, pl_stored);
  energy_.released = std::max(real(0), -se);
  r.energy_error = energy_.balance_error(accounted);
  // The energy balance: work put in against everything stored, dissipated and moving. Runs
  // whose caller prescribes node velocities (tests) are not checked.
  energy_.check_row(accounted, ke, scene_.solver.max_energy_error, loads_.prescribed.set_by_caller(), where(),
                    [&] { return instability_advice(); });
  return r;
}

void Solver::tet_stress(const std::vector<Vec3>& xs, const std::vector<Vec3>& vs, std::vector<Sym3>& stress,
                        std::vector<real>& von_mises) const {
  const Model& m = model_;
  const int nt = int(m.tet_nodes.size());
  stress.resize(nt);
  von_mises.resize(nt);
#pragma omp parallel for
  for (int t = 0; t < nt; ++t) {
    Vec3 xe[4], ve[4], fe[4];
    gather(xs, m.tet_nodes[t], xe);
    gather(vs, m.tet_nodes[t], ve);
    const Tet4Law l = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    stress[t] =
        tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], l.lambda, l.mu, m.tet_eta[t], fe, m.initial_stress_of(t))
            .stress;
    von_mises[t] = fdem::von_mises(stress[t]);
  }
}

void Solver::crack_faces(const std::vector<Ce6Damage>& cs, std::vector<std::array<int, 3>>& faces,
                         std::vector<real>& damage, std::vector<int>& mode) const {
  faces.clear();
  damage.clear();
  mode.clear();
  for (std::size_t i = 0; i < cs.size(); ++i) {
    if (!layout_.own_ce6[i] || cs[i].mode == kCe6Excavated) continue;
    const real d = ce6_broken(cs[i]) ? 1 : ce6_max_damage(cs[i]);
    if (d <= 0) continue;
    const auto& q = model_.ce6_nodes[i];
    faces.push_back({q[0], q[1], q[2]});
    damage.push_back(d);
    mode.push_back(cs[i].mode);
  }
}

void Solver::broken_faces(std::vector<std::array<Vec3, 3>>& corners, std::vector<int>& mode) const {
  sync_host();
  corners.clear();
  mode.clear();
  for (std::size_t i = 0; i < state.ce6.size(); ++i) {
    if (!layout_.own_ce6[i] || !ce6_broken(state.ce6.damage[i]) || laws_.joint_of_law(model_.ce6_law[i]) >= 0 ||
        state.ce6.damage[i].mode == kCe6Excavated)
      continue;  // (the rock's fractures: not the joints, nor what an excavation removed)
    const auto& q = model_.ce6_nodes[i];
    corners.push_back({model_.X[q[0]], model_.X[q[1]], model_.X[q[2]]});
    mode.push_back(state.ce6.damage[i].mode);
  }
  if (!layout_.dd.distributed()) return;
  // Every rank's faces, in rank order (9 coordinates and the mode per face).
  std::vector<double> mine;
  for (std::size_t k = 0; k < corners.size(); ++k) {
    for (const Vec3& c : corners[k]) mine.insert(mine.end(), {c.x, c.y, c.z});
    mine.push_back(mode[k]);
  }
  int count = int(mine.size());
  std::vector<int> counts(layout_.dd.size), offsets(layout_.dd.size + 1, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, layout_.comm);
  for (int r = 0; r < layout_.dd.size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<double> all(offsets[layout_.dd.size]);
  MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE, layout_.comm);
  corners.clear();
  mode.clear();
  for (std::size_t k = 0; k + 10 <= all.size(); k += 10) {
    corners.push_back({Vec3{all[k], all[k + 1], all[k + 2]}, Vec3{all[k + 3], all[k + 4], all[k + 5]},
                       Vec3{all[k + 6], all[k + 7], all[k + 8]}});
    mode.push_back(int(all[k + 9]));
  }
}

namespace {

/// A material's values in the fingerprint's order.
std::array<real, 14> material_values(const Material& a) {
  return {a.density,
          a.youngs_modulus,
          a.poisson_ratio,
          a.tensile_strength,
          a.cohesion,
          a.friction_angle,
          a.fracture_energy_I,
          a.fracture_energy_II,
          a.contact_penalty,
          a.cohesive_penalty_open,
          a.cohesive_penalty_tangential,
          a.cohesive_penalty_overlap,
          a.friction_platen,
          a.friction_rock};
}

/// The materials after the first, the interfaces and the joints.
std::uint64_t hash_materials(const Scene& s, std::uint64_t h) {
  auto add = [&](const Material& a) {
    const std::array<real, 14> v = material_values(a);
    const real softening = real(a.softening);
    h = fnv1a64(v.data(), sizeof v, h);
    h = fnv1a64(&softening, sizeof softening, h);
    h = fnv1a64(a.name.data(), a.name.size(), h);
  };
  for (std::size_t i = 1; i < s.materials.size(); ++i) add(s.materials[i]);
  for (const MaterialInterface& f : s.interfaces) add(f.law);
  for (const Joint& j : s.joints) {
    add(j.law);
    h = fnv1a64(&j.frictional, sizeof j.frictional, h);
  }
  return h;
}

/// This rank model's arrays that the equations of motion use: reference positions,
/// connectivity, masses, and each element's material, law, factors and excavation stage.
std::uint64_t model_arrays_hash(const Model& m) {
  std::uint64_t h = fnv1a64(m.X.data(), m.X.size() * sizeof(Vec3));
  h = fnv1a64(m.tet_nodes.data(), m.tet_nodes.size() * sizeof(m.tet_nodes[0]), h);
  h = fnv1a64(m.ce6_nodes.data(), m.ce6_nodes.size() * sizeof(m.ce6_nodes[0]), h);
  h = fnv1a64(m.mass.data(), m.mass.size() * sizeof(real), h);
  h = fnv1a64(m.tet_joint.data(), m.tet_joint.size(), h);
  h = fnv1a64(m.tet_material.data(), m.tet_material.size(), h);
  h = fnv1a64(m.ce6_law.data(), m.ce6_law.size(), h);
  h = fnv1a64(m.ce6_strength.data(), m.ce6_strength.size() * sizeof(real), h);  // (none: h as it was)
  h = fnv1a64(m.tet_stiffness.data(), m.tet_stiffness.size() * sizeof(real), h);
  return fnv1a64(m.tet_stage.data(), m.tet_stage.size(), h);
}

/// What a checkpoint must agree with: the model (reference positions, connectivity, masses),
/// the time step, and every scene value the equations of motion use.
std::uint64_t physics_fingerprint(const Scene& s, const Model& m, real dt) {
  return scene_physics_hash(s, dt, model_arrays_hash(m));
}

}  // namespace

std::uint64_t scene_physics_hash(const Scene& s, real dt, std::uint64_t h) {
  const Material& a = s.material();
  const std::array<real, 14> first = material_values(a);  // (one stream with the values after it)
  h = fnv1a64(first.data(), sizeof first, h);
  const real values[] = {real(s.platens.enabled),
                         s.platens.velocity,
                         s.platens.ramp_time,
                         real(s.confinement.enabled),
                         s.confinement.pressure,
                         s.confinement.ramp_time,
                         s.contact.buffer,
                         s.gravity.x,
                         s.gravity.y,
                         s.gravity.z,
                         s.solver.mass_scaling,
                         s.solver.damping_scale,
                         dt};
  h = fnv1a64(values, sizeof values, h);
  h = hash_materials(s, h);
  for (const ExcavationStage& e : s.excavation) {  // (which tets: each tet's stage)
    const real v[] = {e.start, e.relax};
    h = fnv1a64(v, sizeof v, h);
  }
  if (s.initial_stress.given) {
    const InitialStress& in = s.initial_stress;
    const Sym3 v[] = {in.stress, in.gradient, {in.reference_z, 0, 0, 0, 0, 0}};
    h = fnv1a64(v, sizeof v, h);
  }
  for (const BoundaryCondition& c : s.conditions) {
    const real v[] = {real(c.type), c.velocity.x, c.velocity.y, c.velocity.z,       real(c.components), c.traction.x,
                      c.traction.y, c.traction.z, c.pressure,   real(c.time.shape), c.time.duration};
    h = fnv1a64(v, sizeof v, h);
    h = fnv1a64(c.time.table.data(), c.time.table.size() * sizeof c.time.table[0], h);
    h = fnv1a64(c.surface.data(), c.surface.size(), h);
  }
  const std::string words = std::string(name_of(a.softening)) + "|" + name_of(s.confinement.path) + "|" +
                            name_of(s.contact.activation) + "|" + name_of(s.contact.law);
  return fnv1a64(words.data(), words.size(), h);
}

void Solver::save(CheckpointOut& out) const {
  sync_host();
  saved_layout().save(out);  // (read by a restart on another rank count)
  // After the contact ghosts grew, the rank model is no longer the one the run started with.
  out.put(growth_);
  out.put(grown_);
  if (grown_) put_rank_model(out, {model_, layout_.dd}, 0);
  out.put(excavated_);
  out.put(loads_.gravity.relax_start);
  out.put(loads_.gravity.push);
  out.put(physics_fingerprint(scene_, model_, dt_));
  out.put(std::uint64_t(loads_.prescribed.node.size()));
  save_state(out);
}

void Solver::save_state(CheckpointOut& out) const {
  state.save(out);
  loads_.save(out);
  energy_.save(out);
  contacts.save(out);
}

void Solver::load(CheckpointIn& in) {
  SavedLayout saved;
  saved.load(in);
  if (saved.size != layout_.dd.size || saved.rank != layout_.dd.rank)
    in.mismatch("rank " + std::to_string(saved.rank) + " of " + std::to_string(saved.size));
  in.get(growth_);
  in.get(grown_);
  if (grown_) {  // the grown rank model replaces the one the run started with
    RankModel rm = get_rank_model(in, 0);
    if (!layout_.dd.distributed() || rm.dd.rank != layout_.dd.rank || rm.dd.size != layout_.dd.size)
      in.mismatch("a rank model of rank " + std::to_string(rm.dd.rank) + " of " + std::to_string(rm.dd.size));
    adopt_layout(std::move(rm));
  }
  // The excavation stages done: their forces, and the model without their rock.
  std::vector<NodePush> push;
  in.get(excavated_);
  in.get(loads_.gravity.relax_start);
  in.get(push);
  if (excavated_ < 0 || excavated_ > int(scene_.excavation.size()) || (!push.empty() && push.size() != model_.X.size()))
    in.mismatch(std::to_string(excavated_) + " excavation stages done, with forces on " + std::to_string(push.size()) +
                " nodes");
  loads_.gravity.push = std::move(push);
  if (excavated_ > 0) loads_.gravity.relax_time = scene_.excavation[excavated_ - 1].relax;
  remove_excavated();
  // (After a gathering the reach counts from the saved positions: a new loop places them.)
  if (growth_.count > 0 || excavated_ > 0) dev_ = make_device_loop(backend_, loop_parts());
  std::uint64_t fp = 0, fixed = 0;
  in.get(fp);
  if (fp != physics_fingerprint(scene_, model_, dt_))
    in.mismatch("the mesh, the material, the loading, mass scaling or the time step differ");
  in.get(fixed);
  if (fixed != loads_.prescribed.node.size()) in.mismatch("a different set of prescribed nodes");
  load_state(in);
  host_current_ = true;
  host_changed();
}

void Solver::load_state(CheckpointIn& in) {
  state.load(in);
  loads_.load(in, false);
  energy_.load(in);
  contacts.load(in);
}

}  // namespace fdem
