#include "solver/solver.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/gather.hpp"
#include "io/checkpoint.hpp"
#include "model/laws.hpp"
#include "partition/grow.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"

namespace fdem {

Solver::Solver(const Scene& scene, Model model, Decomposition dd, MPI_Comm comm)
    : scene_(scene), model_(std::move(model)), dd_(std::move(dd)), comm_(comm) {
  setup();
  backend_ = scene_.solver.backend;
  dev_ = make_device_loop(backend_, *this);
  compute_forces();
  // The host copy holds the whole state (forces and contact pairs included), and the first step
  // starts from it: code may set velocities or prescriptions before it, as on a new state.
  sync_host();
  host_changed();
}

void Solver::setup() {
  const Material& mat = scene_.material;
  const SolverSettings& sol = scene_.solver;
  if (sol.threads > 0) omp_set_num_threads(sol.threads);
  lambda_ = mat.lame_lambda();
  mu_ = mat.lame_mu();
  ce6p_ = make_ce6_params(mat);
  ce6p_.broken_inert = scene_.contact.enabled() ? 1 : 0;
  const std::size_t nn = model_.X.size();
  x = model_.X;
  v.assign(nn, {0, 0, 0});
  f.assign(nn, {0, 0, 0});
  ce6.assign_intact(model_.ce6_nodes.size());
  platen_anchor.resize(model_.platen_nodes.size());
  for (std::size_t i = 0; i < model_.platen_nodes.size(); ++i) {
    const Vec3 p = model_.X[model_.platen_nodes[i]];
    platen_anchor[i] = {p.x, p.y, 0};
  }
  if (dd_.distributed()) {
    const int size = size_of(comm_);
    if (size != dd_.size || dd_.node_owned.size() != nn || dd_.tet_owned.size() != model_.tet_nodes.size() ||
        dd_.ce6_owned.size() != model_.ce6_nodes.size())
      throw InputError("the model is partitioned for " + std::to_string(dd_.size) + " ranks but runs on " +
                       std::to_string(size) + " (or its decomposition does not match it). Fix: run with mpiexec -n " +
                       std::to_string(dd_.size) + ", or partition again for " + std::to_string(size) + " ranks");
    own_node_ = dd_.node_owned;
    own_tet_ = dd_.tet_owned;
    own_ce6_ = dd_.ce6_owned;
    // With contact the node lists follow the active tets (partition/halo.hpp).
    halo_ = std::make_unique<Halo>(comm_, dd_, scene_.contact.enabled() ? &model_.tet_nodes : nullptr);
    // Forces are needed on owned nodes only: the loops skip elements that are not this rank's
    // and have no owned node (ghosts' nodes take their owners' values after each step). With
    // CE6 everywhere that is every ghost TET4 and every CE6 off the partition boundary.
    auto keep_touching_owned = [&](Colouring& c, const std::vector<std::uint8_t>& own, auto&& nodes_of) {
      Colouring kept;
      kept.offsets.push_back(0);
      for (int k = 0; k < c.colours(); ++k) {
        for (int j = c.offsets[k]; j < c.offsets[k + 1]; ++j) {
          bool any = own[c.order[j]];
          for (int n : nodes_of(c.order[j])) any = any || own_node_[n];
          if (any) kept.order.push_back(c.order[j]);
        }
        kept.offsets.push_back(int(kept.order.size()));
      }
      c = std::move(kept);
    };
    keep_touching_owned(model_.tet_colours, own_tet_, [&](int t) { return model_.tet_nodes[t]; });
    keep_touching_owned(model_.ce6_colours, own_ce6_, [&](int c) { return model_.ce6_nodes[c]; });
  } else {
    own_node_.assign(nn, 1);
    own_tet_.assign(model_.tet_nodes.size(), 1);
    own_ce6_.assign(model_.ce6_nodes.size(), 1);
  }
  // The forces start at zero without a pass of their own: the first TET4 (in colour order) to
  // reach a node assigns to it, the rest add; nodes no TET4 reaches (ghosts of other ranks'
  // elements) are zeroed apart.
  tet_assigns_.assign(model_.tet_nodes.size(), 0);
  {
    std::vector<char> reached(nn, 0);
    for (int t : model_.tet_colours.order)
      for (int i = 0; i < 4; ++i)
        if (!reached[model_.tet_nodes[t][i]]) reached[model_.tet_nodes[t][i]] = 1, tet_assigns_[t] |= 1 << i;
    unreached_nodes_.clear();
    for (std::size_t n = 0; n < nn; ++n)
      if (!reached[n]) unreached_nodes_.push_back(int(n));
  }
  contacts = ContactSet(model_, scene_);
  if (dd_.distributed()) contacts.set_ownership(&own_tet_, dd_.reach, model_.X);
  ce6_broke_.assign(model_.ce6_nodes.size(), 0);

  platen_k_.resize(model_.platen_nodes.size());
  for (std::size_t i = 0; i < model_.platen_nodes.size(); ++i)
    platen_k_[i] = mat.contact_penalty * model_.platen_node_area[i] / model_.platen_node_h[i];
  stable_ = stable_step_bound();
  const real M = lambda_ + 2 * mu_;
  const real rho = sol.mass_scaling * mat.density;
  stable_.dt = sol.time_step_safety * stable_.dt;
  dt_ = sol.time_step > 0 ? sol.time_step : stable_.dt;
  check_step_count();

  top_z0_ = model_.box_max.z;
  bottom_z0_ = model_.box_min.z;
  const real c = std::sqrt(M / rho);
  ramp_ = scene_.platens.ramp_time > 0 ? scene_.platens.ramp_time : 10 * model_.height0 / c;
  confine_ramp_ = scene_.confinement.ramp_time > 0 ? scene_.confinement.ramp_time : 10 * model_.height0 / c;
  hydrostatic_ = scene_.confinement.path == ConfinementPath::hydrostatic;
  lateral_faces_.clear();
  if (scene_.confinement.enabled) {
    // Lateral faces: surface faces not lying on the top or bottom end.
    std::vector<char> top(model_.X.size(), 0), bottom(model_.X.size(), 0);
    for (int n : model_.top_nodes) top[n] = 1;
    for (int n : model_.bottom_nodes) bottom[n] = 1;
    for (const auto& q : model_.surface_faces) {
      const bool on_top = top[q[0]] && top[q[1]] && top[q[2]];
      const bool on_bottom = bottom[q[0]] && bottom[q[1]] && bottom[q[2]];
      if (!on_top && !on_bottom) lateral_faces_.push_back(q);
    }
    lateral_force_.assign(lateral_faces_.size(), Vec3{0, 0, 0});
  }
  real volume = 0;
  for (std::size_t t = 0; t < model_.tet_V0.size(); ++t) volume += own_tet_[t] * model_.tet_V0[t];
  sum(&volume, 1);
  energy_floor_ = 1e-3 * mat.tensile_strength * mat.tensile_strength / (2 * mat.youngs_modulus) * volume;
}

void Solver::grow_contact_ghosts() {
  const double t0 = MPI_Wtime();
  sync_host();
  GhostState now;
  now.x = x, now.v = v, now.ce6 = ce6.states(), now.active = contacts.active();
  GrownRank g = fdem::grow_contact_ghosts(comm_, model_, dd_, now);
  CheckpointOut kept;
  save_state(kept);
  // The grown layout, then the state, extended by the ghosts'.
  adopt_layout(std::move(g.rm));
  CheckpointIn in(kept.payload(), "the state before the contact ghosts grew");
  load_state(in, &g.added);
  in.finish();
  contacts.set_plan(x);  // the reach counts from here
  ++growth_.count;
  growth_.tets += g.added_total;
  growth_.step = step_;
  restart_device();
  growth_.seconds += MPI_Wtime() - t0;
}

void Solver::adopt_layout(RankModel rm) {
  dev_.reset();
  halo_.reset();
  model_ = std::move(rm.model);
  dd_ = std::move(rm.dd);
  const real dt = dt_;  // the run's time step stays
  const StableStep stable = stable_;
  setup();
  dt_ = dt, stable_ = stable;
}

void Solver::restart_device() {
  dev_ = make_device_loop(backend_, *this);
  dev_->upload(*this);
  device_current_ = true;
  host_current_ = true;
}

void Solver::sync_host() const {
  // The scalars of the last force evaluation come with the state: completing the bookkeeping
  // of the step already taken does not change the solver's state either.
  dev_->settle(const_cast<Solver&>(*this));
  if (host_current_) return;
  // The host copy is a cache of the device state: bringing it up to date does not change the
  // solver's state, so it is allowed on a const solver.
  dev_->download(const_cast<Solver&>(*this));
  host_current_ = true;
}

void Solver::report_inverted() const {
  sync_host();
  const Model& m = model_;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    Vec3 xe[4], ve[4], fe[4];
    gather(x, m.tet_nodes[t], xe);
    gather(v, m.tet_nodes[t], ve);
    const Tet4Eval r = tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], lambda_, mu_, m.tet_eta[t], fe);
    if (!(r.J > 0))
      throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) + " s): TET4 #" +
                     std::to_string(model_.tet_input[t] + 1) + " inverted (J = " + fmt(r.J, 3) +
                     "). The run is unstable. " + instability_advice());
  }
  throw RunError("step " + std::to_string(step_) + ": a TET4 inverted on the device but not in the host copy");
}

