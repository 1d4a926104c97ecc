#include "solver/contact_set.hpp"

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/checkpoint.hpp"

namespace fdem {

ContactSet::ContactSet(const Model& m, const Scene& s) {
  enabled_ = s.contact.enabled();
  if (!enabled_) return;
  penalty_ = s.material().contact_penalty;
  law_ = s.contact.law;
  mu_ = s.material().friction_rock;
  buffer_ = s.contact.buffer > 0 ? s.contact.buffer : 0.1 * m.mean_edge;
  const int nt = int(m.tet_nodes.size());

  // Mesh vertex -> tets (CSR), for the vicinity of a broken CE6.
  VertexTets vt(m);
  vertex_tet_ptr_ = std::move(vt.ptr);
  vertex_tets_ = std::move(vt.tets);

  face_ce6_ = face_ce6_of(m);

  tet_flags.assign(nt, 0);
  if (s.contact.activation == Activation::full) {
    std::fill(tet_flags.begin(), tet_flags.end(), TetFlag::kCandidate);
  } else if (s.platens.enabled) {
    // Adaptive: the tets at the loaded ends are candidates from the start.
    std::vector<std::uint8_t> loaded(m.X.size(), 0);
    for (int n : m.top_nodes) loaded[n] = 1;
    for (int n : m.bottom_nodes) loaded[n] = 1;
    for (int t = 0; t < nt; ++t)
      for (int n : m.tet_nodes[t])
        if (loaded[n]) tet_flags[t] = TetFlag::kCandidate;
  }
  recount_active();
}

std::vector<std::array<int, 4>> ContactSet::face_ce6_of(const Model& m) {
  std::vector<std::array<int, 4>> out(m.tet_nodes.size(), {-1, -1, -1, -1});
  for (int c = 0; c < int(m.ce6_tets.size()); ++c)
    for (int t : m.ce6_tets[c]) {
      int face = -1;  // the corner not on the CE6's face
      for (int i = 0; i < 4; ++i) {
        const int u = m.node_vertex[m.tet_nodes[t][i]];
        bool on = false;
        for (int j = 0; j < 3; ++j) on = on || m.node_vertex[m.ce6_nodes[c][j]] == u;
        if (!on) face = face < 0 ? i : 4;
      }
      if (face < 0 || face > 3 || out[t][face] >= 0)
        throw RunError("contact: CE6 #" + std::to_string(c) + " does not lie on one face of tet #" + std::to_string(t) +
                       " (a model whose CE6s do not match its tets)");
      out[t][face] = c;
    }
  return out;
}

void ContactSet::recount_active() {
  active_count_ =
      std::count_if(tet_flags.begin(), tet_flags.end(), [](std::uint8_t f) { return TetFlag::candidate(f); });
}

void ContactSet::set_ownership(const std::vector<std::uint8_t>* tet_owned, real reach) {
  tet_owned_ = tet_owned;
  reach_ = reach;
}

long ContactSet::activate_ce6(const Model& m, int c) {
  if (!enabled_) return 0;
  long added = 0;
  for (int i = 0; i < 3; ++i) {
    const int vtx = m.node_vertex[m.ce6_nodes[c][i]];
    for (int k = vertex_tet_ptr_[vtx]; k < vertex_tet_ptr_[vtx + 1]; ++k) {
      std::uint8_t& a = tet_flags[vertex_tets_[k]];
      if (!(a & TetFlag::kCandidate)) a |= TetFlag::kCandidate, ++added;
    }
  }
  active_count_ += added;
  if (added) rebuild_due = true;
  for (int t : m.ce6_tets[c])
    for (int i = 0; i < 4; ++i)
      if (face_ce6_[t][i] == c && !(tet_flags[t] & TetFlag::face_released(i)))
        tet_flags[t] |= TetFlag::face_released(i), rebuild_due = true;
  return added;
}

void ContactSet::check_reach(const Model& m, const std::vector<Vec3>& x) const {
  // A rank holds the tets within reach_ of its own at plan_x_: a tet it lacks can touch one of
  // its own only after some node has moved reach_/2 from there. The contact ghosts are gathered
  // again once a node has moved a quarter of the reach (Solver::step); a node that moved half
  // the reach in the steps since outran that.
  const FarthestMove far = farthest_move(m, x);
  if (far.tet >= 0 && far.moved >= 0.5 * reach_)
    throw RunError("tet-tet contact across ranks: a node of tet #" + std::to_string(m.tet_input[far.tet] + 1) +
                   " has moved " + fmt(far.moved, 3) +
                   " m since the contact ghosts were last gathered, half the contact reach " + fmt(reach_, 3) +
                   " m or more: partners beyond the reach, which this rank does not hold, could have touched it. " +
                   reach_fix(reach_, far.moved));
}

ContactSet::FarthestMove ContactSet::farthest_move(const Model& m, const std::vector<Vec3>& x) const {
  FarthestMove far;
  real far2 = 0;
  if (tet_owned_)
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
      if ((*tet_owned_)[t])
        for (int n : m.tet_nodes[t]) {
          const real d2 = dot(x[n] - plan_x_[n], x[n] - plan_x_[n]);
          if (far.tet < 0 || d2 > far2) far2 = d2, far.tet = int(t);
        }
  far.moved = std::sqrt(far2);
  return far;
}

std::string ContactSet::reach_fix(real reach, real moved) {
  return "Fix: a larger reach (--contact-reach of fdem run or fdem partition, e.g. --contact-reach " +
         fmt(std::max(2 * reach, 4 * moved), 3) + "; it must exceed twice the distance a node moves in a step), " +
         "or fewer ranks";
}

void ContactSet::save(CheckpointOut& out) const {
  out.put(enabled_);
  out.put(touching);
  if (!enabled_) return;
  out.put(tet_flags);
  each_evolving([&](const auto& v) { out.put(v); }, *this);
}

void ContactSet::load(CheckpointIn& in) {
  bool enabled = false;
  in.get(enabled);
  if (enabled != enabled_) in.mismatch("contact.activation differs: 'none' in one of them");
  in.get(touching);
  if (!enabled_) return;
  const std::size_t nt = tet_flags.size(), nn = plan_x_.size();
  in.get(tet_flags);
  if (tet_flags.size() != nt)
    in.mismatch("tet count " + std::to_string(tet_flags.size()) + ", the model has " + std::to_string(nt));
  each_evolving([&](auto& v) { in.get(v); }, *this);
  if (history.size() != pairs.size() || eval.size() != pairs.size()) in.mismatch("inconsistent contact pair arrays");
  if (plan_x_.size() != nn)
    in.mismatch("node count " + std::to_string(plan_x_.size()) + " of the contact reach, the model has " +
                std::to_string(nn));
}

void ContactSet::carry_from(ContactSet&& old, const std::vector<std::uint8_t>& appended) {
  touching = old.touching;
  if (!enabled_) return;
  const std::size_t nt = tet_flags.size();
  tet_flags = std::move(old.tet_flags);
  tet_flags.insert(tet_flags.end(), appended.begin(), appended.end());
  if (tet_flags.size() != nt || !old.enabled_)
    throw RunError("contact ghosts: the grown model has " + std::to_string(nt) + " tets, the contact state " +
                   std::to_string(tet_flags.size()));
  each_evolving([](auto& mine, auto& theirs) { mine = std::move(theirs); }, *this, old);
  recount_active();
  rebuild_due = true;  // (the new tets are candidates only after a build; the caller sets the plan)
}

}  // namespace fdem
