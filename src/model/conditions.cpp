#include "model/conditions.hpp"

#include <algorithm>
#include <map>

#include "core/error.hpp"
#include "core/format.hpp"

namespace fdem {

namespace {

using VertexTriple = std::array<int, 3>;

/// "(x, y, z)", for messages.
std::string point(Vec3 p) {
  return "(" + fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) + ")";
}

VertexTriple sorted(VertexTriple t) {
  std::sort(t.begin(), t.end());
  return t;
}

/// The surface group a condition names (by name, or by tag where it is a number).
const MeshGroup& named_surface(const Mesh& mesh, const Scene& scene, std::size_t i) {
  return named_group(mesh, scene.conditions[i].surface, 2, scene.file + ": " + BoundaryCondition::key(i) + ".surface",
                     "a boundary condition acts on a surface");
}

/// Marks bit i on the surface faces of condition i's group; each of its faces must be one.
void mark_group(const Mesh& mesh, const Scene& scene, std::size_t i, const std::map<VertexTriple, int>& surface_face_of,
                Model& m) {
  const MeshGroup& g = named_surface(mesh, scene, i);
  if (g.faces.empty())
    throw InputError(scene.file + ": " + BoundaryCondition::key(i) + ".surface: " + g.label() +
                     " has no faces; name a group with faces");
  for (const auto& f : g.faces) {
    const auto it = surface_face_of.find(sorted(f));
    if (it == surface_face_of.end()) {
      const Vec3 c = (real(1) / 3) * (mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]);
      throw InputError(scene.file + ": " + BoundaryCondition::key(i) + ".surface: " + g.label() +
                       " has a face inside the rock (vertices " + std::to_string(f[0] + 1) + ", " +
                       std::to_string(f[1] + 1) + ", " + std::to_string(f[2] + 1) + ", centre " + point(c) +
                       " m); a boundary condition acts on the outer surface: name a group of boundary faces");
    }
    m.surface_conditions[it->second] |= std::uint32_t(1) << i;
  }
}

/// A roller's axis: its faces' normal, which must be one axis for all of them.
int roller_axis(const Scene& scene, std::size_t i, const Model& m) {
  int axis = -1;
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k) {
    if (!(m.surface_conditions[k] >> i & 1)) continue;
    const FaceAxis a = face_axis(m, m.surface_faces[k]);
    if (!a.aligned || (axis >= 0 && a.axis != axis))
      throw InputError(scene.file + ": " + BoundaryCondition::key(i) + ": a roller holds the velocity along its " +
                       "surface's normal, and surface '" + scene.conditions[i].surface +
                       "' is not one plane normal to x, y or z; split it into such planes, or use type: fixed");
    axis = a.axis;
  }
  return axis;
}

/// Two conditions fight over a mesh vertex's component when both prescribe it, unless both hold
/// it at zero (a fixed face meeting a roller along an edge agrees). By vertex, not node: where
/// CE6s split a vertex into several nodes, they would tear the CE6s between those apart.
void check_conflicts(const Scene& scene, const Model& m) {
  struct Claim {
    int condition = -1;
    bool zero = true;
  };
  std::vector<std::array<Claim, 3>> claims(m.X.size());  // (by vertex: node_vertex < nodes)
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k)
    for (std::size_t i = 0; i < scene.conditions.size(); ++i) {
      if (!(m.surface_conditions[k] >> i & 1)) continue;
      const BoundaryCondition& c = scene.conditions[i];
      const int mask = prescribed_components(c, m.condition_axis[i]);
      for (int n : m.surface_faces[k])
        for (int d = 0; d < 3; ++d) {
          if (!(mask >> d & 1)) continue;
          const bool zero = c.type != ConditionType::velocity || c.velocity[d] == 0;
          Claim& was = claims[m.node_vertex[n]][d];
          if (was.condition >= 0 && was.condition != int(i) && !(was.zero && zero))
            throw InputError(scene.file + ": " + BoundaryCondition::key(std::min<std::size_t>(was.condition, i)) +
                             " and " + BoundaryCondition::key(std::max<std::size_t>(was.condition, i)) +
                             " both prescribe the " + std::string(1, "xyz"[d]) + " velocity at " + point(m.X[n]) +
                             " m (surfaces '" + scene.conditions[was.condition].surface + "' and '" + c.surface +
                             "' meet there), with different values; give the shared edge to one of them (a "
                             "surface group without it)");
          if (was.condition < 0) was = Claim{int(i), zero};
        }
    }
}