StableStep Solver::stable_step_bound() const {
  // An upper bound of the model's highest frequency, node by node (Gershgorin on the rows
  // of M^-1 K, with Weyl's inequality for the sum of parts): the TET4's own eigenvalue
  // (exact per element) plus, for every CE6 node pair and platen spring at the node, the
  // row sum of its stiffness over the node's mass. A split node sits in up to three CE6s,
  // so a one-pair estimate would overstate the stable step by up to sqrt(3).
  const Model& m = model_;
  const Material& mat = scene_.material;
  const real rho = scene_.solver.mass_scaling * mat.density;
  const std::size_t nn = m.X.size();
  std::vector<real> w2_tet(nn, 0), c_tet(nn, 0), g_ce6(nn, 0), g_platen(nn, 0);
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const real w2 = tet4_max_eigenvalue(m.tet_Xinv[t], lambda_, mu_, rho);
    const real c = tet4_max_eigenvalue(m.tet_Xinv[t], 0, 0.5 * m.tet_eta[t], rho);
    for (int n : m.tet_nodes[t]) {
      w2_tet[n] = std::max(w2_tet[n], w2);
      c_tet[n] = std::max(c_tet[n], c);
    }
  }
  const real P = std::max({mat.cohesive_penalty_open, mat.cohesive_penalty_tangential, mat.cohesive_penalty_overlap});
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    const auto& q = m.ce6_nodes[c];
    const real area = 0.5 * norm(cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]));
    const real k = P * area / (3 * m.ce6_h[c]);  // row sum of the pair's relative stiffness
    for (int i = 0; i < 3; ++i)
      if (q[i] != q[i + 3]) {  // a pair that is one node (region border) has no spring
        g_ce6[q[i]] += 2 * k / m.mass[q[i]];
        g_ce6[q[i + 3]] += 2 * k / m.mass[q[i + 3]];
      }
  }
  // Tet-tet contact: two faces of area A pressed together stiffen by about 4 P_n A (1/h_a + 1/h_b)
  // (the potential gradient is 4/h at a face of altitude h); shared by the face's three nodes,
  // doubled for the Gershgorin row of the coupled pair, for up to three faces of a tet at a node.
  std::vector<real> g_con(nn, 0);
  if (scene_.contact.enabled())
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
      Vec3 xe[4];
      for (int i = 0; i < 4; ++i) xe[i] = m.X[m.tet_nodes[t][i]];
      real amax = 0;
      for (int k = 0; k < 4; ++k)
        amax = std::max(amax, 0.5 * norm(cross(xe[(k + 2) % 4] - xe[(k + 1) % 4], xe[(k + 3) % 4] - xe[(k + 1) % 4])));
      const real k_face = 8 * mat.contact_penalty * amax / tet4_min_altitude(xe);
      for (int n : m.tet_nodes[t]) g_con[n] = std::max(g_con[n], 2 * k_face / m.mass[n]);
    }
  if (scene_.platens.enabled)
    for (std::size_t i = 0; i < m.platen_nodes.size(); ++i)
      g_platen[m.platen_nodes[i]] += platen_k_[i] / m.mass[m.platen_nodes[i]];

  StableStep st;
  st.dt = st.dt_tet = st.dt_ce6 = st.dt_platen = st.dt_contact = 1e300;
  std::size_t lim = 0;
  for (std::size_t n = 0; n < nn; ++n) {
    if (!own_node_[n]) continue;  // a ghost's row lacks the elements beyond this rank
    const real dt = damped_stable_step(w2_tet[n] + g_ce6[n] + g_platen[n] + g_con[n], c_tet[n]);
    if (dt < st.dt) st.dt = dt, lim = n;
    st.dt_tet = std::min(st.dt_tet, damped_stable_step(w2_tet[n], c_tet[n]));
    if (g_ce6[n] > 0) st.dt_ce6 = std::min(st.dt_ce6, 2 / std::sqrt(g_ce6[n]));
    if (g_platen[n] > 0) st.dt_platen = std::min(st.dt_platen, 2 / std::sqrt(g_platen[n]));
    if (g_con[n] > 0) st.dt_contact = std::min(st.dt_contact, 2 / std::sqrt(g_con[n]));
  }
  const real w2 = w2_tet[lim] + g_ce6[lim] + g_platen[lim] + g_con[lim];
  auto pct = [&](real part) { return std::to_string(int(std::lround(100 * part / w2))) + " %"; };
  const long lim_id = dd_.distributed() ? dd_.node_global[lim] : long(lim);
  st.limit = "node " + std::to_string(lim_id + 1) + " (its squared frequency: TET4 " + pct(w2_tet[lim]) +
             ", CE6 penalty " + fmt(P, 3) + " Pa " + pct(g_ce6[lim]) + ", platen " + pct(g_platen[lim]) + ", contact " +
             pct(g_con[lim]) + ")";
  if (dd_.distributed()) {  // the smallest over the ranks, and the limit named by the rank that has it
    struct {
      double dt;
      int rank;
    } mine{st.dt, dd_.rank}, best{};
    MPI_Allreduce(&mine, &best, 1, MPI_DOUBLE_INT, MPI_MINLOC, comm_);
    real parts[4] = {st.dt_tet, st.dt_ce6, st.dt_platen, st.dt_contact};
    MPI_Allreduce(MPI_IN_PLACE, parts, 4, MPI_DOUBLE, MPI_MIN, comm_);
    st.dt = best.dt;
    st.dt_tet = parts[0], st.dt_ce6 = parts[1], st.dt_platen = parts[2], st.dt_contact = parts[3];
    int len = int(st.limit.size());
    MPI_Bcast(&len, 1, MPI_INT, best.rank, comm_);
    st.limit.resize(len);
    MPI_Bcast(st.limit.data(), len, MPI_CHAR, best.rank, comm_);
  }
  return st;
}

