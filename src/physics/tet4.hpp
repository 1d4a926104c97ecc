#pragma once
// TET4, finite strain, compressible neo-Hookean with viscous damping.
//   X0 = [X1-X0, X2-X0, X3-X0] (reference edges), Xc the same in current positions.
//   F = Xc X0^-1, J = det F, B = F F^T, L = Xdot Xc^-1, D = sym(L)
//   sigma = [mu (B - I) + lambda ln J I] / J + eta D            (Cauchy, Pa)
//   W     = mu/2 (tr B - 3) - mu ln J + lambda/2 (ln J)^2        (per reference volume)
// Nodal forces: f_i = -v sigma grad N_i with grad N_{1..3} the rows of Xc^-1 and
// grad N_0 = -(sum of them), i.e. f_i = sigma a_i / 3 with a_i the outward area
// vector of the face opposite node i. They sum to zero by construction.
// In-situ stress S0 (scene initial_stress): a constant second Piola-Kirchhoff stress added to the
// law, so sigma += F S0 F^T / J and W += S0 : E with E = (F^T F - I)/2. At F = I the tet holds
// S0 and no strain energy; a rigid rotation turns S0 with the tet and stores nothing.
#include <cmath>

#include "core/portable_math.hpp"
#include "core/vec.hpp"

namespace fdem {

struct Tet4Reference {
  Mat3 Xinv;  // inverse reference edge matrix
  real V0;    // reference volume, m^3 (negative if the node order is inverted)
};

FDEM_HD Mat3 tet4_edges(const Vec3 (&x)[4]) {
  return Mat3::from_columns(x[1] - x[0], x[2] - x[0], x[3] - x[0]);
}

/// Signed volume of a tet (positive for a right-handed node order).
FDEM_HD real tet4_volume(const Vec3 (&x)[4]) {
  return det(tet4_edges(x)) / 6;
}

FDEM_HD Tet4Reference tet4_reference(const Vec3 (&X)[4]) {
  const Mat3 E = tet4_edges(X);
  return {inverse(E), det(E) / 6};
}

/// Smallest altitude (vertex to opposite face), m: the length the stable step scales with.
FDEM_HD real tet4_min_altitude(const Vec3 (&x)[4]) {
  const real v = std::fabs(tet4_volume(x));
  real hmin = 0;
  for (int i = 0; i < 4; ++i) {
    const Vec3 a = x[(i + 1) % 4], b = x[(i + 2) % 4], c = x[(i + 3) % 4];
    const real area = real(0.5) * norm(cross(b - a, c - a));
    const real h = 3 * v / area;
    hmin = (i == 0 || h < hmin) ? h : hmin;
  }
  return hmin;
}

struct Tet4Eval {
  real J;              // volume ratio; J <= 0 means the tet inverted (forces are then zero)
  real strain_energy;  // J (joules), V0 W
  real viscous_power;  // W, v eta D:D (rate of viscous dissipation)
  Sym3 stress;         // Cauchy stress including the viscous part, Pa
};

/// `S0`: the tet's in-situ stress (Pa), or null for none. Always inlined: a pass that reads only J
/// and the viscous power then skips the stress and the strain energy.
FDEM_HD_INLINE Tet4Eval tet4_forces(const Vec3 (&x)[4], const Vec3 (&v)[4], const Mat3& Xinv, real V0, real lambda,
                                    real mu, real eta, Vec3 (&f)[4], const Sym3* S0 = nullptr) {
  Tet4Eval r{};
  const Mat3 Xc = tet4_edges(x);
  const Mat3 F = Xc * Xinv;
  const real J = det(F);
  r.J = J;
  if (!(J > 0)) {
    for (int i = 0; i < 4; ++i) f[i] = {0, 0, 0};
    return r;
  }
  const Mat3 Xcinv = inverse(Xc);
  const Mat3 Vd = Mat3::from_columns(v[1] - v[0], v[2] - v[0], v[3] - v[0]);
  const Mat3 L = Vd * Xcinv;
  const Sym3 D = to_sym(L);
  const Mat3 B = F * transpose(F);
  const real lnJ = portable_log(J);
  const real vol = J * V0;
  // Kirchhoff-like part times V0 (= Cauchy times current volume), then the viscous part.
  const real s = V0;
  Sym3 sv{s * (mu * (B.a[0][0] - 1) + lambda * lnJ) + vol * eta * D.xx,
          s * (mu * (B.a[1][1] - 1) + lambda * lnJ) + vol * eta * D.yy,
          s * (mu * (B.a[2][2] - 1) + lambda * lnJ) + vol * eta * D.zz,
          s * mu * B.a[1][2] + vol * eta * D.yz,
          s * mu * B.a[0][2] + vol * eta * D.xz,
          s * mu * B.a[0][1] + vol * eta * D.xy};
  real insitu_energy = 0;
  if (S0) {
    const Sym3& S = *S0;
    const Mat3 Sm{{{S.xx, S.xy, S.xz}, {S.xy, S.yy, S.yz}, {S.xz, S.yz, S.zz}}};
    const Mat3 P = F * Sm * transpose(F);
    sv.xx += V0 * P.a[0][0], sv.yy += V0 * P.a[1][1], sv.zz += V0 * P.a[2][2];
    sv.yz += V0 * P.a[1][2], sv.xz += V0 * P.a[0][2], sv.xy += V0 * P.a[0][1];
    const Mat3 C = transpose(F) * F;  // S0 : E, the off-diagonal terms counted twice
    insitu_energy = real(0.5) * V0 *
                    (S.xx * (C.a[0][0] - 1) + S.yy * (C.a[1][1] - 1) + S.zz * (C.a[2][2] - 1) +
                     2 * (S.yz * C.a[1][2] + S.xz * C.a[0][2] + S.xy * C.a[0][1]));
  }
  Vec3 sum{0, 0, 0};
  for (int j = 1; j < 4; ++j) {
    const Vec3 g{Xcinv.a[j - 1][0], Xcinv.a[j - 1][1], Xcinv.a[j - 1][2]};
    f[j] = -(sv * g);
    sum += f[j];
  }
  f[0] = -sum;
  const real ivol = 1 / vol;
  r.stress = {sv.xx * ivol, sv.yy * ivol, sv.zz * ivol, sv.yz * ivol, sv.xz * ivol, sv.xy * ivol};
  const real DD = D.xx * D.xx + D.yy * D.yy + D.zz * D.zz + 2 * (D.yz * D.yz + D.xz * D.xz + D.xy * D.xy);
  r.viscous_power = vol * eta * DD;
  r.strain_energy = V0 * (real(0.5) * mu * (trace(B) - 3) - mu * lnJ + real(0.5) * lambda * lnJ * lnJ) + insitu_energy;
  return r;
}

}  // namespace fdem
