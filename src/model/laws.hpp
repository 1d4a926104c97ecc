#pragma once
// The element laws' parameters (src/physics, which knows no scene) from a scene's material.
#include <cmath>

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
  return p;
}

/// The element laws' constants of a run: the TET4's Lame constants and the CE6 law's parameters.
struct ElementLaws {
  real lambda = 0, mu = 0;  // Pa
  Ce6Params ce6{};
};

/// The laws of `scene`'s material; tet-tet contact, where the scene has it, takes over broken
/// CE6 faces (Ce6Params::broken_inert).
inline ElementLaws make_element_laws(const Scene& scene) {
  ElementLaws l;
  l.lambda = scene.material.lame_lambda();
  l.mu = scene.material.lame_mu();
  l.ce6 = make_ce6_params(scene.material);
  l.ce6.broken_inert = scene.contact.enabled() ? 1 : 0;
  return l;
}

}  // namespace fdem
