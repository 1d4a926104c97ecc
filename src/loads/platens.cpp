#include "loads/platens.hpp"

#include <cmath>

namespace fdem {

void PlatenLoad::set_up(const Scene& scene, const Model& m, real transits) {
  enabled = scene.platens.enabled;
  speed = scene.platens.velocity;
  ramp = scene.platens.ramp_time > 0 ? scene.platens.ramp_time : transits;
  friction = scene.material().friction_platen;
  top_z0 = m.box_max.z;
  bottom_z0 = m.box_min.z;
  k.resize(m.platen_nodes.size());
  anchor.resize(m.platen_nodes.size());
  for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) {
    k[i] = scene.material().contact_penalty * m.platen_node_area[i] / m.platen_node_h[i];
    const Vec3 X = m.X[m.platen_nodes[i]];
    anchor[i] = {X.x, X.y, 0};
  }
}

void PlatenLoad::monitor(const Model& m, Monitors& r) const {
  r.axial_strain = top_offset / m.height0;
  r.force_top = -force_top;
  r.force_bottom = force_bottom;
  r.axial_stress = axial_stress(m.area0);
  // Brazilian test: axial_stress is P / (D t) for a line-loaded disc.
  if (m.line_loaded) r.indirect_tensile = 2 / M_PI * r.axial_stress;
}

void PlatenLoad::save(CheckpointOut& out) const {
  out.put(top_offset);
  out.put(force_top);
  out.put(force_bottom);
  out.put(anchor);
}

void PlatenLoad::load(CheckpointIn& in, bool) {
  const std::size_t nodes = anchor.size();
  in.get(top_offset);
  in.get(force_top);
  in.get(force_bottom);
  in.get(anchor);
  if (anchor.size() != nodes) in.mismatch("the platen nodes differ");
}

void PlatenLoad::place(const Model& m, bool held) {
  fdem::place(b_, nodes_, m.platen_nodes);
  fdem::place(b_, k_, k);
  if (!held) return;
  std::vector<int> of(m.X.size(), -1);
  if (enabled)
    for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) of[m.platen_nodes[i]] = int(i);
  held_of_.upload(of);
  held_.resize(m.platen_nodes.size());
}

}  // namespace fdem
