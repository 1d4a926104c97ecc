// Joint sets: surface groups inside the rock whose faces get CE6s of the joint's law. Which
// groups exist, and whether their faces lie inside the rock, is known only with the mesh.
#include "model/joints.hpp"

#include <algorithm>

#include "core/error.hpp"
#include "core/format.hpp"
#include "model/laws.hpp"

namespace fdem {

namespace {

std::string joint_key(const Scene& scene, std::size_t j) {
  return scene.file + ": " + Joint::key(j) + " ('" + scene.joints[j].name + "')";
}

/// The surface group a joint names (by name, or by tag where it is a number).
const MeshGroup& named_surface(const Mesh& mesh, const Scene& scene, std::size_t j, const std::string& want) {
  const MeshGroup& g = named_group(mesh, want, 2, joint_key(scene, j) + ".surfaces", "a joint lies on a surface");
  if (g.faces.empty())
    throw InputError(joint_key(scene, j) + ".surfaces: " + g.label() + " has no faces; name a group with faces");
  return g;
}

std::array<int, 3> sorted(std::array<int, 3> f) {
  std::sort(f.begin(), f.end());
  return f;
}

}  // namespace

JointFaces joint_faces(const Mesh& mesh, const Scene& scene) {
  JointFaces out;
  for (std::size_t j = 0; j < scene.joints.size(); ++j)
    for (const std::string& name : scene.joints[j].surfaces)
      for (const auto& f : named_surface(mesh, scene, j, name).faces) {
        const auto [it, added] = out.emplace(sorted(f), JointFace{int(j), false});
        if (!added && it->second.joint != int(j))
          throw InputError(joint_key(scene, j) + ".surfaces: the face of vertices " + std::to_string(f[0] + 1) + ", " +
                           std::to_string(f[1] + 1) + ", " + std::to_string(f[2] + 1) + " is also on " +
                           Joint::key(it->second.joint) + " ('" + scene.joints[it->second.joint].name +
                           "'); give each surface to one joint");
      }
  return out;
}

void check_joint_faces_internal(const Mesh& mesh, const Scene& scene, const JointFaces& faces) {
  for (const auto& [f, jf] : faces) {
    if (jf.internal) continue;
    const Vec3 c = (real(1) / 3) * (mesh.vertices[f[0]] + mesh.vertices[f[1]] + mesh.vertices[f[2]]);
    throw InputError(joint_key(scene, jf.joint) + ".surfaces: the face of vertices " + std::to_string(f[0] + 1) + ", " +
                     std::to_string(f[1] + 1) + ", " + std::to_string(f[2] + 1) + " (centre (" + fmt(c.x) + ", " +
                     fmt(c.y) + ", " + fmt(c.z) +
                     ") m) is not between two tets: it is on the outer surface, or the mesh does not conform to "
                     "it. A joint lies inside the rock: embed its surface in the volume (gmsh: Surface{s} In "
                     "Volume{v}, or BooleanFragments) and name it with a physical group");
  }
}

std::vector<std::uint8_t> tets_on_joints(const Scene& scene, const Model& m) {
  if (scene.joints.empty()) return {};
  std::vector<std::uint8_t> on(m.tet_nodes.size(), 0);
  const std::size_t first = joint_law(scene, 0);
  auto friction = [&](int j) { return scene.joints[j].law.friction_rock; };
  for (std::size_t c = 0; c < m.ce6_law.size(); ++c) {
    if (m.ce6_law[c] < first) continue;
    const int j = int(m.ce6_law[c] - first);
    for (int t : m.ce6_tets[c]) {
      const int held = int(on[t]) - 1;
      if (held < 0 || friction(j) < friction(held) || (friction(j) == friction(held) && j < held))
        on[t] = std::uint8_t(j + 1);
    }
  }
  return on;
}

std::string describe_joints(const Scene& scene, const Model& m, const std::string& where) {
  std::string out;
  const std::size_t first = joint_law(scene, 0);
  for (std::size_t j = 0; j < scene.joints.size(); ++j) {
    const Joint& a = scene.joints[j];
    const long ce6s = long(std::count(m.ce6_law.begin(), m.ce6_law.end(), std::uint8_t(first + j)));
    std::string surfaces;
    for (const std::string& s : a.surfaces) surfaces += (surfaces.empty() ? "" : ", ") + s;
    out += "  joint '" + a.name + "' (surfaces " + surfaces + "): " + std::to_string(ce6s) + " CE6s" + where + ", " +
           (a.frictional ? "frictional" : "cohesive, tensile strength " + fmt(a.law.tensile_strength) + " Pa") +
           ", friction " + fmt(a.law.friction_rock) + "\n";
  }
  return out;
}

}  // namespace fdem