void Solver::prescribe(int node, int mask, Vec3 velocity) {
  // The state first: a step left pending reads the lists below as they were (on the cpu
  // backend the loop borrows them).
  sync_host();
  // One entry per node (the device applies the entries in parallel): a node prescribed again
  // takes the new components, as if the calls were applied in turn.
  const auto slot = fixed_slot_.emplace(node, int(fixed_node_.size()));
  if (slot.second) {
    fixed_node_.push_back(node);
    fixed_mask_.push_back(mask);
    fixed_velocity_.push_back(velocity);
  } else {
    const int i = slot.first->second;
    fixed_mask_[i] |= mask;
    for (int d = 0; d < 3; ++d)
      if (mask >> d & 1) fixed_velocity_[i][d] = velocity[d];
  }
  for (int d = 0; d < 3; ++d)
    if (mask >> d & 1) v[node][d] = velocity[d];
  host_changed();
}

void Solver::compute_forces() {
  upload_if_changed();
  dev_->compute_forces(*this);
  host_current_ = false;  // the forces (and after a growth of the contact ghosts, more) changed there
}

void Solver::upload_if_changed() {
  if (device_current_) return;
  dev_->upload(*this);
  device_current_ = true;
}

real Solver::axial_stress() const {
  return model_.area0 > 0 ? 0.5 * (-force_top_ + force_bottom_) / model_.area0 : 0;
}

