// The scene's rock. `material` gives one material to every tet. `materials` is a list, each
// entry a material with a name and the volume groups it fills; one entry may leave out groups
// and fills the rest. `interfaces` gives CE6 laws between two materials, `joints` CE6 laws on
// surfaces inside the rock. Which groups exist is known only with the mesh: model/materials.cpp
// and model/joints.cpp check the names.
#include "scene/materials.hpp"

#include <algorithm>
#include <cmath>

#include "core/format.hpp"

namespace fdem::scene_reading {

namespace {

const char* const kMaterialsForm =
    "write e.g. materials: [{name: granite, groups: [rock], youngs_modulus: 60e9}, {name: dyke, groups: [dyke], "
    "youngs_modulus: 20e9}]";

/// The keys of the CE6 law, which an interface may give.
const std::vector<std::string> kCe6Keys = {"tensile_strength",
                                           "cohesion",
                                           "friction_angle",
                                           "fracture_energy_I",
                                           "fracture_energy_II",
                                           "cohesive_penalty_open",
                                           "cohesive_penalty_tangential",
                                           "cohesive_penalty_overlap",
                                           "softening"};

/// groups: [name or tag, ...] (or a joint's surfaces), at least one.
void read_groups(YamlReader& r, const YAML::Node& n, const std::string& p, std::vector<std::string>& out,
                 const std::string& kind = "volume") {
  const std::string form = kind == "volume"
                               ? "write e.g. groups: [rock] (volume groups of the mesh; fdem check lists them)"
                               : "write e.g. surfaces: [bedding] (surface groups of the mesh; fdem check lists them)";
  if (!n.IsSequence() || n.size() == 0) {
    r.error(p, "expected a list of " + kind + " group names, got " + describe(n), form);
    return;
  }
  for (std::size_t k = 0; k < n.size(); ++k) {
    if (!n[k].IsScalar() || n[k].Scalar().empty()) {
      r.error(p + "[" + std::to_string(k) + "]", "expected a group name or tag, got " + describe(n[k]), form);
      continue;
    }
    if (std::find(out.begin(), out.end(), n[k].Scalar()) != out.end())
      r.error(p + "[" + std::to_string(k) + "]", "'" + n[k].Scalar() + "' is listed twice", "list each group once");
    out.push_back(n[k].Scalar());
  }
}

void read_one_material(YamlReader& r, const YAML::Node& n, const std::string& p, Material& m) {
  std::vector<std::string> allowed = {"name", "groups"};
  const std::vector<std::string> keys = material_keys();
  allowed.insert(allowed.end(), keys.begin(), keys.end());
  if (!r.check_map(n, p, allowed)) return;
  if (!n["name"]) r.error(p + ".name", "missing", "give the material a name (interfaces and listings use it)");
  r.text(n, p, "name", m.name, "give the material a name");
  if (n["groups"]) read_groups(r, n["groups"], p + ".groups", m.groups);
  read_material_keys(r, n, p, m);
}

/// The material an interface names, or -1 (reported).
int material_named(YamlReader& r, const Scene& s, const YAML::Node& v, const std::string& p) {
  std::string list;
  for (const Material& m : s.materials) {
    if (v.IsScalar() && v.Scalar() == m.name) return int(&m - s.materials.data());
    list += (list.empty() ? "" : ", ") + m.name;
  }
  r.error(p, (v.IsScalar() ? "'" + v.Scalar() + "'" : describe(v)) + " is not a material", "the materials: " + list);
  return -1;
}

/// Which of materials a and b is weaker: the lower tensile strength (model/laws.hpp's rule).
int weaker(const Scene& s, int a, int b) {
  const real fa = s.materials[a].tensile_strength, fb = s.materials[b].tensile_strength;
  return fb < fa || (fb == fa && b < a) ? b : a;
}

/// One CE6 law's fracture energies against the element size h (m): each must exceed the
/// elastic energy its penalty stores at the peak, (2/3) strength o_p with o_p = 2 h strength / P.
void cohesive_law(YamlReader& r, const Material& m, const std::string& p, double h) {
  const double o_p = 2 * h * m.tensile_strength / m.cohesive_penalty_open;
  const double gi_min = 2.0 / 3.0 * m.tensile_strength * o_p;
  if (!(m.fracture_energy_I > gi_min))
    r.error(p + ".fracture_energy_I",
            fmt(m.fracture_energy_I) +
                " J/m^2 is too small for the cohesive law: need > (2/3)*tensile_strength*o_p = " + fmt(gi_min) +
                " J/m^2, o_p = 2*element_size*tensile_strength/cohesive_penalty_open",
            "raise fracture_energy_I or cohesive_penalty_open, or lower mesh.generate.element_size or "
            "tensile_strength");
  const double s_p = 2 * h * m.cohesion / m.cohesive_penalty_tangential;
  const double gii_min = 2.0 / 3.0 * m.cohesion * s_p;
  if (!(m.fracture_energy_II > gii_min))
    r.error(p + ".fracture_energy_II",
            fmt(m.fracture_energy_II) + " J/m^2 is too small for the cohesive law: need > (2/3)*cohesion*s_p = " +
                fmt(gii_min) + " J/m^2, s_p = 2*element_size*cohesion/cohesive_penalty_tangential",
            "raise fracture_energy_II or cohesive_penalty_tangential, or lower mesh.generate.element_size or "
            "cohesion");
}

/// heterogeneity: {distribution: weibull, modulus: m, seed: k} or {distribution: normal,
/// deviation: s, seed: k}.
void read_heterogeneity(YamlReader& r, const YAML::Node& n, const std::string& p, Heterogeneity& h) {
  if (!r.check_map(n, p, {"distribution", "modulus", "deviation", "seed", "youngs_modulus"})) return;
  if (!n["distribution"]) r.error(p + ".distribution", "missing", "give distribution: weibull or normal");
  if (!r.choice(n, p, "distribution", h.distribution)) return;
  const bool weibull = h.distribution == StrengthSpread::weibull, normal = h.distribution == StrengthSpread::normal;
  const char* key = weibull ? "modulus" : "deviation";
  if ((weibull || normal) && !n[key])
    r.error(p + "." + key, "missing",
            weibull ? "give the Weibull modulus m (e.g. 6; larger is more uniform)"
                    : "give the standard deviation over the mean (e.g. 0.2)");
  for (const char* other : {"modulus", "deviation"})
    if (n[other] && (std::string(other) != key || !(weibull || normal)))
      r.error(p + "." + other, std::string("is not read for distribution ") + name_of(h.distribution), "remove it");
  r.number(n, p, "modulus", Range{0.5, 1000, true, true}, h.modulus);
  r.number(n, p, "deviation", Range{0, 0.3, true, false}, h.deviation);
  r.number(n, p, "seed", count_at_least(0, 1e15), h.seed);
  r.boolean(n, p, "youngs_modulus", h.youngs_modulus);
}

}  // namespace

std::vector<std::string> material_keys() {
  std::vector<std::string> k = {"density", "youngs_modulus", "poisson_ratio"};
  k.insert(k.end(), kCe6Keys.begin(), kCe6Keys.end());
  k.insert(k.end(), {"contact_penalty", "friction_platen", "friction_rock", "heterogeneity"});
  return k;
}

void read_material_keys(YamlReader& r, const YAML::Node& n, const std::string& p, Material& m) {
  // Upper bounds far beyond any solid (osmium 22.6e3 kg/m^3, diamond 1.2e12 Pa), so that the
  // products in the laws stay finite: density 1e300 gave a time step of 1e141 s and NaN forces.
  auto up_to = [](double hi) { return Range{0, hi, true, false}; };
  r.number(n, p, "density", up_to(1e5), m.density);
  r.number(n, p, "youngs_modulus", up_to(1e13), m.youngs_modulus);
  r.number(n, p, "poisson_ratio", Range{0, 0.5, false, true}, m.poisson_ratio);
  r.number(n, p, "tensile_strength", up_to(1e11), m.tensile_strength);
  r.number(n, p, "cohesion", up_to(1e11), m.cohesion);
  r.number(n, p, "friction_angle", Range{0, 90, false, true}, m.friction_angle);
  r.number(n, p, "fracture_energy_I", up_to(1e9), m.fracture_energy_I);
  r.number(n, p, "fracture_energy_II", up_to(1e9), m.fracture_energy_II);
  r.number(n, p, "contact_penalty", up_to(1e17), m.contact_penalty);
  r.number(n, p, "cohesive_penalty_open", up_to(1e17), m.cohesive_penalty_open);
  r.number(n, p, "cohesive_penalty_tangential", up_to(1e17), m.cohesive_penalty_tangential);
  r.number(n, p, "cohesive_penalty_overlap", up_to(1e17), m.cohesive_penalty_overlap);
  r.number(n, p, "friction_platen", closed(0, 10), m.friction_platen);
  r.number(n, p, "friction_rock", closed(0, 10), m.friction_rock);
  r.choice(n, p, "softening", m.softening);
  if (n["heterogeneity"]) read_heterogeneity(r, n["heterogeneity"], p + ".heterogeneity", m.heterogeneity);
}

void read_materials(YamlReader& r, const YAML::Node& n, Scene& s) {
  const std::string p = "materials";
  if (!n.IsSequence() || n.size() == 0) {
    r.error(p, "expected a list of materials, got " + describe(n), kMaterialsForm);
    return;
  }
  if (n.size() > Scene::kMaxMaterials) {
    r.error(p, std::to_string(n.size()) + " materials", "give at most " + std::to_string(Scene::kMaxMaterials));
    return;
  }
  s.materials.clear();
  int rest = -1;
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string pi = p + "[" + std::to_string(i) + "]";
    Material m;
    read_one_material(r, n[i], pi, m);
    for (const Material& o : s.materials)
      if (!m.name.empty() && o.name == m.name)
        r.error(pi + ".name", "'" + m.name + "' names two materials", "give each material its own name");
    if (m.groups.empty() && n[i].IsMap() && !n[i]["groups"]) {
      if (rest >= 0)
        r.error(pi + ".groups", "missing, and materials[" + std::to_string(rest) + "] has none either",
                "one material may leave out groups (it fills every tet the others do not); give the others "
                "their volume groups");
      rest = int(i);
    }
    s.materials.push_back(m);
  }
}