/// m.node_conditions: each kinematic condition's bit on every node at a vertex of its faces.
void mark_held_nodes(const Scene& scene, Model& m) {
  std::uint32_t kinematic = 0;
  for (std::size_t i = 0; i < scene.conditions.size(); ++i)
    if (scene.conditions[i].kinematic()) kinematic |= std::uint32_t(1) << i;
  if (kinematic == 0) return;
  std::vector<std::uint32_t> at_vertex(m.X.size(), 0);  // (by vertex: node_vertex < nodes)
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k)
    for (int n : m.surface_faces[k]) at_vertex[m.node_vertex[n]] |= m.surface_conditions[k] & kinematic;
  m.node_conditions.resize(m.X.size());
  for (std::size_t n = 0; n < m.X.size(); ++n) m.node_conditions[n] = at_vertex[m.node_vertex[n]];
}

}  // namespace

FaceAxis face_axis(const Model& m, const std::array<int, 3>& q) {
  const Vec3 n = cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
  FaceAxis a;
  for (int d = 1; d < 3; ++d)
    if (std::fabs(n[d]) > std::fabs(n[a.axis])) a.axis = d;
  real off = 0;
  for (int d = 0; d < 3; ++d)
    if (d != a.axis) off = std::max(off, std::fabs(n[d]));
  a.aligned = off <= 1e-6 * std::fabs(n[a.axis]);
  return a;
}

int prescribed_components(const BoundaryCondition& c, int axis) {
  switch (c.type) {
    case ConditionType::roller:
      return 1 << axis;
    case ConditionType::velocity:
      return c.components;
    case ConditionType::fixed:
      return 7;
    default:
      return 0;  // a face load
  }
}

std::string describe_conditions(const Scene& scene, const Model& m, const std::string& where) {
  std::string out;
  for (std::size_t i = 0; i < scene.conditions.size(); ++i) {
    long faces = 0;
    for (std::size_t k = 0; k < m.surface_faces.size(); ++k) faces += m.conditions_of(k) >> i & 1;
    const BoundaryCondition& c = scene.conditions[i];
    out += "  boundary condition bc" + std::to_string(i) + " " + name_of(c.type) + " on surface '" + c.surface +
           "': " + std::to_string(faces) + " faces" + where + "\n";
  }
  return out;
}

void mark_condition_faces(const Mesh& mesh, const Scene& scene, Model& m) {
  m.surface_conditions.clear(), m.node_conditions.clear(), m.condition_axis.clear();
  if (scene.conditions.empty()) return;
  m.surface_conditions.assign(m.surface_faces.size(), 0);
  std::map<VertexTriple, int> surface_face_of;
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k) {
    const auto& q = m.surface_faces[k];
    surface_face_of[sorted({m.node_vertex[q[0]], m.node_vertex[q[1]], m.node_vertex[q[2]]})] = int(k);
  }
  for (std::size_t i = 0; i < scene.conditions.size(); ++i) {
    mark_group(mesh, scene, i, surface_face_of, m);
    m.condition_axis.push_back(
        std::int8_t(scene.conditions[i].type == ConditionType::roller ? roller_axis(scene, i, m) : -1));
  }
  check_conflicts(scene, m);
  mark_held_nodes(scene, m);
}

}  // namespace fdem
