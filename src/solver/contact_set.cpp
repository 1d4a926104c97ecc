#include "solver/contact_set.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "core/error.hpp"
#include "core/format.hpp"
#include "core/gather.hpp"
#include "io/checkpoint.hpp"

namespace fdem {
namespace {

bool share_node(const std::array<int, 4>& p, const std::array<int, 4>& q) {
  for (int i : p)
    for (int j : q)
      if (i == j) return true;
  return false;
}

}  // namespace

ContactSet::ContactSet(const Model& m, const Scene& s) {
  enabled_ = s.contact.enabled();
  if (!enabled_) return;
  penalty_ = s.material.contact_penalty;
  mu_ = s.material.friction_rock;
  buffer_ = s.contact.buffer > 0 ? s.contact.buffer : 0.1 * m.mean_edge;
  const int nt = int(m.tet_nodes.size());

  // Mesh vertex -> tets (CSR), for the vicinity of a broken CE6.
  VertexTets vt(m);
  vertex_tet_ptr_ = std::move(vt.ptr);
  vertex_tets_ = std::move(vt.tets);

  tet_ce6_.assign(nt, {-1, -1, -1, -1});
  for (int c = 0; c < int(m.ce6_tets.size()); ++c)
    for (int t : m.ce6_tets[c]) {
      auto& slots = tet_ce6_[t];
      for (int& sl : slots)
        if (sl < 0) {
          sl = c;
          break;
        }
    }

  active_.assign(nt, 0);
  if (s.contact.activation == Activation::full) {
    std::fill(active_.begin(), active_.end(), 1);
  } else if (s.platens.enabled) {
    // Adaptive: the tets at the loaded ends are candidates from the start.
    std::vector<std::uint8_t> loaded(m.X.size(), 0);
    for (int n : m.top_nodes) loaded[n] = 1;
    for (int n : m.bottom_nodes) loaded[n] = 1;
    for (int t = 0; t < nt; ++t)
      for (int n : m.tet_nodes[t])
        if (loaded[n]) active_[t] = 1;
  }
  active_count_ = std::count(active_.begin(), active_.end(), 1);
}

void ContactSet::set_ownership(const std::vector<std::uint8_t>* node_owned, const std::vector<std::uint8_t>* tet_owned,
                               const std::vector<long>* tet_global, real reach, const std::vector<Vec3>& plan_x) {
  node_owned_ = node_owned;
  tet_owned_ = tet_owned;
  tet_global_ = tet_global;
  reach_ = reach;
  plan_x_ = plan_x;
}

void ContactSet::flags_changed() {
  active_count_ = std::count(active_.begin(), active_.end(), 1);
  dirty_ = true;
}

long ContactSet::owned_active_count() const {
  if (!tet_owned_) return active_count_;
  long k = 0;
  for (std::size_t t = 0; t < active_.size(); ++t) k += active_[t] && (*tet_owned_)[t];
  return k;
}

long ContactSet::owned_pair_count() const {
  if (!tet_owned_) return long(pairs_.size());
  long k = 0;
  for (const ContactPair& p : pairs_) k += pair_counts(p);
  return k;
}

long ContactSet::activate_ce6(const Model& m, int c) {
  if (!enabled_) return 0;
  long added = 0;
  for (int i = 0; i < 3; ++i) {
    const int vtx = m.node_vertex[m.ce6_nodes[c][i]];
    for (int k = vertex_tet_ptr_[vtx]; k < vertex_tet_ptr_[vtx + 1]; ++k) {
      std::uint8_t& a = active_[vertex_tets_[k]];
      if (!a) a = 1, ++added;
    }
  }
  if (added) {
    active_count_ += added;
    dirty_ = true;
  }
  return added;
}

bool ContactSet::moved_too_far(const std::vector<Vec3>& x) const {
  const real lim2 = 0.25 * buffer_ * buffer_;
  const int n = int(watch_nodes_.size());
  int far = 0;
#pragma omp parallel for schedule(static) reduction(| : far)
  for (int i = 0; i < n; ++i) {
    const Vec3 d = x[watch_nodes_[i]] - watch_x_[i];
    far |= dot(d, d) > lim2;
  }
  return far != 0;
}

void ContactSet::check_reach(const Model& m, const std::vector<Vec3>& x) const {
  if (!tet_owned_) return;
  // A rank holds the tets within reach_ of its own at plan_x_: a tet it lacks can touch one of
  // its own only after some node has moved reach_/2 from there. The contact ghosts are gathered
  // again once a node has moved a quarter of the reach (Solver::step); a node that moved half
  // the reach in the steps since outran that.
  const real lim2 = 0.25 * reach_ * reach_;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (!(*tet_owned_)[t]) continue;
    for (int n : m.tet_nodes[t]) {
      const Vec3 d = x[n] - plan_x_[n];
      if (dot(d, d) >= lim2)
        throw RunError("tet-tet contact across ranks: a node of tet #" + std::to_string(m.tet_input[t] + 1) +
                       " has moved " + fmt(std::sqrt(dot(d, d)), 3) +
                       " m since the contact ghosts were last gathered, half the contact reach " + fmt(reach_, 3) +
                       " m or more: partners beyond the reach, which this rank does not hold, could have touched "
                       "it. Fix: a larger reach (--contact-reach of fdem run or fdem partition, e.g. "
                       "--contact-reach " +
                       fmt(std::max(2 * reach_, 4 * std::sqrt(dot(d, d))), 3) +
                       "; it must exceed twice the distance a node moves in a step), or fewer ranks");
    }
  }
}