void Solver::sum(real* values, int n) const {
  if (dd_.distributed()) sum_over_ranks(comm_, values, n);
}

void Solver::check_finite(long bad_nodes) const {
  if (bad_nodes == 0) return;
  int first = -1;  // (a prescribed node counted as bad has had its velocity reset: then none here)
  for (std::size_t n = 0; n < v.size(); ++n)
    if (own_node_[n] && !std::isfinite(v[n].x + v[n].y + v[n].z)) {
      first = int(n);
      break;
    }
  if (first < 0)
    throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) + " s): the velocity of " +
                   std::to_string(bad_nodes) + " node(s) is no longer finite" +
                   (dd_.distributed() ? " (on another rank)" : "") + ". The run is unstable. " + instability_advice());
  throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) + " s): the velocity of " +
                 std::to_string(bad_nodes) + " node(s) is no longer finite (first: node " +
                 std::to_string((dd_.distributed() ? dd_.node_global[first] : long(first)) + 1) +
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
  // Energy enters only through the platens, the pressure and gravity; prescribed velocities
  // (tests) bring their own.
  const real input = w_external_ + initial_kinetic_;
  if (!fixed_node_.empty() || ke <= 2 * std::fabs(input) + energy_floor_) return;
  throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) + " s): kinetic energy " + fmt(ke, 3) +
                 " J against external work " + fmt(input, 3) + " J: the run is unstable. " + instability_advice());
}

