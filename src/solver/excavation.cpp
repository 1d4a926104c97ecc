// Excavation (scene `excavate`): at each stage's start the tets of its volume group leave the
// rock. Core replacement: the forces they and their CE6s put on the rock's nodes at that moment
// stay on as loads, relaxed to zero over the stage's `relax` period. The removed tets keep no
// stiffness, their CE6s no force, and contact and the frames skip them; a node that only removed
// tets hold stays where it is.
#include "core/gather.hpp"
#include "solver/solver.hpp"

namespace fdem {

namespace {

/// The CE6 state of a removed CE6: no force, counted nowhere (kCe6Excavated).
Ce6Damage excavated_state() {
  Ce6Damage d{};
  d.D[0] = d.D[1] = d.D[2] = 1;
  d.mode = kCe6Excavated;
  return d;
}

}  // namespace

int Solver::stage_of(std::size_t t) const {
  return model_.tet_stage.empty() ? 0 : model_.tet_stage[t];  // (a rank may hold none)
}

bool Solver::removed_tet(std::size_t t) const {
  const int s = stage_of(t);
  return s != 0 && s <= excavated_;
}

std::vector<char> Solver::kept_nodes(int stages) const {
  const Model& m = model_;
  std::vector<char> kept(m.X.size(), 0);
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
    if (stage_of(t) == 0 || stage_of(t) > stages)
      for (int n : m.tet_nodes[t]) kept[n] = 1;
  return kept;
}

void Solver::excavate_due() {
  while (excavated_ < int(scene_.excavation.size()) && state.time >= scene_.excavation[excavated_].start) {
    sync_host();
    excavation_forces(excavated_ + 1);
    book_removed_energy(excavated_ + 1);
    ++excavated_;
    remove_excavated();
    for (std::size_t n = 0; n < model_.X.size(); ++n)
      if (held_by_excavation_[n]) state.v[n] = Vec3{0, 0, 0};
    if (scene_.contact.enabled()) contacts.request_rebuild();
    // The relaxation from now: from the whole force at the state the stage left.
    loads_.gravity.relax_start = state.time;
    loads_.gravity.relax_time = scene_.excavation[excavated_ - 1].relax;
    restart_device();
    compute_forces();  // (the forces of the rock without the stage, for the next step)
  }
}

void Solver::excavation_forces(int stage) {
  const Model& m = model_;
  std::vector<NodePush>& push = loads_.gravity.push;
  push.resize(m.X.size());
  for (NodePush& p : push) p.relaxing = Vec3{0, 0, 0};  // (the stage before has relaxed)
  const std::vector<char> kept = kept_nodes(stage);
  const Vec3 g = loads_.gravity.g;
  // The removed TET4s' elastic forces on the nodes that stay, and their share of those nodes'
  // weight: it relaxes with them, and is then off for good (the nodes keep the mass).
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (stage_of(t) != stage) continue;
    Vec3 xe[4], ve[4] = {}, fe[4];
    gather(state.x, m.tet_nodes[t], xe);
    const Tet4Law l = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], l.lambda, l.mu, 0, fe, m.initial_stress_of(t));
    for (int i = 0; i < 4; ++i) {
      const int n = m.tet_nodes[t][i];
      if (!kept[n]) continue;
      const Vec3 weight = gravity_force(l.density * m.tet_V0[t] / 4, g);
      push[n].relaxing += fe[i] + weight;
      push[n].held -= weight;
    }
  }
  // The removed CE6s' forces on the nodes that stay (a CE6 between a removed tet and one that
  // stays: its side on the rock).
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    if (stage_of(m.ce6_tets[c][0]) != stage && stage_of(m.ce6_tets[c][1]) != stage) continue;
    Vec3 xe[6], ve[6], fe[6];
    for (int i = 0; i < 6; ++i) xe[i] = state.x[m.ce6_nodes[c][i]], ve[i] = state.v[m.ce6_nodes[c][i]];
    Ce6Damage d = state.ce6.damage[c];  // (its last state: evaluating it must not advance it)
    Ce6Anchors a = state.ce6.anchors[c];
    const real strength = m.ce6_strength.empty() ? real(1) : m.ce6_strength[c];
    const Ce6Prestress* pre = m.ce6_prestress.empty() ? nullptr : &m.ce6_prestress[c];
    cohesive6_forces(laws_.ce6[m.ce6_law[c]], xe, ve, m.ce6_h[c], d, a.a, fe, strength, pre);
    for (int i = 0; i < 6; ++i)
      if (kept[m.ce6_nodes[c][i]]) push[m.ce6_nodes[c][i]].relaxing += fe[i];
  }
  // A node only removed tets hold: its weight held off, so that it stays where it is.
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (!kept[n]) push[n] = NodePush{Vec3{0, 0, 0}, -gravity_force(m.mass[n], g)};
}