void read_interfaces(YamlReader& r, const YAML::Node& n, Scene& s) {
  const std::string p = "interfaces";
  const std::string form = "write e.g. interfaces: [{between: [granite, dyke], tensile_strength: 0.5e6}]";
  if (!n.IsSequence()) {
    r.error(p, "expected a list of interfaces, got " + describe(n), form);
    return;
  }
  if (s.materials.size() + n.size() > Scene::kMaxMaterials) {
    r.error(p, std::to_string(n.size()) + " interfaces",
            "give at most " + std::to_string(Scene::kMaxMaterials) + " materials and interfaces in all");
    return;
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string pi = MaterialInterface::key(i);
    std::vector<std::string> allowed = {"between"};
    allowed.insert(allowed.end(), kCe6Keys.begin(), kCe6Keys.end());
    if (!r.check_map(n[i], pi, allowed)) continue;
    const YAML::Node w = n[i]["between"];
    if (!w || !w.IsSequence() || w.size() != 2) {
      r.error(pi + ".between", w ? "expected two material names, got " + describe(w) : "missing", form);
      continue;
    }
    const int a = material_named(r, s, w[0], pi + ".between[0]"), b = material_named(r, s, w[1], pi + ".between[1]");
    if (a < 0 || b < 0) continue;
    if (a == b) {
      r.error(pi + ".between", "names '" + s.materials[a].name + "' twice",
              "an interface joins two materials; a material's own CE6s take its keys");
      continue;
    }
    for (const MaterialInterface& o : s.interfaces)
      if ((o.between[0] == s.materials[a].name && o.between[1] == s.materials[b].name) ||
          (o.between[1] == s.materials[a].name && o.between[0] == s.materials[b].name))
        r.error(pi + ".between", "the interface between these two is given twice", "give it once");
    MaterialInterface f;
    f.between = {s.materials[a].name, s.materials[b].name};
    f.law = s.materials[weaker(s, a, b)];  // the keys not given: the weaker material's
    f.law.name = f.between[0] + "|" + f.between[1], f.law.groups.clear();
    f.law.heterogeneity = Heterogeneity{};  // (the materials' spread is their own CE6s')
    read_material_keys(r, n[i], pi, f.law);
    s.interfaces.push_back(f);
  }
}

