#include "loads/surface_loads.hpp"

namespace fdem {

namespace {

/// Per surface face, whether it is lateral: not lying on the top or bottom end.
std::vector<char> lateral_faces(const Model& m) {
  std::vector<char> top(m.X.size(), 0), bottom(m.X.size(), 0), lateral;
  for (int n : m.top_nodes) top[n] = 1;
  for (int n : m.bottom_nodes) bottom[n] = 1;
  for (const auto& q : m.surface_faces) {
    const bool on_top = top[q[0]] && top[q[1]] && top[q[2]];
    const bool on_bottom = bottom[q[0]] && bottom[q[1]] && bottom[q[2]];
    lateral.push_back(!on_top && !on_bottom);
  }
  return lateral;
}

/// A condition's value at scale 1: the pressure or the traction (none for the others).
Vec3 face_value(const BoundaryCondition& c) {
  switch (c.type) {
    case ConditionType::pressure:
      return Vec3{c.pressure, 0, 0};
    case ConditionType::traction:
      return c.traction;
    default:
      return Vec3{0, 0, 0};
  }
}

/// The P and S impedances (Pa s/m) of the material of surface face k's tet, mass scaling included.
Vec3 rock_impedance(const Scene& scene, const Model& m, std::size_t k) {
  const int t = m.surface_tet[k];
  const Material& mat = scene.materials[m.tet_material[t]];
  const real rho = scene.solver.mass_scaling * mat.density, f = m.tet_stiffness.empty() ? 1 : m.tet_stiffness[t];
  return Vec3{p_impedance(rho, f * mat.lame_lambda(), f * mat.lame_mu()), s_impedance(rho, f * mat.lame_mu()), 0};
}

}  // namespace

void SurfaceLoads::set_up(const Scene& scene, const Model& m, real transits) {
  confining = scene.confinement.enabled;
  hydrostatic = confining && scene.confinement.path == ConfinementPath::hydrostatic;
  target = confining ? scene.confinement.pressure : 0;
  ramp = scene.confinement.ramp_time > 0 ? scene.confinement.ramp_time : transits;
  faces.clear(), face_condition.clear(), face_area0.clear(), face_impedance.clear();
  type_.clear(), value_.clear(), time_.clear();
  bool any = false, absorbing = false;
  for (const BoundaryCondition& c : scene.conditions) {
    type_.push_back(c.type), value_.push_back(face_value(c)), time_.push_back(c.time);
    any = any || !c.kinematic();
    absorbing = absorbing || c.type == ConditionType::absorbing;
  }
  // Surface faces in order (those of contact ghosts gathered later come last), each as a
  // lateral face of the confinement, then once per condition it carries.
  const std::vector<char> lateral = confining ? lateral_faces(m) : std::vector<char>{};
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k) {
    if (confining && lateral[k]) {
      faces.push_back(m.surface_faces[k]), face_condition.push_back(-1);
      if (absorbing) face_impedance.push_back(Vec3{0, 0, 0});
    }
    for (std::size_t c = 0; any && c < scene.conditions.size(); ++c)
      if ((m.conditions_of(k) >> c & 1) && !scene.conditions[c].kinematic()) {
        faces.push_back(m.surface_faces[k]), face_condition.push_back(int(c));
        if (absorbing) face_impedance.push_back(rock_impedance(scene, m, k));
      }
  }
  if (any)
    for (const auto& q : faces) face_area0.push_back(0.5 * norm(cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]])));
  enabled = confining || any;
  face_force.assign(faces.size(), Vec3{0, 0, 0});
  face_power.assign(any ? faces.size() : 0, 0);
  face_work.assign(any ? faces.size() : 0, 0);
  if (!any) face_condition.clear();  // (the confinement alone: no per-face condition read)
}

real SurfaceLoads::pressure_at(real time, real axial) const {
  if (!confining) return 0;
  return confining_pressure(hydrostatic, target, hydrostatic ? target : ramped_speed(time, target, ramp), axial);
}

FaceLaws SurfaceLoads::laws_at(real time) const {
  FaceLaws laws{};
  for (std::size_t c = 0; c < type_.size(); ++c) {
    laws.type[c] = type_[c];
    laws.value[c] = type_[c] == ConditionType::absorbing ? value_[c] : time_[c].at(time) * value_[c];
  }
  return laws;
}

std::vector<real> SurfaceLoads::condition_sums(const std::vector<std::uint8_t>& owned) const {
  std::vector<real> sums(4 * type_.size(), 0);
  for (std::size_t i = 0; i < face_condition.size(); ++i) {
    const int c = face_condition[i];
    if (c < 0) continue;
    for (int n : faces[i])
      if (owned.empty() || owned[n])
        for (int d = 0; d < 3; ++d) sums[4 * c + d] += face_force[i][d];
    sums[4 * c + 3] += face_work[i];
  }
  return sums;
}

void SurfaceLoads::save(CheckpointOut& out) const {
  out.put(pressure);
  out.put(power);
  out.put(face_force);
  out.put(face_power);
  out.put(face_work);
}

void SurfaceLoads::load(CheckpointIn& in, bool ghosts_appended) {
  const std::size_t faces_now = face_force.size(), kept = face_power.size();
  in.get(pressure);
  in.get(power);
  in.get(face_force);
  in.get(face_power);
  in.get(face_work);
  if (ghosts_appended) {  // faces of the ghosts: never owned, no condition
    face_force.resize(faces_now, Vec3{0, 0, 0});
    face_power.resize(kept, 0), face_work.resize(kept, 0);
  }
  if (face_force.size() != faces_now || face_power.size() != kept || face_work.size() != kept)
    in.mismatch("the loaded surface differs");
}

void SurfaceLoads::place(const Model& m, bool held) {
  fdem::place(b_, faces_, reinterpret_cast<const int*>(faces.data()), 3 * faces.size());
  fdem::place(b_, cond_, face_condition);
  fdem::place(b_, area0_, face_area0);
  fdem::place(b_, impedance_, face_impedance);
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

void SurfaceLoads::upload_state() {
  fdem::place(b_, force_, face_force);
  fdem::place(b_, power_, face_power);
  fdem::place(b_, work_, face_work);
}

void SurfaceLoads::download_state() {
  force_.download(face_force);
  if (power_.size() == 0) return;
  power_.download(face_power);
  work_.download(face_work);
}

}  // namespace fdem
