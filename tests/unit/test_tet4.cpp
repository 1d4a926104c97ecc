// TET4: patch test, objectivity, force balance, energy consistency.
#include <gtest/gtest.h>

#include <cmath>

#include "physics/tet4.hpp"
#include "scene/scene.hpp"

using namespace fdem;

namespace {

const Material mat;
const real lam = mat.lame_lambda(), mu = mat.lame_mu();

// A deliberately irregular, positively oriented tet.
void reference(Vec3 (&X)[4]) {
  X[0] = {0.001, -0.0004, 0.0002};
  X[1] = {0.0031, 0.0003, -0.0001};
  X[2] = {0.0005, 0.0027, 0.0004};
  X[3] = {0.0008, 0.0006, 0.0029};
}

Mat3 rotation(real ax, real ay, real az) {
  const Mat3 rx{{{1, 0, 0}, {0, std::cos(ax), -std::sin(ax)}, {0, std::sin(ax), std::cos(ax)}}};
  const Mat3 ry{{{std::cos(ay), 0, std::sin(ay)}, {0, 1, 0}, {-std::sin(ay), 0, std::cos(ay)}}};
  const Mat3 rz{{{std::cos(az), -std::sin(az), 0}, {std::sin(az), std::cos(az), 0}, {0, 0, 1}}};
  return rz * ry * rx;
}

Tet4Eval eval(const Vec3 (&X)[4], const Vec3 (&x)[4], const Vec3 (&v)[4], real eta, Vec3 (&f)[4]) {
  const Tet4Reference ref = tet4_reference(X);
  return tet4_forces(x, v, ref.Xinv, ref.V0, lam, mu, eta, f);
}

}  // namespace

TEST(Tet4, UniformStrainPatchGivesExactNeoHookeanStress) {
  Vec3 X[4], x[4], v[4] = {}, f[4];
  reference(X);
  const Mat3 F{{{1.001, 0.0004, -0.0002}, {0.0003, 0.9985, 0.0007}, {-0.0001, 0.0002, 1.0012}}};
  for (int i = 0; i < 4; ++i) x[i] = F * X[i];
  const Tet4Eval r = eval(X, x, v, 0, f);
  const real J = det(F);
  const Mat3 B = F * transpose(F);
  const Sym3 expect = to_sym((1 / J) * (mu * (B + (-1.0) * Mat3::identity()) + (lam * std::log(J)) * Mat3::identity()));
  EXPECT_NEAR(r.J, J, 1e-14);
  const real scale = std::fabs(expect.xx);
  EXPECT_NEAR(r.stress.xx, expect.xx, 1e-9 * scale);
  EXPECT_NEAR(r.stress.yy, expect.yy, 1e-9 * scale);
  EXPECT_NEAR(r.stress.zz, expect.zz, 1e-9 * scale);
  EXPECT_NEAR(r.stress.yz, expect.yz, 1e-9 * scale);
  EXPECT_NEAR(r.stress.xz, expect.xz, 1e-9 * scale);
  EXPECT_NEAR(r.stress.xy, expect.xy, 1e-9 * scale);
  // Small strain: the stress is Hooke's law to first order.
  const real exx = 0.001 - 0, eyy = -0.0015, ezz = 0.0012;
  EXPECT_NEAR(r.stress.xx, lam * (exx + eyy + ezz) + 2 * mu * exx, 2e-3 * scale);
}

TEST(Tet4, NodalForcesAreSigmaTimesFaceAreaOverThreeAndSumToZero) {
  Vec3 X[4], x[4], v[4] = {}, f[4];
  reference(X);
  const Mat3 F{{{1.002, 0.001, 0}, {0, 0.997, 0.0005}, {0.0002, 0, 1.001}}};
  for (int i = 0; i < 4; ++i) x[i] = F * X[i];
  const Tet4Eval r = eval(X, x, v, 0, f);
  Vec3 sum{0, 0, 0}, moment{0, 0, 0};
  for (int i = 0; i < 4; ++i) {
    sum += f[i];
    moment += cross(x[i], f[i]);
    // Outward area vector of the face opposite node i.
    const Vec3 a = x[(i + 1) % 4], b = x[(i + 2) % 4], c = x[(i + 3) % 4];
    Vec3 n = 0.5 * cross(b - a, c - a);
    if (dot(n, x[i] - a) > 0) n = -n;
    const Vec3 expect = (1.0 / 3) * (r.stress * n);
    EXPECT_NEAR(norm(f[i] - expect), 0, 1e-9 * norm(expect));
  }
  EXPECT_LT(norm(sum), 1e-9 * norm(f[0]));
  EXPECT_LT(norm(moment), 1e-9 * norm(f[0]) * 0.003);  // symmetric stress carries no net moment
}