void ContactSet::rebuild(const Model& m, const std::vector<Vec3>& x) {
  const int nt = int(m.tet_nodes.size());
  std::vector<int> ids;
  ids.reserve(active_count_);
  for (int t = 0; t < nt; ++t)
    if (active_[t]) ids.push_back(t);
  std::vector<Aabb> boxes(nt);
  const real half = 0.5 * buffer_;
  const int na = int(ids.size());
#pragma omp parallel for schedule(static)
  for (int k = 0; k < na; ++k) {
    const auto& q = m.tet_nodes[ids[k]];
    Aabb b{x[q[0]], x[q[0]]};
    for (int i = 1; i < 4; ++i)
      for (int d = 0; d < 3; ++d) {
        b.lo[d] = std::min(b.lo[d], x[q[i]][d]);
        b.hi[d] = std::max(b.hi[d], x[q[i]][d]);
      }
    for (int d = 0; d < 3; ++d) b.lo[d] -= half, b.hi[d] += half;
    boxes[ids[k]] = b;
  }
  std::vector<std::array<int, 2>> found;
  find_box_pairs(boxes, ids, 0, found, &stats_);

  // Drop pairs that share a node (continuous rock outside the fracture regions); note the
  // CE6 joining a pair, if any.
  std::vector<ContactPair> next;
  next.reserve(found.size());
  for (const auto& p : found) {
    int joint = -1;
    for (int c : tet_ce6_[p[0]])
      if (c >= 0 && (m.ce6_tets[c][0] == p[1] || m.ce6_tets[c][1] == p[1])) joint = c;
    // Tets sharing a node are one continuous body, unless a CE6 joins them: on the border
    // of a fracture region a CE6 can have one or two single-node pairs and still break.
    if (joint < 0 && share_node(m.tet_nodes[p[0]], m.tet_nodes[p[1]])) continue;
    // A rank's part of a decomposed model: a pair acting on no owned node does not matter here.
    if (node_owned_) {
      bool any = false;
      for (int t : p)
        for (int n : m.tet_nodes[t]) any = any || (*node_owned_)[n];
      if (!any) continue;
    }
    next.push_back({p[0], p[1], joint});
  }
  // Pairs in global order: a is the tet of lower global id, and the list is sorted by the global
  // ids of (a, b). The local order is the global one except for contact ghosts appended by a
  // growth; in global order every node sums its contact forces as on one rank, bit for bit.
  const long* tg = tet_global_ ? tet_global_->data() : nullptr;
  auto gid = [tg](int t) { return tg ? tg[t] : long(t); };
  auto global_less = [&gid](const ContactPair& p, const ContactPair& q) {
    return gid(p.a) != gid(q.a) ? gid(p.a) < gid(q.a) : gid(p.b) < gid(q.b);
  };
  if (tg) {  // (one rank: find_box_pairs' order already)
    for (ContactPair& p : next)
      if (gid(p.b) < gid(p.a)) std::swap(p.a, p.b);
    std::sort(next.begin(), next.end(), global_less);
  }
  // Carry each surviving pair's friction spring over (both lists are in that order).
  std::vector<Vec3> next_spring(next.size(), Vec3{0, 0, 0});
  const int nn = int(next.size());
#pragma omp parallel for schedule(static)
  for (int i = 0; i < nn; ++i) {
    auto it = std::lower_bound(pairs_.begin(), pairs_.end(), next[i], global_less);
    if (it != pairs_.end() && it->a == next[i].a && it->b == next[i].b) next_spring[i] = spring[it - pairs_.begin()];
  }
  pairs_.swap(next);
  spring.swap(next_spring);
  eval_.assign(pairs_.size(), ContactEval{});
  pair_force_.assign(8 * pairs_.size(), Vec3{0, 0, 0});

  // Gather index: (node, slot) sorted by node, then slot.
  std::vector<std::array<int, 2>> ns;
  ns.reserve(8 * pairs_.size());
  for (int p = 0; p < int(pairs_.size()); ++p) {
    for (int i = 0; i < 4; ++i) ns.push_back({m.tet_nodes[pairs_[p].a][i], 8 * p + i});
    for (int i = 0; i < 4; ++i) ns.push_back({m.tet_nodes[pairs_[p].b][i], 8 * p + 4 + i});
  }
  std::sort(ns.begin(), ns.end());
  gather_node_.clear();
  gather_ptr_.assign(1, 0);
  gather_slot_.resize(ns.size());
  for (std::size_t k = 0; k < ns.size(); ++k) {
    if (k == 0 || ns[k][0] != ns[k - 1][0]) {
      if (k > 0) gather_ptr_.push_back(int(k));
      gather_node_.push_back(ns[k][0]);
    }
    gather_slot_[k] = ns[k][1];
  }
  if (!ns.empty()) gather_ptr_.push_back(int(ns.size()));

  // Watch the nodes of the active tets for the next rebuild.
  std::vector<std::uint8_t> seen(x.size(), 0);
  watch_nodes_.clear();
  for (int t : ids)
    for (int n : m.tet_nodes[t])
      if (!seen[n]) seen[n] = 1, watch_nodes_.push_back(n);
  watch_x_.resize(watch_nodes_.size());
  for (std::size_t i = 0; i < watch_nodes_.size(); ++i) watch_x_[i] = x[watch_nodes_[i]];
  dirty_ = false;
  ++times.rebuilds;
}

