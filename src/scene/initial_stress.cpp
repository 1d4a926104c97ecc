// The scene's initial_stress: the in-situ stress the rock starts in, as a tensor at a reference
// level with its change per metre of depth, or geostatic (the weight of the rock above, with
// horizontal ratios). Either way a linear function of depth, which must balance gravity so that
// the rock starts at rest.
#include <cmath>

#include "core/format.hpp"
#include "scene/conditions.hpp"

namespace fdem::scene_reading {

namespace {

const char* const kForm =
    "write e.g. initial_stress: {stress: {xx: -20e6, yy: -10e6, zz: -15e6}} (Pa, tension positive), or "
    "initial_stress: {geostatic: {surface_z: 0, k_x: 1.5, k_y: 1.0}} with gravity: [0, 0, -9.81]";

/// A symmetric tensor {xx, yy, zz, yz, xz, xy}; components not given are 0.
void read_tensor(YamlReader& r, const YAML::Node& n, const std::string& p, const Range& range, Sym3& out) {
  if (!r.check_map(n, p, {"xx", "yy", "zz", "yz", "xz", "xy"})) return;
  r.number(n, p, "xx", range, out.xx);
  r.number(n, p, "yy", range, out.yy);
  r.number(n, p, "zz", range, out.zz);
  r.number(n, p, "yz", range, out.yz);
  r.number(n, p, "xz", range, out.xz);
  r.number(n, p, "xy", range, out.xy);
}

/// geostatic: {surface_z, k_x, k_y}: sigma_zz = -rho g (surface_z - z) with materials[0]'s
/// density and gravity's magnitude, sigma_xx = k_x sigma_zz, sigma_yy = k_y sigma_zz. The ratios
/// default to the laterally confined elastic rock's nu / (1 - nu). False where it could not be read.
bool read_geostatic(YamlReader& r, const YAML::Node& n, const Scene& s, InitialStress& out) {
  const std::string p = "initial_stress.geostatic";
  if (!r.check_map(n, p, {"surface_z", "k_x", "k_y"})) return false;
  if (!n["surface_z"]) r.error(p + ".surface_z", "missing", "give the height of the ground surface, m");
  r.number(n, p, "surface_z", closed(-1e7, 1e7), out.reference_z);
  const real nu = s.material().poisson_ratio;
  real kx = nu / (1 - nu), ky = kx;
  r.number(n, p, "k_x", closed(0, 100), kx);
  r.number(n, p, "k_y", closed(0, 100), ky);
  if (s.gravity.x != 0 || s.gravity.y != 0 || !(s.gravity.z < 0)) {
    r.error(p,
            "needs gravity along -z (gravity is [" + fmt(s.gravity.x) + ", " + fmt(s.gravity.y) + ", " +
                fmt(s.gravity.z) + "])",
            "give gravity: [0, 0, -9.81], or give initial_stress as stress and gradient");
    return false;
  }
  const real weight = s.material().density * -s.gravity.z;  // Pa per m of depth
  out.gradient = {-kx * weight, -ky * weight, -weight, 0, 0, 0};
  out.geostatic = true;
  return true;
}

/// The stress must change with depth as the rock's weight: d sigma_iz / d depth = rho g_i, with
/// rho the mass-scaled density gravity acts on. Else the rock would not start at rest.
void check_balance(YamlReader& r, const Scene& s) {
  const InitialStress& in = s.initial_stress;
  const Vec3 grad{in.gradient.xz, in.gradient.yz, in.gradient.zz};
  for (std::size_t i = 0; i < s.materials.size(); ++i) {
    const Material& m = s.materials[i];
    const real rho = s.solver.mass_scaling * m.density;
    const Vec3 weight = rho * s.gravity;  // Pa per m of depth
    const Vec3 miss = grad - weight;
    const real scale = std::max(norm(grad), norm(weight));
    if (!(norm(miss) > 1e-9 * scale)) continue;
    const std::string who = s.materials.size() > 1 ? "material '" + m.name + "'" : "the material";
    const std::string why =
        "its change with depth (xz, yz, zz: " + fmt(grad.x, 4) + ", " + fmt(grad.y, 4) + ", " + fmt(grad.z, 4) +
        " Pa/m) does not balance the weight of " + who + " (rho g: " + fmt(weight.x, 4) + ", " + fmt(weight.y, 4) +
        ", " + fmt(weight.z, 4) + " Pa/m" +
        (s.solver.mass_scaling != 1 ? ", with mass scaling " + fmt(s.solver.mass_scaling) + ", which gravity weighs"
                                    : std::string()) +
        "), so the rock would not start at rest";
    const std::string fix = in.geostatic ? "give every material the density of materials[0], or leave out "
                                           "solver.mass_scaling while gravity loads the rock"
                                         : "give gradient {xz: " + fmt(weight.x, 6) + ", yz: " + fmt(weight.y, 6) +
                                               ", zz: " + fmt(weight.z, 6) + "}, or change gravity to match";
    r.error(in.geostatic ? "initial_stress.geostatic" : "initial_stress.gradient", why, fix);
    return;
  }
}

}  // namespace

void read_initial_stress(YamlReader& r, const YAML::Node& n, Scene& s) {
  const std::string p = "initial_stress";
  if (!r.check_map(n, p, {"stress", "gradient", "reference_z", "geostatic"})) return;
  InitialStress& out = s.initial_stress;
  out.given = true;
  if (n["geostatic"]) {
    if (n["stress"] || n["gradient"] || n["reference_z"]) {
      r.error(p + ".geostatic", "given with stress, gradient or reference_z",
              "give the geostatic form or the tensor form, not both; " + std::string(kForm));
      return;
    }
    if (!read_geostatic(r, n["geostatic"], s, out)) return;  // (no second message on the balance)
  } else {
    if (!n["stress"] && !n["gradient"]) r.error(p, "gives neither stress nor gradient", kForm);
    if (n["stress"]) read_tensor(r, n["stress"], p + ".stress", closed(-1e10, 1e10), out.stress);
    if (n["gradient"]) read_tensor(r, n["gradient"], p + ".gradient", closed(-1e9, 1e9), out.gradient);
    r.number(n, p, "reference_z", closed(-1e7, 1e7), out.reference_z);
  }
  check_balance(r, s);
}

}  // namespace fdem::scene_reading
