#include "loads/confinement.hpp"

namespace fdem {

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

void ConfiningPressure::set_up(const Scene& scene, const Model& m, real transits) {
  enabled = scene.confinement.enabled;
  hydrostatic = scene.confinement.path == ConfinementPath::hydrostatic;
  target = scene.confinement.pressure;
  ramp = scene.confinement.ramp_time > 0 ? scene.confinement.ramp_time : transits;
  if (!enabled) return;
  faces = lateral_faces(m);
  face_force.assign(faces.size(), Vec3{0, 0, 0});
}

real ConfiningPressure::pressure_at(real time, real axial) const {
  return confining_pressure(hydrostatic, target, hydrostatic ? target : ramped_speed(time, target, ramp), axial);
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

void ConfiningPressure::place(const Model& m, bool held) {
  fdem::place(b_, faces_, reinterpret_cast<const int*>(faces.data()), 3 * faces.size());
  std::vector<std::array<int, 2>> nf;
  for (int i = 0; i < int(faces.size()); ++i)
    for (int n : faces[i]) nf.push_back({n, i});
  std::stable_sort(nf.begin(), nf.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
  std::vector<int> node, ptr{0}, face;
  for (std::size_t k = 0; k < nf.size(); ++k) {
    if (k > 0 && nf[k][0] != nf[k - 1][0]) ptr.push_back(int(k));
    if (k == 0 || nf[k][0] != nf[k - 1][0]) node.push_back(nf[k][0]);
    face.push_back(nf[k][1]);
  }
  if (!nf.empty()) ptr.push_back(int(nf.size()));
  node_.upload(node);
  ptr_.upload(ptr);
  face_.upload(face);
  held_ = held;
  if (!held) return;
  std::vector<int> of(m.X.size(), -1);
  if (enabled)
    for (std::size_t k = 0; k < node.size(); ++k) of[node[k]] = int(k);
  held_of_.upload(of);
  loaded_nodes_ = enabled ? node : std::vector<int>{};
}

}  // namespace fdem