real ContactSet::power(const Model& m, const std::vector<Vec3>& v) const {
  const int np = int(pairs_.size());
  real p = 0;
#pragma omp parallel for schedule(static) reduction(+ : p)
  for (int k = 0; k < np; ++k) {
    const Vec3* fp = &pair_force_[8 * k];
    for (int i = 0; i < 4; ++i) {
      const int na = m.tet_nodes[pairs_[k].a][i], nb = m.tet_nodes[pairs_[k].b][i];
      if (node_counts(na)) p -= dot(fp[i], v[na]);
      if (node_counts(nb)) p -= dot(fp[4 + i], v[nb]);
    }
  }
  return p;
}

ContactPower ContactSet::add_forces(const Model& m, const std::vector<Vec3>& x, const std::vector<Vec3>& v,
                                    const std::vector<Ce6State>& ce6, const std::vector<std::uint8_t>& fresh, real dt,
                                    std::vector<Vec3>& f) {
  ContactPower out;
  if (!enabled_) return out;
  double t0 = omp_get_wtime();
  if (dirty_ || moved_too_far(x)) rebuild(m, x);
  double t1 = omp_get_wtime();
  times.broad += t1 - t0;

  const int np = int(pairs_.size());
  long touching = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : touching)
  for (int p = 0; p < np; ++p) {
    const ContactPair& cp = pairs_[p];
    Vec3* fp = &pair_force_[8 * p];
    if (cp.joint >= 0 && (!ce6_broken(ce6[cp.joint]) || fresh[cp.joint])) {
      for (int i = 0; i < 8; ++i) fp[i] = Vec3{0, 0, 0};
      eval_[p] = ContactEval{{0, 0, 0}, {0, 0, 0}, 0};
      continue;
    }
    Vec3 xa[4], xb[4], fa[4], fb[4];
    gather(x, m.tet_nodes[cp.a], xa);
    gather(x, m.tet_nodes[cp.b], xb);
    eval_[p] = contact_tet_pair(xa, xb, penalty_, fa, fb);
    touching += eval_[p].weight > 0 && pair_counts(cp);
    for (int i = 0; i < 4; ++i) fp[i] = fa[i], fp[4 + i] = fb[i];
  }
  double t2 = omp_get_wtime();
  times.narrow += t2 - t1;

  real dissipated = 0, stored = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(+ : dissipated, stored)
  for (int p = 0; p < np; ++p) {
    const ContactPair& cp = pairs_[p];
    if (!(eval_[p].weight > 0)) {
      spring[p] = Vec3{0, 0, 0};
      continue;
    }
    Vec3 xa[4], xb[4], va[4], vb[4], fa[4], fb[4];
    gather(x, m.tet_nodes[cp.a], xa);
    gather(x, m.tet_nodes[cp.b], xb);
    gather(v, m.tet_nodes[cp.a], va);
    gather(v, m.tet_nodes[cp.b], vb);
    for (int i = 0; i < 4; ++i) fa[i] = fb[i] = Vec3{0, 0, 0};
    const real k_t = contact_tangential_stiffness(xa, xb, penalty_);
    const real d = contact_friction(xa, xb, va, vb, eval_[p], mu_, k_t, dt, spring[p], fa, fb);
    if (pair_counts(cp)) {
      dissipated += d;
      stored += 0.5 * k_t * dot(spring[p], spring[p]);
    }
    Vec3* fp = &pair_force_[8 * p];
    for (int i = 0; i < 4; ++i) {
      fp[i] += fa[i];
      fp[4 + i] += fb[i];
    }
  }
  double t3 = omp_get_wtime();
  times.friction += t3 - t2;
  const int ng = int(gather_node_.size());
