#include "model/initial_stress.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.hpp"
#include "core/format.hpp"

namespace fdem {

namespace {

/// One CE6 point's opening offsets under traction t0 (Pa, on A's face by B) across unit normal n:
/// the gap at which the law gives t0 (physics/cohesive6.hpp). `why` says why it cannot.
struct PointOffset {
  real normal = 0;  // m, along n
  Vec3 shear{0, 0, 0};
  std::string why;
};

/// An intact CE6: compression on the overlap penalty, tension and shear on their pre-peak curves
/// f (2x - x^2), inverted: x = 1 - sqrt(1 - t/f). Shear strength c + sigma_n tan(phi) as the law's.
PointOffset intact_offset(const Ce6Params& p, real strength, real h, real tn, Vec3 ts) {
  PointOffset out;
  const real ft = strength * p.ft;
  if (tn < 0) {
    out.normal = tn * h / p.P_overlap;
  } else if (tn < ft) {
    out.normal = (2 * h * ft / p.P_open) * (1 - std::sqrt(1 - tn / ft));
  } else {
    out.why = "normal traction " + fmt(tn, 4) + " Pa against its tensile strength " + fmt(ft, 4) + " Pa";
    return out;
  }
  const real fs = strength * p.cohesion + std::max(real(0), -tn) * p.tan_phi;
  const real tsn = norm(ts);
  if (tsn >= fs) {
    out.why = "shear traction " + fmt(tsn, 4) + " Pa against its shear strength " + fmt(fs, 4) + " Pa";
    return out;
  }
  if (tsn > 0) out.shear = ((2 * h * fs / p.P_tan) * (1 - std::sqrt(1 - tsn / fs)) / tsn) * ts;
  return out;
}

/// A frictional joint's CE6 (broken from the start): compression on the overlap penalty, shear on
/// the friction spring P_tan / h up to mu |sigma_n|. With tet-tet contact the CE6 carries no
/// force and contact takes the traction, so only the checks apply.
PointOffset joint_offset(const Ce6Params& p, real h, real tn, Vec3 ts) {
  PointOffset out;
  if (tn > 0) {
    out.why = "tension " + fmt(tn, 4) + " Pa across a frictional joint, which holds none";
    return out;
  }
  const real tsn = norm(ts);
  if (tsn > 0 && tsn >= p.mu_rock * -tn) {
    out.why = "shear traction " + fmt(tsn, 4) + " Pa above the joint's friction " + fmt(p.mu_rock * -tn, 4) + " Pa";
    return out;
  }
  out.normal = tn * h / p.P_overlap;
  out.shear = (h / p.P_tan) * ts;
  return out;
}

/// A geostatic stress above the ground surface would be tension.
void check_surface(const Scene& scene, const Model& m) {
  const InitialStress& in = scene.initial_stress;
  if (!in.geostatic || m.X.empty()) return;
  real top = m.X[0].z;
  for (const Vec3& X : m.X) top = std::max(top, X.z);
  const real scale = std::max(std::fabs(top), std::fabs(in.reference_z)) + m.mean_edge;
  if (top > in.reference_z + 1e-9 * scale)
    throw InputError(scene.file + ": initial_stress.geostatic.surface_z " + fmt(in.reference_z) +
                     " m lies below the top of the rock, " + fmt(top) +
                     " m: the rock above it would start in tension. Fix: give the height of the ground "
                     "surface, at or above " +
                     fmt(top) + " m");
}

}  // namespace

std::string describe_initial_stress(const Scene& scene) {
  const InitialStress& in = scene.initial_stress;
  if (!in.given) return "";
  auto tensor = [](const Sym3& s) {
    return "(" + fmt(s.xx, 4) + ", " + fmt(s.yy, 4) + ", " + fmt(s.zz, 4) + ", " + fmt(s.yz, 4) + ", " + fmt(s.xz, 4) +
           ", " + fmt(s.xy, 4) + ")";
  };
  return "  initial stress (xx, yy, zz, yz, xz, xy; Pa, tension positive): " + tensor(in.stress) +
         " at z = " + fmt(in.reference_z) + " m" + (in.geostatic ? " (the ground surface)" : "") + ", plus " +
         tensor(in.gradient) + " per m of depth below it\n";
}

void place_initial_stress(const Scene& scene, const ElementLaws& laws, Model& m) {
  m.tet_initial_stress.clear();
  m.ce6_prestress.clear();
  const InitialStress& in = scene.initial_stress;
  if (!in.given) return;
  check_surface(scene, m);
  m.tet_initial_stress.resize(m.tet_nodes.size());
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    Vec3 c{0, 0, 0};
    for (int n : m.tet_nodes[t]) c += real(0.25) * m.X[n];
    m.tet_initial_stress[t] = in.at(c);
  }
  m.ce6_prestress.assign(m.ce6_nodes.size(), Ce6Prestress{});
  std::size_t refused = 0;
  std::string first;
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    const Ce6Params& p = laws.ce6[m.ce6_law[c]];
    const int j = laws.joint_of_law(m.ce6_law[c]);
    const bool never_bonded = j >= 0 && laws.joint_frictional[j];
    const auto& q = m.ce6_nodes[c];
    const Vec3 X[3] = {m.X[q[0]], m.X[q[1]], m.X[q[2]]};
    const Vec3 nn = cross(X[1] - X[0], X[2] - X[0]);
    const Vec3 n = (1 / norm(nn)) * nn, e1 = (1 / norm(X[1] - X[0])) * (X[1] - X[0]), e2 = cross(n, e1);
    const real strength = m.ce6_strength.empty() ? real(1) : m.ce6_strength[c];
    for (int k = 0; k < 3; ++k) {
      const Sym3 s = in.at(real(0.5) * (X[k] + X[(k + 1) % 3]));  // the law's point k
      const Vec3 t0 = s * n;
      const real tn = dot(n, t0);
      const Vec3 ts = t0 - tn * n;
      const PointOffset o =
          never_bonded ? joint_offset(p, m.ce6_h[c], tn, ts) : intact_offset(p, strength, m.ce6_h[c], tn, ts);
      if (!o.why.empty()) {
        if (refused++ == 0) {
          const Vec3 at = (real(1) / 3) * (X[0] + X[1] + X[2]);
          first = "the CE6 between input tets " + std::to_string(m.tet_input[m.ce6_tets[c][0]] + 1) + " and " +
                  std::to_string(m.tet_input[m.ce6_tets[c][1]] + 1) + " at (" + fmt(at.x, 4) + ", " + fmt(at.y, 4) +
                  ", " + fmt(at.z, 4) + ") m: " + o.why;
        }
        break;
      }
      if (!(never_bonded && p.broken_inert))  // (with contact: no force, contact carries its faces)
        m.ce6_prestress[c].at[k] = {o.normal, dot(o.shear, e1), dot(o.shear, e2)};
    }
  }
  if (refused > 0)
    throw InputError(scene.file + ": initial_stress: the in-situ traction reaches the strength of " +
                     std::to_string(refused) + " CE6" + (refused > 1 ? "s" : "") + " (the first: " + first +
                     "), so the rock could not start at rest. Fix: lower the initial stress, raise the strengths "
                     "(tensile_strength, cohesion, friction_angle, a joint's friction), or leave these faces out "
                     "of fracture_regions");
}

}  // namespace fdem