void Solver::book_removed_energy(int stage) {
  // What leaves with the removed rock: its tets' strain energy, the kinetic energy of the nodes
  // that stop, and (for the cohesive column only) its CE6s' stored energy.
  const Model& m = model_;
  const std::vector<char> kept = kept_nodes(stage);
  real sums[2] = {0, 0};  // J: strain and kinetic energy; CE6 stored energy
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (stage_of(t) != stage || !layout_.own_tet[t]) continue;
    Vec3 xe[4], ve[4] = {}, fe[4];
    gather(state.x, m.tet_nodes[t], xe);
    const Tet4Law l = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    sums[0] +=
        tet4_forces(xe, ve, m.tet_Xinv[t], m.tet_V0[t], l.lambda, l.mu, 0, fe, m.initial_stress_of(t)).strain_energy;
  }
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (!kept[n] && layout_.own_node[n]) sums[0] += real(0.5) * m.mass[n] * dot(state.v[n], state.v[n]);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    if (!layout_.own_ce6[c] || state.ce6.damage[c].mode == kCe6Excavated) continue;
    if (stage_of(m.ce6_tets[c][0]) != stage && stage_of(m.ce6_tets[c][1]) != stage) continue;
    Vec3 xe[6], ve[6] = {}, fe[6];
    for (int i = 0; i < 6; ++i) xe[i] = state.x[m.ce6_nodes[c][i]];
    Ce6Damage d = state.ce6.damage[c];
    Ce6Anchors a = state.ce6.anchors[c];
    const real strength = m.ce6_strength.empty() ? real(1) : m.ce6_strength[c];
    const Ce6Prestress* pre = m.ce6_prestress.empty() ? nullptr : &m.ce6_prestress[c];
    if (!ce6_broken(d))
      sums[1] += cohesive6_forces(laws_.ce6[m.ce6_law[c]], xe, ve, m.ce6_h[c], d, a.a, fe, strength, pre).stored;
  }
  layout_.sum(sums, 2);
  energy_.excavated += sums[0];
  energy_.cohesive_start -= sums[1];
}

void Solver::remove_excavated() {
  Model& m = model_;
  held_by_excavation_.assign(m.X.size(), 0);
  if (excavated_ == 0) return;
  if (m.tet_stiffness.empty()) m.tet_stiffness.assign(m.tet_nodes.size(), 1);
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (!removed_tet(t)) continue;
    m.tet_stiffness[t] = 0, m.tet_eta[t] = 0;
    if (!m.tet_initial_stress.empty()) m.tet_initial_stress[t] = Sym3{0, 0, 0, 0, 0, 0};
    if (t < contacts.tet_flags.size()) contacts.tet_flags[t] |= TetFlag::kExcavated;
  }
  const std::vector<char> kept = kept_nodes(excavated_);
  for (std::size_t n = 0; n < m.X.size(); ++n) held_by_excavation_[n] = !kept[n];
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c)
    if (removed_tet(m.ce6_tets[c][0]) || removed_tet(m.ce6_tets[c][1])) state.ce6.damage[c] = excavated_state();
  loads_.gravity.enabled = true;
}

}  // namespace fdem
