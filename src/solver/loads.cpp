#include "solver/loads.hpp"

#include <cmath>

#include "physics/integrate.hpp"

namespace fdem {

real ConfiningPressure::pressure_at(real time, real axial) const {
  return confining_pressure(hydrostatic, target, hydrostatic ? target : ramped_speed(time, target, ramp), axial);
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

void PlatenLoad::load(CheckpointIn& in) {
  const std::size_t nodes = anchor.size();
  in.get(top_offset);
  in.get(force_top);
  in.get(force_bottom);
  in.get(anchor);
  if (anchor.size() != nodes) in.mismatch("the platen nodes differ");
}

void ConfiningPressure::save(CheckpointOut& out) const {
  out.put(pressure);
  out.put(power);
  out.put(face_force);
}

void ConfiningPressure::load(CheckpointIn& in, bool ghosts_appended) {
  const std::size_t faces_now = face_force.size();
  in.get(pressure);
  in.get(power);
  in.get(face_force);
  if (ghosts_appended) face_force.resize(faces_now, Vec3{0, 0, 0});  // faces of the ghosts: never owned
  if (face_force.size() != faces_now) in.mismatch("the lateral surface differs");
}

void GravityLoad::save(CheckpointOut& out) const {
  out.put(power);
}
void GravityLoad::load(CheckpointIn& in) {
  in.get(power);
}

void Loads::save(CheckpointOut& out) const {
  platens.save(out);
  confinement.save(out);
  gravity.save(out);
}

void Loads::load(CheckpointIn& in, bool ghosts_appended) {
  platens.load(in);
  confinement.load(in, ghosts_appended);
  gravity.load(in);
}

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

namespace {

/// Lateral faces: surface faces not lying on the top or bottom end.
std::vector<std::array<int, 3>> lateral_faces(const Model& m) {
  std::vector<char> top(m.X.size(), 0), bottom(m.X.size(), 0);
  for (int n : m.top_nodes) top[n] = 1;
  for (int n : m.bottom_nodes) bottom[n] = 1;
  std::vector<std::array<int, 3>> faces;
  for (const auto& q : m.surface_faces) {
    const bool on_top = top[q[0]] && top[q[1]] && top[q[2]];
    const bool on_bottom = bottom[q[0]] && bottom[q[1]] && bottom[q[2]];
    if (!on_top && !on_bottom) faces.push_back(q);
  }
  return faces;
}

}  // namespace

Loads make_loads(const Scene& scene, const Model& m, real wave_speed) {
  Loads l;
  const real transits = 10 * m.height0 / wave_speed;
  PlatenLoad& p = l.platens;
  p.enabled = scene.platens.enabled;
  p.speed = scene.platens.velocity;
  p.ramp = scene.platens.ramp_time > 0 ? scene.platens.ramp_time : transits;
  p.friction = scene.material.friction_platen;
  p.top_z0 = m.box_max.z;
  p.bottom_z0 = m.box_min.z;
  p.k.resize(m.platen_nodes.size());
  p.anchor.resize(m.platen_nodes.size());
  for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) {
    p.k[i] = scene.material.contact_penalty * m.platen_node_area[i] / m.platen_node_h[i];
    const Vec3 X = m.X[m.platen_nodes[i]];
    p.anchor[i] = {X.x, X.y, 0};
  }
  ConfiningPressure& c = l.confinement;
  c.enabled = scene.confinement.enabled;
  c.hydrostatic = scene.confinement.path == ConfinementPath::hydrostatic;
  c.target = scene.confinement.pressure;
  c.ramp = scene.confinement.ramp_time > 0 ? scene.confinement.ramp_time : transits;
  if (c.enabled) {
    c.faces = lateral_faces(m);
    c.face_force.assign(c.faces.size(), Vec3{0, 0, 0});
  }
  l.gravity.enabled = scene.has_gravity();
  l.gravity.g = scene.gravity;
  return l;
}

}  // namespace fdem
