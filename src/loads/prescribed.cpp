#include "loads/prescribed.hpp"

#include "model/conditions.hpp"

namespace fdem {

int PrescribedVelocities::entry_of(int n) {
  const auto s = slot.emplace(n, int(node.size()));
  if (s.second) {
    node.push_back(n);
    mask.push_back(0);
    velocity.push_back(Vec3{0, 0, 0});
    scale_of.push_back(-1);
    condition.push_back({-1, -1, -1});
    reaction.push_back(Vec3{0, 0, 0});
    work.push_back(Vec3{0, 0, 0});
  }
  return s.first->second;
}

void PrescribedVelocities::set_up(const Scene& scene, const Model& m) {
  time_.clear();
  for (const BoundaryCondition& c : scene.conditions) time_.push_back(c.time);
  // Faces in order, their nodes in turn: the same entries on every backend. Where conditions
  // meet, the model build checked that they agree (model/conditions.cpp); the first reports.
  for (std::size_t k = 0; k < m.surface_conditions.size(); ++k)
    for (std::size_t ci = 0; ci < scene.conditions.size(); ++ci) {
      if (!(m.surface_conditions[k] >> ci & 1)) continue;
      const BoundaryCondition& c = scene.conditions[ci];
      const int components = prescribed_components(c, m, m.surface_faces[k]);
      if (components == 0) continue;  // a face load (loads/surface_loads.hpp)
      const bool moves =
          c.type == ConditionType::velocity && (c.velocity.x != 0 || c.velocity.y != 0 || c.velocity.z != 0);
      for (int n : m.surface_faces[k]) {
        const int i = entry_of(n);
        mask[i] |= components;
        if (moves) velocity[i] = c.velocity, scale_of[i] = int(ci);
        for (int d = 0; d < 3; ++d)
          if (components >> d & 1 && condition[i][d] < 0) condition[i][d] = int(ci);
      }
    }
}

void PrescribedVelocities::set(int n, int components, Vec3 v) {
  const int i = entry_of(n);
  by_caller_ = true;
  if (scale_of[i] >= 0) velocity[i] = scales_at(0).at[scale_of[i]] * velocity[i];  // (now held as it is)
  scale_of[i] = -1;
  mask[i] |= components;
  for (int d = 0; d < 3; ++d)
    if (components >> d & 1) velocity[i][d] = v[d], condition[i][d] = -1;
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