TEST(Tet4, RigidRotationOfUnstressedTetGivesZeroStress) {
  Vec3 X[4], x[4], v[4] = {}, f[4];
  reference(X);
  const Mat3 R = rotation(0.7, -1.1, 2.3);  // large rotation: objectivity, not small-strain luck
  const Vec3 shift{0.3, -0.2, 0.1};
  for (int i = 0; i < 4; ++i) x[i] = R * X[i] + shift;
  const Tet4Eval r = eval(X, x, v, 0, f);
  EXPECT_NEAR(r.J, 1, 1e-12);
  EXPECT_LT(von_mises(r.stress) + std::fabs(r.stress.xx + r.stress.yy + r.stress.zz), 1e-9 * mat.youngs_modulus);
  for (int i = 0; i < 4; ++i) EXPECT_LT(norm(f[i]), 1e-12 * mat.youngs_modulus * 1e-6);
  // Round-off only: a strain of 1e-6 would already store about mu V0 1e-12.
  EXPECT_NEAR(r.strain_energy, 0, 1e-14 * mu * tet4_reference(X).V0);
}

TEST(Tet4, StressRotatesWithTheBody) {
  Vec3 X[4], x[4], xr[4], v[4] = {}, f[4], fr[4];
  reference(X);
  const Mat3 F{{{1.003, 0.001, 0}, {0.0005, 0.998, 0}, {0, 0.0003, 1.0}}};
  const Mat3 R = rotation(0.4, 0.9, -0.3);
  for (int i = 0; i < 4; ++i) {
    x[i] = F * X[i];
    xr[i] = R * x[i];
  }
  eval(X, x, v, 0, f);
  eval(X, xr, v, 0, fr);
  for (int i = 0; i < 4; ++i) EXPECT_LT(norm(fr[i] - R * f[i]), 1e-9 * norm(f[i]));
}

TEST(Tet4, ForcesAreTheGradientOfTheStrainEnergy) {
  Vec3 X[4], x[4], v[4] = {}, f[4], fd[4];
  reference(X);
  const Mat3 F{{{1.01, 0.004, 0}, {0.002, 0.99, 0.001}, {0, 0.003, 1.02}}};
  for (int i = 0; i < 4; ++i) x[i] = F * X[i];
  eval(X, x, v, 0, f);
  const real h = 1e-9;
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      Vec3 xp[4], xm[4];
      for (int j = 0; j < 4; ++j) xp[j] = xm[j] = x[j];
      xp[i][d] += h;
      xm[i][d] -= h;
      const real dW = (eval(X, xp, v, 0, fd).strain_energy - eval(X, xm, v, 0, fd).strain_energy) / (2 * h);
      EXPECT_NEAR(f[i][d], -dW, 1e-5 * norm(f[i]) + 1e-3);
    }
}