void read_joints(YamlReader& r, const YAML::Node& n, Scene& s) {
  const std::string p = "joints";
  const std::string form = "write e.g. joints: [{name: bedding, surfaces: [bedding], friction: 0.6, frictional: true}]";
  if (!n.IsSequence() || n.size() == 0) {
    r.error(p, "expected a list of joints, got " + describe(n), form);
    return;
  }
  if (s.materials.size() + s.interfaces.size() + n.size() > Scene::kMaxMaterials) {
    r.error(p, std::to_string(n.size()) + " joints",
            "give at most " + std::to_string(Scene::kMaxMaterials) + " materials, interfaces and joints in all");
    return;
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string pi = Joint::key(i);
    std::vector<std::string> allowed = {"name", "surfaces", "frictional", "friction"};
    allowed.insert(allowed.end(), kCe6Keys.begin(), kCe6Keys.end());
    if (!r.check_map(n[i], pi, allowed)) continue;
    Joint j;
    j.law = s.material();  // the keys not given: the first material's
    j.law.groups.clear();
    j.law.heterogeneity = Heterogeneity{};
    if (!n[i]["name"]) r.error(pi + ".name", "missing", "give the joint a name (listings and broken_ce6.csv use it)");
    r.text(n[i], pi, "name", j.name, "give the joint a name");
    for (const Joint& o : s.joints)
      if (!j.name.empty() && o.name == j.name)
        r.error(pi + ".name", "'" + j.name + "' names two joints", "give each joint its own name");
    if (!n[i]["surfaces"])
      r.error(pi + ".surfaces", "missing", "give the surface groups the joint lies on (fdem check lists them)");
    else
      read_groups(r, n[i]["surfaces"], pi + ".surfaces", j.surfaces, "surface");
    r.boolean(n[i], pi, "frictional", j.frictional);
    r.number(n[i], pi, "friction", closed(0, 10), j.law.friction_rock);
    read_material_keys(r, n[i], pi, j.law);
    j.law.name = j.name;
    s.joints.push_back(j);
  }
}

