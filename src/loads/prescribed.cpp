#include "loads/prescribed.hpp"

#include "model/conditions.hpp"

namespace fdem {

int PrescribedVelocities::entry_of(int n) {
  const auto s = slot.emplace(n, int(node.size()));
  if (s.second) {
    node.push_back(n);
    mask.push_back(0);
    velocity.push_back(Vec3{0, 0, 0});
    scale_of.push_back(0);
    condition.push_back({-1, -1, -1});
    reaction.push_back(Vec3{0, 0, 0});
    work.push_back(Vec3{0, 0, 0});
  }
  return s.first->second;
}

void PrescribedVelocities::set_up(const Scene& scene, const Model& m) {
  time_.clear();
  for (const BoundaryCondition& c : scene.conditions) time_.push_back(c.time);
  if (m.node_conditions.empty()) return;
  // Conditions in list order, their nodes in turn: where two hold one component (the model
  // build checked that they agree), the first in the list reports it.
  for (std::size_t ci = 0; ci < scene.conditions.size(); ++ci) {
    const BoundaryCondition& c = scene.conditions[ci];
    if (!c.kinematic()) continue;
    const int components = prescribed_components(c, m.condition_axis[ci]);
    for (std::size_t n = 0; n < m.X.size(); ++n) {
      if (!(m.node_conditions[n] >> ci & 1)) continue;
      const int i = entry_of(int(n));
      mask[i] |= components;
      for (int d = 0; d < 3; ++d) {
        if (!(components >> d & 1)) continue;
        if (condition[i][d] < 0) condition[i][d] = int(ci);
        if (c.type == ConditionType::velocity && c.velocity[d] != 0)
          velocity[i][d] = c.velocity[d], scale_of[i] = with_scale(scale_of[i], d, int(ci));
      }
    }
  }
}

void PrescribedVelocities::set(int n, int components, Vec3 v, real t) {
  const int i = entry_of(n);
  by_caller_ = true;
  const ConditionScales now = scales_at(t);
  for (int d = 0; d < 3; ++d)
    if (components >> d & 1) {
      velocity[i][d] = v[d], condition[i][d] = -1;
      scale_of[i] = with_scale(scale_of[i], d, -1);
    } else if (const int s = scale_in(scale_of[i], d); s >= 0) {  // (held at its value now)
      velocity[i][d] *= now.at[s], scale_of[i] = with_scale(scale_of[i], d, -1);
    }
  mask[i] |= components;
}

ConditionScales PrescribedVelocities::scales_at(real t) const {
  ConditionScales s{};
  for (std::size_t c = 0; c < time_.size(); ++c) s.at[c] = time_[c].at(t);
  return s;
}

std::vector<real> PrescribedVelocities::condition_sums(const std::vector<std::uint8_t>& owned) const {
  std::vector<real> sums(4 * time_.size(), 0);
  for (std::size_t i = 0; i < node.size(); ++i) {
    if (!owned.empty() && !owned[node[i]]) continue;
    for (int d = 0; d < 3; ++d) {
      const int c = condition[i][d];
      if (c < 0) continue;
      sums[4 * c + d] += reaction[i][d];
      sums[4 * c + 3] += work[i][d];
    }
  }
  return sums;
}

void PrescribedVelocities::save(CheckpointOut& out) const {
  out.put(reaction);
  out.put(work);
}

void PrescribedVelocities::load(CheckpointIn& in, bool) {
  const std::size_t entries = node.size();
  in.get(reaction);
  in.get(work);
  if (reaction.size() != entries || work.size() != entries) in.mismatch("a different set of prescribed nodes");
}

void PrescribedVelocities::upload_state() {
  fdem::place(b_, node_, node);
  fdem::place(b_, mask_, mask);
  fdem::place(b_, velocity_, velocity);
  fdem::place(b_, scale_of_, scale_of);
  fdem::place(b_, reaction_, reaction);
  fdem::place(b_, work_, work);
  if (per_node_ && !node.empty()) {
    std::vector<int> of(nodes_, -1);
    for (std::size_t i = 0; i < node.size(); ++i) of[node[i]] = int(i);
    place_of_.upload(of);
  } else {
    place_of_.resize(0);
  }
}

void PrescribedVelocities::download_state() {
  if (node.empty()) return;
  reaction_.download(reaction);
  work_.download(work);
}

}  // namespace fdem
