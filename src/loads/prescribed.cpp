#include "loads/prescribed.hpp"

namespace fdem {

void PrescribedVelocities::set(int n, int components, Vec3 v) {
  const auto s = slot.emplace(n, int(node.size()));
  if (s.second) {
    node.push_back(n);
    mask.push_back(components);
    velocity.push_back(v);
    return;
  }
  const int i = s.first->second;
  mask[i] |= components;
  for (int d = 0; d < 3; ++d)
    if (components >> d & 1) velocity[i][d] = v[d];
}

void PrescribedVelocities::upload_state() {
  fdem::place(b_, node_, node);
  fdem::place(b_, mask_, mask);
  fdem::place(b_, velocity_, velocity);
  if (per_node_ && !node.empty()) {
    std::vector<int> of(nodes_, -1);
    for (std::size_t i = 0; i < node.size(); ++i) of[node[i]] = int(i);
    place_of_.upload(of);
  } else {
    place_of_.resize(0);
  }
}

}  // namespace fdem
