#pragma once
// The element laws' parameters (src/physics, which knows no scene) from a scene's materials:
// one TET4 law per material, and one CE6 law per material followed by one per interface and
// one per joint.
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "physics/cohesive6.hpp"
#include "scene/scene.hpp"

namespace fdem {

/// The CE6 law's parameters from material m; broken_inert 0 (the solver sets it where tet-tet
/// contact takes over broken faces).
inline Ce6Params make_ce6_params(const Material& m) {
  Ce6Params p;
  p.ft = m.tensile_strength;
  p.cohesion = m.cohesion;
  p.tan_phi = std::tan(m.friction_angle * real(3.14159265358979323846) / 180);
  p.GI = m.fracture_energy_I;
  p.GII = m.fracture_energy_II;
  p.P_open = m.cohesive_penalty_open;
  p.P_tan = m.cohesive_penalty_tangential;
  p.P_overlap = m.cohesive_penalty_overlap;
  p.mu_rock = m.friction_rock;
  p.softening = m.softening == Softening::linear ? 1 : 0;
  p.Z = softening_integral(p.softening);
  p.broken_inert = 0;
  p.joint = 0;
  return p;
}

/// The largest strength factor (model/heterogeneity.hpp) CE6 law p takes at size h (m): the
/// pre-peak energy (2/3) f o_p, with o_p = 2 h f / P, must stay below G in both modes, so
/// f < sqrt(3 G P / (4 h)).
inline real largest_strength_factor(const Ce6Params& p, real h) {
  const real fi = std::sqrt(3 * p.GI * p.P_open / (4 * h)) / p.ft;
  const real fii = std::sqrt(3 * p.GII * p.P_tan / (4 * h)) / p.cohesion;
  return fi < fii ? fi : fii;
}

/// A TET4's Lamé constants (Pa) and its material's density with mass scaling (kg/m^3).
struct Tet4Law {
  real lambda, mu;
  real density;
};

/// The index of joint j's CE6 law: after the materials' and the interfaces'.
inline std::size_t joint_law(const Scene& scene, std::size_t j) {
  return scene.materials.size() + scene.interfaces.size() + j;
}

/// The element laws of a run: per material its TET4 law (Model::tet_material indexes it), and
/// the CE6 laws (Model::ce6_law indexes them): each material's own, each interface's, then each
/// joint's.
struct ElementLaws {
  std::vector<Tet4Law> tet4;
  std::vector<Ce6Params> ce6;
  std::vector<std::string> ce6_names;  // "granite", "granite|dyke", "bedding": for listings
  std::size_t first_joint = 0;         // ce6[first_joint + j] is joint j's law
  std::vector<real> joint_friction;    // per joint, the Coulomb coefficient of its faces in contact
  std::vector<char> joint_frictional;  // per joint, 1 where it starts broken
  /// The joint whose law is CE6 law `law`, or -1 (intact rock or an interface).
  int joint_of_law(std::size_t law) const {
    return law >= first_joint && law < first_joint + joint_friction.size() ? int(law - first_joint) : -1;
  }
};

/// A model's tet t's law: its material's, its E scaled by its factor in a heterogeneous rock.
inline Tet4Law tet4_law_of(const ElementLaws& laws, const std::vector<std::uint8_t>& material,
                           const std::vector<real>& stiffness, std::size_t t) {
  Tet4Law l = laws.tet4[material[t]];
  if (!stiffness.empty()) l.lambda *= stiffness[t], l.mu *= stiffness[t];
  return l;
}

/// The CE6 law of a face between tets of materials a and b (indices into scene.materials): a's
/// own where they are the same; else the interface that names the two; else the law of the one
/// with the lower tensile strength (the lower index on a tie).
inline std::uint8_t ce6_law_between(const Scene& scene, int a, int b) {
  if (a == b) return std::uint8_t(a);
  const std::string& na = scene.materials[a].name;
  const std::string& nb = scene.materials[b].name;
  for (std::size_t i = 0; i < scene.interfaces.size(); ++i) {
    const auto& w = scene.interfaces[i].between;
    if ((w[0] == na && w[1] == nb) || (w[0] == nb && w[1] == na)) return std::uint8_t(scene.materials.size() + i);
  }
  const real fa = scene.materials[a].tensile_strength, fb = scene.materials[b].tensile_strength;
  return std::uint8_t(fb < fa || (fb == fa && b < a) ? b : a);
}

/// The laws of `scene`'s materials, interfaces and joints; tet-tet contact, where the scene has it,
/// takes over broken CE6 faces (Ce6Params::broken_inert).
inline ElementLaws make_element_laws(const Scene& scene) {
  ElementLaws l;
  for (const Material& m : scene.materials) {
    l.tet4.push_back({m.lame_lambda(), m.lame_mu(), scene.solver.mass_scaling * m.density});
    l.ce6.push_back(make_ce6_params(m));
    l.ce6_names.push_back(m.name);
  }
  for (const MaterialInterface& i : scene.interfaces) {
    l.ce6.push_back(make_ce6_params(i.law));
    l.ce6_names.push_back(i.between[0] + "|" + i.between[1]);
  }
  l.first_joint = l.ce6.size();
  for (const Joint& j : scene.joints) {
    l.ce6.push_back(make_ce6_params(j.law));
    l.ce6.back().joint = 1;
    l.ce6_names.push_back(j.name);
    l.joint_friction.push_back(j.law.friction_rock);
    l.joint_frictional.push_back(j.frictional);
  }
  for (Ce6Params& p : l.ce6) p.broken_inert = scene.contact.enabled() ? 1 : 0;
  return l;
}

}  // namespace fdem