TEST(Tet4, AnInSituStressIsHeldTurnsWithTheBodyAndIsTheGradientOfItsEnergy) {
  // S0 at F = I: the stress is S0, the forces S0 a_i / 3, no strain energy. Rotated rigidly: the
  // stress turns with the body and still stores nothing. Deformed: the forces are -dW/dx.
  Vec3 X[4], x[4], v[4] = {}, f[4], fr[4];
  reference(X);
  const Sym3 S0{-9e6, -3e6, -6e6, 1e6, -2e6, 0.5e6};
  const Tet4Reference ref = tet4_reference(X);
  auto eval0 = [&](const Vec3(&at)[4], Vec3(&out)[4]) {
    return tet4_forces(at, v, ref.Xinv, ref.V0, lam, mu, 0, out, &S0);
  };
  const Tet4Eval r = eval0(X, f);
  const real s[6] = {r.stress.xx - S0.xx, r.stress.yy - S0.yy, r.stress.zz - S0.zz,
                     r.stress.yz - S0.yz, r.stress.xz - S0.xz, r.stress.xy - S0.xy};
  for (real d : s) EXPECT_LT(std::fabs(d), 1e-9 * 9e6);
  EXPECT_NEAR(r.strain_energy, 0, 1e-12 * 9e6 * ref.V0);
  for (int i = 0; i < 4; ++i) {
    const Vec3 a = X[(i + 1) % 4], b = X[(i + 2) % 4], c = X[(i + 3) % 4];
    Vec3 n = 0.5 * cross(b - a, c - a);
    if (dot(n, X[i] - a) > 0) n = -n;
    EXPECT_LT(norm(f[i] - (1.0 / 3) * (S0 * n)), 1e-9 * norm(f[i]));
  }
  const Mat3 R = rotation(0.7, -1.1, 2.3);
  for (int i = 0; i < 4; ++i) x[i] = R * X[i];
  const Tet4Eval rr = eval0(x, fr);
  for (int i = 0; i < 4; ++i) EXPECT_LT(norm(fr[i] - R * f[i]), 1e-9 * norm(f[i]));
  EXPECT_NEAR(rr.strain_energy, 0, 1e-12 * 9e6 * ref.V0);
  const Mat3 F{{{1.01, 0.004, 0}, {0.002, 0.99, 0.001}, {0, 0.003, 1.02}}};
  for (int i = 0; i < 4; ++i) x[i] = F * X[i];
  eval0(x, f);
  const real h = 1e-9;
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      Vec3 xp[4], xm[4], fd[4];
      for (int j = 0; j < 4; ++j) xp[j] = xm[j] = x[j];
      xp[i][d] += h;
      xm[i][d] -= h;
      const real dW = (eval0(xp, fd).strain_energy - eval0(xm, fd).strain_energy) / (2 * h);
      EXPECT_NEAR(f[i][d], -dW, 1e-5 * norm(f[i]) + 1e-3);
    }
}

TEST(Tet4, ViscousStressIsEtaTimesStrainRate) {
  Vec3 X[4], v[4], f[4];
  reference(X);
  const Mat3 L{{{10, 2, 0}, {2, -5, 1}, {0, 1, 3}}};  // symmetric velocity gradient, 1/s
  for (int i = 0; i < 4; ++i) v[i] = L * X[i];
  const real eta = 1234.5;
  const Tet4Eval r = eval(X, X, v, eta, f);
  EXPECT_NEAR(r.stress.xx, eta * 10, 1e-9 * eta * 10);
  EXPECT_NEAR(r.stress.yy, eta * -5, 1e-9 * eta * 10);
  EXPECT_NEAR(r.stress.xy, eta * 2, 1e-9 * eta * 10);
  EXPECT_NEAR(r.stress.yz, eta * 1, 1e-9 * eta * 10);
  const real DD = 100 + 25 + 9 + 2 * (4 + 1);
  EXPECT_NEAR(r.viscous_power, eta * DD * tet4_reference(X).V0, 1e-9 * eta * DD * tet4_reference(X).V0);
}

TEST(Tet4, InvertedTetReportsNonPositiveJacobian) {
  Vec3 X[4], x[4], v[4] = {}, f[4];
  reference(X);
  for (int i = 0; i < 4; ++i) x[i] = X[i];
  std::swap(x[1], x[2]);
  const Tet4Eval r = eval(X, x, v, 0, f);
  EXPECT_LT(r.J, 0);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(norm(f[i]), 0);
}

TEST(Tet4, MinAltitudeOfRegularCornerTet) {
  Vec3 x[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  // Altitudes: 1 to each coordinate face, 1/sqrt(3) from the origin to the slanted face.
  EXPECT_NEAR(tet4_min_altitude(x), 1 / std::sqrt(3.0), 1e-14);
  EXPECT_NEAR(tet4_volume(x), 1.0 / 6, 1e-15);
}