void check_materials(YamlReader& r, const Scene& s) {
  const Material& first = s.material();
  for (std::size_t i = 1; i < s.materials.size(); ++i) {
    const Material& m = s.materials[i];
    const std::pair<const char*, real> shared[] = {{"contact_penalty", m.contact_penalty - first.contact_penalty},
                                                   {"friction_platen", m.friction_platen - first.friction_platen},
                                                   {"friction_rock", m.friction_rock - first.friction_rock}};
    for (const auto& [key, diff] : shared)
      if (diff != 0)
        r.error("materials[" + std::to_string(i) + "]." + key, "differs from materials[0]'s",
                "tet-tet contact and the platens use one value for every pair of tets: give every material the "
                "same " +
                    std::string(key));
  }
  if (!s.mesh.generated()) return;  // mesh from a file: no element size known here
  const bool one = s.materials.size() == 1 && s.materials[0].name.empty();
  for (std::size_t i = 0; i < s.materials.size(); ++i)
    cohesive_law(r, s.materials[i], one ? "material" : "materials[" + std::to_string(i) + "]", s.mesh.element_size);
  for (std::size_t i = 0; i < s.interfaces.size(); ++i)
    cohesive_law(r, s.interfaces[i].law, MaterialInterface::key(i), s.mesh.element_size);
  for (std::size_t i = 0; i < s.joints.size(); ++i)
    if (!s.joints[i].frictional) cohesive_law(r, s.joints[i].law, Joint::key(i), s.mesh.element_size);
}

}  // namespace fdem::scene_reading
