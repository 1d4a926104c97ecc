// Materials on volume groups: each tet takes the material whose groups hold it, or the one
// material that names no groups. Which groups exist is known only with the mesh, so the
// checks that name them are here and not in the scene reader.
#include "model/materials.hpp"

#include "core/error.hpp"
#include "core/format.hpp"
#include "model/laws.hpp"

namespace fdem {

namespace {

std::string material_key(const Scene& scene, std::size_t i) {
  return scene.file + ": materials[" + std::to_string(i) + "] ('" + scene.materials[i].name + "')";
}

/// The volume group a material names (by name, or by tag where it is a number).
const MeshGroup& named_volume(const Mesh& mesh, const Scene& scene, std::size_t i, const std::string& want) {
  return named_group(mesh, want, 3, material_key(scene, i) + ".groups", "a material fills volumes");
}

/// "(x, y, z) m", the centroid of a tet of the mesh, for messages.
std::string tet_place(const Mesh& mesh, int t) {
  Vec3 c{0, 0, 0};
  for (int v : mesh.tets[t]) c += 0.25 * mesh.vertices[v];
  return "tet " + std::to_string(t + 1) + " at (" + fmt(c.x) + ", " + fmt(c.y) + ", " + fmt(c.z) + ") m";
}

}  // namespace

std::vector<std::uint8_t> material_of_mesh_tets(const Mesh& mesh, const Scene& scene) {
  constexpr std::uint8_t kNone = 0xff;
  const std::size_t nt = mesh.tets.size();
  if (scene.materials.size() == 1 && scene.materials[0].groups.empty()) return std::vector<std::uint8_t>(nt, 0);
  std::vector<std::uint8_t> of(nt, kNone);
  int rest = -1;  // the material that names no groups
  for (std::size_t i = 0; i < scene.materials.size(); ++i) {
    if (scene.materials[i].groups.empty()) rest = int(i);
    for (const std::string& name : scene.materials[i].groups)
      for (int t : named_volume(mesh, scene, i, name).tets) {
        if (of[t] != kNone && of[t] != i)
          throw InputError(material_key(scene, i) + ".groups: " + tet_place(mesh, t) + " is in group '" + name +
                           "' and also in a group of materials[" + std::to_string(of[t]) + "] ('" +
                           scene.materials[of[t]].name + "'); give each volume group to one material");
        of[t] = std::uint8_t(i);
      }
  }
  std::vector<long> count(scene.materials.size(), 0);
  for (std::size_t t = 0; t < nt; ++t) {
    if (of[t] == kNone) {
      if (rest < 0)
        throw InputError(scene.file + ": materials: " + tet_place(mesh, int(t)) +
                         " is in no material's volume groups; give its group to a material, or leave one "
                         "material without groups (it fills every tet the others do not)");
      of[t] = std::uint8_t(rest);
    }
    ++count[of[t]];
  }
  for (std::size_t i = 0; i < count.size(); ++i)
    if (count[i] == 0)
      throw InputError(material_key(scene, i) + ": no tet is made of it (" +
                       (scene.materials[i].groups.empty() ? std::string("the other materials' groups hold every tet")
                                                          : std::string("its groups hold no tets")) +
                       "); remove it or give it a volume group");
  return of;
}

std::string describe_materials(const Scene& scene, const Model& m, const std::string& where) {
  const Material& only = scene.materials[0];
  if (scene.materials.size() == 1 && only.name.empty() && !only.heterogeneity.on()) return "";  // (the shorthand)
  const std::size_t nm = scene.materials.size(), nl = nm + scene.interfaces.size();
  std::vector<long> tets(nm, 0), ce6s(nl, 0);
  for (std::uint8_t k : m.tet_material) ++tets[k];
  for (std::uint8_t k : m.ce6_law)
    if (k < nl) ++ce6s[k];  // (a joint's laws follow: describe_joints)
  std::string out;
  for (std::size_t i = 0; i < nm; ++i) {
    const Material& a = scene.materials[i];
    std::string groups;
    for (const std::string& g : a.groups) groups += (groups.empty() ? "" : ", ") + g;
    const Heterogeneity& h = a.heterogeneity;
    const std::string spread = h.distribution == StrengthSpread::weibull ? ", strengths Weibull m = " + fmt(h.modulus)
                               : h.distribution == StrengthSpread::normal
                                   ? ", strengths normal, deviation " + fmt(h.deviation) + " of the mean"
                                   : "";
    const std::string label = a.name.empty() ? "material" : "material '" + a.name + "'";
    out += "  " + label + " (" +
           (!groups.empty() ? "volume groups " + groups
            : nm == 1       ? "every tet"
                            : "every other tet") +
           "): " + std::to_string(tets[i]) + " tets, " + std::to_string(ce6s[i]) + " CE6s with its law" + spread +
           where + "\n";
  }
  for (std::size_t i = nm; i < nl; ++i) {
    const auto& w = scene.interfaces[i - nm].between;
    out += "  interface '" + w[0] + "' | '" + w[1] + "': " + std::to_string(ce6s[i]) + " CE6s" + where + "\n";
  }
  return out;
}

}  // namespace fdem