std::string Solver::instability_advice() const {
  const SolverSettings& s = scene_.solver;
  const Material& mat = scene_.material;
  const real bound = stable_bound();
  const real ratio = dt_ / bound;
  const real E = mat.youngs_modulus;
  const real p_ce6 =
      std::max({mat.cohesive_penalty_open, mat.cohesive_penalty_tangential, mat.cohesive_penalty_overlap});
  std::string cause;
  if (ratio > 1)
    cause = "the time step " + fmt(dt_, 3) + " s is " + fmt(ratio, 3) + " x the stable-step bound " + fmt(bound, 3) +
            " s (limited by " + stable_.limit + ")";
  else if (s.mass_scaling >= 100)
    cause = "mass scaling m = " + fmt(s.mass_scaling, 3) +
            ": the loading is no longer quasi-static and the inertia of the fragments dominates";
  else if (contacts.enabled() && touching_ > 0 &&
           w_contact_ < -0.01 * std::max(std::fabs(w_external_ + initial_kinetic_), energy_floor_))
    cause = "tet-tet contact has put " + fmt(-w_contact_, 3) + " J in (" + std::to_string(touching_) +
            " pairs touching, penalty " + fmt(mat.contact_penalty, 3) + " Pa = " + fmt(mat.contact_penalty / E, 3) +
            " E): the potential contact force is not exactly conservative, and overlapping fragments can feed "
            "energy in whatever the time step (docs/stability.md)";
  else if (p_ce6 > 1000 * E)
    cause = "the cohesive penalty " + fmt(p_ce6, 3) + " Pa (" + fmt(p_ce6 / E, 3) + " E)";
  else
    cause = "large deformation or fragment overlap beyond the stable-step bound " + fmt(bound, 3) + " s (limited by " +
            stable_.limit + "); the time step is " + fmt(ratio, 3) + " of it";
  const std::string step_fix =
      s.time_step > 0 ? "lower solver.time_step (now " + fmt(s.time_step, 3) + " s, " + fmt(ratio, 3) +
                            " x the stable-step bound), or set it to 0 for the bound times solver.time_step_safety"
                      : "lower solver.time_step_safety (now " + fmt(s.time_step_safety, 3) +
                            ", <= 1 is stable for the small-strain model)";
  return "Cause: " + cause + ". Fix: " + step_fix +
         ", lower the penalties (material.contact_penalty, "
         "material.cohesive_penalty_*), or lower solver.mass_scaling (now " +
         fmt(s.mass_scaling, 3) + ")";
}

void Solver::step() {
  const real dt = dt_;
  upload_if_changed();
  if (step_ == 0) {  // velocities given as initial conditions bring their own energy
    real ke = 0.5 * dev_->kinetic2();
    sum(&ke, 1);
    initial_kinetic_ = ke;
  }
  // The platen speed over [t, t+dt], for the works of the interval (finish_step).
  step_speed_ = scene_.platens.enabled ? ramped_speed(time_ + 0.5 * dt, scene_.platens.velocity, ramp_) : 0;
  bool gather_ghosts = false;
  host_current_ = false;
  // One rank: the device loop finishes the step inside the next force evaluation, whose first
  // copy to the host brings the integration's sums too (DeviceLoop::advance).
  AdvanceSums a;
  if (dev_->advance(*this, dt, a)) gather_ghosts = finish_step(step_sums(a));
  // Several ranks: a node a quarter of the contact reach from where the contact ghosts were
  // gathered (on any rank): every rank gathers them again, before the broad phase looks.
  if (gather_ghosts) grow_contact_ghosts();
  compute_forces();
  if (backend_ == Backend::debug) dev_->poison_host(*this);
}

Solver::StepSums Solver::step_sums(const AdvanceSums& a) const {
  // The works over the step of the forces at t, with the mean of the velocities before and after.
  const real dt = dt_;
  StepSums st;
  st.bad = a.bad, st.ke = a.kinetic2, st.far = a.far, st.lost = a.lost;
  st.n_more = a.n_more, st.more = a.more;
  if (contacts.enabled()) st.w_con = 0.5 * dt * (p_contact_ + a.contact_power);
  if (scene_.confinement.enabled) st.w_pre = 0.5 * dt * (p_pressure_ + a.pressure_power);
  if (scene_.has_gravity()) st.w_grav = 0.5 * dt * (p_gravity_ + a.gravity_power);
  return st;
}