#pragma omp parallel for schedule(static)
  for (int k = 0; k < ng; ++k) {
    Vec3 s{0, 0, 0};
    for (int j = gather_ptr_[k]; j < gather_ptr_[k + 1]; ++j) s += pair_force_[gather_slot_[j]];
    f[gather_node_[k]] += s;
  }
  times.narrow += omp_get_wtime() - t3;  // the force sum belongs to the narrow phase
  out.power = power(m, v);
  out.dissipated = dissipated;
  out.spring_energy = stored;
  out.touching = touching;
  return out;
}

void ContactSet::save(CheckpointOut& out) const {
  out.put(enabled_);
  if (!enabled_) return;
  out.put(active_);
  out.put(active_count_);
  out.put(dirty_);
  out.put(pairs_);
  out.put(stats_);
  out.put(watch_nodes_);
  out.put(watch_x_);
  out.put(eval_);
  out.put(pair_force_);
  out.put(gather_node_);
  out.put(gather_ptr_);
  out.put(gather_slot_);
  out.put(spring);
  out.put(times);
  out.put(plan_x_);
}

void ContactSet::load(CheckpointIn& in, const std::vector<std::uint8_t>* appended) {
  bool enabled = false;
  in.get(enabled);
  if (enabled != enabled_) in.mismatch("contact.activation differs: 'none' in one of them");
  if (!enabled_) return;
  const std::size_t nt = active_.size(), nn = plan_x_.size();
  in.get(active_);
  if (appended) active_.insert(active_.end(), appended->begin(), appended->end());
  if (active_.size() != nt)
    in.mismatch("tet count " + std::to_string(active_.size()) + ", the model has " + std::to_string(nt));
  in.get(active_count_);
  in.get(dirty_);
  in.get(pairs_);
  in.get(stats_);
  in.get(watch_nodes_);
  in.get(watch_x_);
  in.get(eval_);
  in.get(pair_force_);
  in.get(gather_node_);
  in.get(gather_ptr_);
  in.get(gather_slot_);
  in.get(spring);
  in.get(times);
  in.get(plan_x_);
  if (spring.size() != pairs_.size() || eval_.size() != pairs_.size()) in.mismatch("inconsistent contact pair arrays");
  if (appended) {
    // The new tets are candidates only after a build; the caller sets the new plan positions.
    active_count_ = std::count(active_.begin(), active_.end(), 1);
    dirty_ = true;
  } else if (plan_x_.size() != nn) {
    in.mismatch("node count " + std::to_string(plan_x_.size()) + " of the contact reach, the model has " +
                std::to_string(nn));
  }
}

}  // namespace fdem