bool Solver::finish_step(const StepSums& st) {
  const real dt = dt_, speed = step_speed_;
  // The step's reduction over the ranks; a device loop's values ride with it (its force
  // evaluation's sums, which it hands to the Solver now, before the energies below read them:
  // one reduction a step).
  StepSums all = st;  // this rank's, then the whole model's
  if (dd_.distributed()) {
    std::array<real, StepSums::kValues + std::tuple_size_v<decltype(st.more)>> packed{};
    int k = 0;
    all.for_each([&](real& v) { packed[k++] = v; });
    std::copy(st.more.begin(), st.more.begin() + st.n_more, packed.begin() + k);
    sum(packed.data(), k + st.n_more);
    k = 0;
    all.for_each([&](real& v) { v = packed[k++]; });
    if (st.n_more > 0) dev_->take_reduced(*this, packed.data() + k);
  }
  // Energies of the interval [t, t+dt] from the forces at t.
  w_external_ += force_top_ * (-speed * dt);
  w_viscous_ += p_viscous_ * dt;
  w_cohesive_ += p_cohesive_ * dt;
  w_friction_ += p_friction_ * dt;
  if (all.bad > 0 || all.lost > 0) sync_host();
  check_finite(long(all.bad));
  if (all.lost > 0) {  // every rank stops: those with the node name it
    contacts.check_reach(model_, x);
    throw RunError("tet-tet contact across ranks: a node on another rank has moved half the contact reach " +
                   fmt(dd_.reach, 3) + " m since the contact ghosts were last gathered (that rank names it)");
  }
  // for the runaway check of every step (the loop is memory-bound: this is free)
  w_contact_ += all.w_con;
  w_external_ += all.w_pre + all.w_grav;
  // After every work of this step is counted (pressure and gravity just above).
  check_runaway(0.5 * all.ke);
  top_offset = top_offset_after_step();
  time_ = time_after_step();
  ++step_;
  return all.far > 0;
}

Monitors Solver::measure() {
  dev_->settle(*this);  // the platen reactions and energies of the forces on the device
  const Model& m = model_;
  Monitors r;
  r.step = step_;
  r.time = time_;
  r.axial_strain = top_offset / m.height0;
  r.force_top = -force_top_;
  r.force_bottom = force_bottom_;
  r.axial_stress = axial_stress();
  // This rank's sums: on the device where the state is (no copy of the state to the host).
  upload_if_changed();
  MonitorSums sums = dev_->measure_sums(*this);
  if (dd_.distributed()) {  // the whole model's sums: one reduction per monitor row
    std::vector<real> all;
    sums.for_each([&](real& v) { all.push_back(v); });
    sum(all.data(), int(all.size()));
    std::size_t k = 0;
    sums.for_each([&](real& v) { v = all[k++]; });
  }
  const real lat = sums.lateral_ratio, n_lateral = sums.lateral_nodes, ke = sums.kinetic, se = sums.strain;
  const real lat_sv = sums.lateral_stress_volume, lat_v = sums.middle_volume;
  const real coh_stored = sums.cohesive_stored, pl_stored = sums.platen_stored;
  const long damaged = long(sums.damaged), broken = long(sums.broken), b1 = long(sums.broken_I),
             b2 = long(sums.broken_II), b3 = long(sums.broken_mixed);
  r.lateral_strain = n_lateral > 0 ? -lat / n_lateral : 0;
  r.volumetric_strain = r.axial_strain + 2 * r.lateral_strain;
  if (step_ == 0) initial_kinetic_ = ke;
  r.lateral_stress = lat_v > 0 ? lat_sv / lat_v : 0;
  r.damaged = damaged;
  r.broken = broken;
  r.broken_I = b1;
  r.broken_II = b2;
  r.broken_mixed = b3;
  r.kinetic = ke;
  r.strain = se;
  r.cohesive_stored = coh_stored;
  r.cohesive_dissipated = w_cohesive_ - coh_stored;
  r.friction = w_friction_;  // friction-spring energy of broken faces is counted with their work
  r.viscous = w_viscous_;
  r.platen_stored = pl_stored;
  r.platen_friction = w_platen_friction_;
  r.external_work = w_external_;
  r.contact_friction = w_contact_slip_ + contact_spring_;
  r.contact = w_contact_ - r.contact_friction;
  r.active_tets = long(sums.active_tets);
  r.contact_pairs = long(sums.contact_pairs);
  r.contacts = touching_;
  r.confining_pressure = pressure_;
  // Brazilian test: axial_stress is P / (D t) for a line-loaded disc.
  if (m.line_loaded) r.indirect_tensile = 2 / M_PI * r.axial_stress;
  // (sums.friction_stored, the friction-spring energy of broken faces, is counted with their work)
  const real internal = ke + se + w_cohesive_ + w_friction_ + w_viscous_ + pl_stored + w_platen_friction_ + w_contact_;
  const real input = w_external_ + initial_kinetic_;
  r.energy_error = std::fabs(input - internal) / std::max(std::fabs(input), energy_floor_);
  if (!std::isfinite(internal))
    throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) +
                   " s): an energy is no longer finite: the run is unstable. " + instability_advice());
  check_runaway(ke);
  // The energy balance: work put in against everything stored, dissipated and moving. Runs
  // with prescribed node velocities (tests) do not account for the work those do.
  const real tol = scene_.solver.max_energy_error;
  if (tol > 0 && fixed_node_.empty() && std::fabs(input) > 100 * energy_floor_ && r.energy_error > tol)
    throw RunError("step " + std::to_string(step_) + " (t = " + fmt(time_, 3) + " s): the energy balance is off by " +
                   fmt(100 * r.energy_error, 3) + " % of the work put in (" + fmt(input, 3) + " J against " +
                   fmt(internal, 3) + " J stored, dissipated and kinetic), above solver.max_energy_error " +
                   fmt(100 * tol, 3) + " %: the run is unstable. " + instability_advice());
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
    stress[t] = tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], lambda_, mu_, m.tet_eta[t], fe).stress;
    von_mises[t] = fdem::von_mises(stress[t]);
  }
}

void Solver::crack_faces(const std::vector<Ce6State>& cs, std::vector<std::array<int, 3>>& faces,
                         std::vector<real>& damage, std::vector<int>& mode) const {
  faces.clear();
  damage.clear();
  mode.clear();
  for (std::size_t i = 0; i < cs.size(); ++i) {
    if (!own_ce6_[i]) continue;
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
  for (std::size_t i = 0; i < ce6.size(); ++i) {
    if (!own_ce6_[i] || !ce6_broken(ce6.damage[i])) continue;
    const auto& q = model_.ce6_nodes[i];
    corners.push_back({model_.X[q[0]], model_.X[q[1]], model_.X[q[2]]});
    mode.push_back(ce6.damage[i].mode);
  }
  if (!dd_.distributed()) return;
  // Every rank's faces, in rank order (9 coordinates and the mode per face).
  std::vector<double> mine;
  for (std::size_t k = 0; k < corners.size(); ++k) {
    for (const Vec3& c : corners[k]) mine.insert(mine.end(), {c.x, c.y, c.z});
    mine.push_back(mode[k]);
  }
  int count = int(mine.size());
  std::vector<int> counts(dd_.size), offsets(dd_.size + 1, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm_);
  for (int r = 0; r < dd_.size; ++r) offsets[r + 1] = offsets[r] + counts[r];
  std::vector<double> all(offsets[dd_.size]);
  MPI_Allgatherv(mine.data(), count, MPI_DOUBLE, all.data(), counts.data(), offsets.data(), MPI_DOUBLE, comm_);
  corners.clear();
  mode.clear();
  for (std::size_t k = 0; k + 10 <= all.size(); k += 10) {
    corners.push_back({Vec3{all[k], all[k + 1], all[k + 2]}, Vec3{all[k + 3], all[k + 4], all[k + 5]},
                       Vec3{all[k + 6], all[k + 7], all[k + 8]}});
    mode.push_back(int(all[k + 9]));
  }
}

namespace {

/// What a checkpoint must agree with: the model (reference positions, connectivity, masses),
/// the time step, and every scene value the equations of motion use.
std::uint64_t physics_fingerprint(const Scene& s, const Model& m, real dt) {
  std::uint64_t h = fnv1a64(m.X.data(), m.X.size() * sizeof(Vec3));
  h = fnv1a64(m.tet_nodes.data(), m.tet_nodes.size() * sizeof(m.tet_nodes[0]), h);
  h = fnv1a64(m.ce6_nodes.data(), m.ce6_nodes.size() * sizeof(m.ce6_nodes[0]), h);
  h = fnv1a64(m.mass.data(), m.mass.size() * sizeof(real), h);
  const Material& a = s.material;
  const real values[] = {a.density,
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
                         a.friction_rock,
                         real(s.platens.enabled),
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
  const std::string words =
      std::string(name_of(a.softening)) + "|" + name_of(s.confinement.path) + "|" + name_of(s.contact.activation);
  return fnv1a64(words.data(), words.size(), h);
}

}  // namespace

void Solver::save(CheckpointOut& out) const {
  sync_host();
  // After the contact ghosts grew, the rank model is no longer the one the run started with.
  out.put(growth_);
  if (growth_.count > 0) put_rank_model(out, {model_, dd_}, 0);
  out.put(physics_fingerprint(scene_, model_, dt_));
  out.put(std::uint64_t(fixed_node_.size()));
  save_state(out);
}

void Solver::save_state(CheckpointOut& out) const {
  out.put(step_);
  out.put(time_);
  out.put(top_offset);
  out.put(x);
  out.put(v);
  out.put(f);
  out.put(ce6.states());  // (one Ce6State each, as before the state was split in two)
  out.put(ce6_broke_);
  out.put(platen_anchor);
  const real scalars[] = {force_top_,       force_bottom_,      w_external_,     w_cohesive_,     w_friction_,
                          w_viscous_,       w_platen_friction_, p_cohesive_,     p_friction_,     p_viscous_,
                          initial_kinetic_, w_contact_,         w_contact_slip_, contact_spring_, p_contact_,
                          p_gravity_,       pressure_,          p_pressure_,     platen_stored_};
  for (real r : scalars) out.put(r);
  out.put(touching_);
  out.put(lateral_force_);
  contacts.save(out);
}

void Solver::load(CheckpointIn& in) {
  in.get(growth_);
  if (growth_.count > 0) {  // the grown rank model replaces the one the run started with
    RankModel rm = get_rank_model(in, 0);
    if (!dd_.distributed() || rm.dd.rank != dd_.rank || rm.dd.size != dd_.size)
      in.mismatch("a rank model of rank " + std::to_string(rm.dd.rank) + " of " + std::to_string(rm.dd.size));
    adopt_layout(std::move(rm));
    dev_ = make_device_loop(backend_, *this);
  }
  std::uint64_t fp = 0, fixed = 0;
  in.get(fp);
  if (fp != physics_fingerprint(scene_, model_, dt_))
    in.mismatch("the mesh, the material, the loading, mass scaling or the time step differ");
  in.get(fixed);
  if (fixed != fixed_node_.size()) in.mismatch("a different set of prescribed nodes");
  load_state(in);
  host_current_ = true;
  host_changed();
}

void Solver::load_state(CheckpointIn& in, const GhostState* appended) {
  in.get(step_);
  in.get(time_);
  in.get(top_offset);
  const std::size_t nn = x.size(), nc = ce6.size(), np = platen_anchor.size(), nl = lateral_force_.size();
  in.get(x);
  in.get(v);
  in.get(f);
  std::vector<Ce6State> ce6_saved;
  in.get(ce6_saved);
  ce6 = Ce6States{};
  ce6.append(ce6_saved);
  in.get(ce6_broke_);
  in.get(platen_anchor);
  if (appended) {  // the ghosts' state after the old layout's (forces: the next evaluation's)
    x.insert(x.end(), appended->x.begin(), appended->x.end());
    v.insert(v.end(), appended->v.begin(), appended->v.end());
    f.resize(nn, Vec3{0, 0, 0});
    ce6.append(appended->ce6);
    ce6_broke_.resize(nc, 0);
  }
  if (x.size() != nn || v.size() != nn || f.size() != nn || ce6.size() != nc || ce6_broke_.size() != nc ||
      platen_anchor.size() != np)
    in.mismatch("node, CE6 or platen node counts differ");
  real* scalars[] = {&force_top_,       &force_bottom_,      &w_external_,     &w_cohesive_,     &w_friction_,
                     &w_viscous_,       &w_platen_friction_, &p_cohesive_,     &p_friction_,     &p_viscous_,
                     &initial_kinetic_, &w_contact_,         &w_contact_slip_, &contact_spring_, &p_contact_,
                     &p_gravity_,       &pressure_,          &p_pressure_,     &platen_stored_};
  for (real* r : scalars) in.get(*r);
  in.get(touching_);
  in.get(lateral_force_);
  if (appended) lateral_force_.resize(nl, Vec3{0, 0, 0});  // faces of the ghosts: never owned
  if (lateral_force_.size() != nl) in.mismatch("the lateral surface differs");
  contacts.load(in, appended ? &appended->active : nullptr);
}

}  // namespace fdem
