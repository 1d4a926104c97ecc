// CE6 intrinsic cohesive element: fracture energies, Mohr-Coulomb strength, force balance,
// objectivity, monotone damage and friction once broken. A single CE6 is driven
// quasi-statically by prescribing B's node positions; work is integrated by the trapezoid rule.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "model/laws.hpp"
#include "physics/cohesive6.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

constexpr real kH = 1.5e-3;  // element size, m

/// A tilted mm-sized triangle with its local frame (t1, t2, n), n by right-hand rule 0->1->2.
struct Triangle {
  Vec3 X[3];
  Vec3 t1, t2, n;
  real area;
  Triangle() {
    const Mat3 R = rotation({0.3, -0.5, 0.8}, 0.7);
    const Vec3 c{0.4e-3, -0.2e-3, 0.3e-3};
    const Vec3 loc[3] = {{0, 0, 0}, {2.0e-3, 0, 0}, {0.6e-3, 1.8e-3, 0}};
    for (int i = 0; i < 3; ++i) X[i] = c + R * loc[i];
    t1 = R.column(0);
    t2 = R.column(1);
    n = R.column(2);
    area = 0.5 * 2.0e-3 * 1.8e-3;
  }
};

/// Drives one CE6: A fixed, B displaced uniformly by u (all three B nodes).
struct Driver {
  Ce6Params p;
  Ce6State s{};
  Triangle tri;
  Vec3 u{0, 0, 0};
  Vec3 f[6]{};
  Ce6Eval ev{0, 0};
  real work = 0;  // work done on the element by the agent moving B
  real dt = 1e-4;
  real strength = 1;  // the element's strength factor (heterogeneous rock)

  explicit Driver(const Material& m) : p(make_ce6_params(m)) { eval(u, {0, 0, 0}); }

  Vec3 FB() const { return f[3] + f[4] + f[5]; }
  /// Normal traction (tension positive) and tangential traction vector from the forces.
  real sigma() const { return -dot(FB(), tri.n) / tri.area; }
  Vec3 tau() const {
    const Vec3 F = FB();
    return (-1 / tri.area) * (F - dot(F, tri.n) * tri.n);
  }
  real dissipated() const { return work - ev.stored; }

  void eval(Vec3 unew, Vec3 vel) {
    Vec3 x[6], v[6];
    for (int i = 0; i < 3; ++i) {
      x[i] = tri.X[i];
      x[i + 3] = tri.X[i] + unew;
      v[i] = {0, 0, 0};
      v[i + 3] = vel;
    }
    ev = cohesive6_forces(p, x, v, kH, s, f, strength);
  }
  /// Straight path to `target` in n increments; `each` is called after every increment.
  template <class F>
  void move_to(Vec3 target, int n, F each) {
    const Vec3 u0 = u;
    for (int i = 1; i <= n; ++i) {
      const Vec3 un = u0 + (real(i) / n) * (target - u0);
      const Vec3 du = un - u;
      const Vec3 Fold = FB();
      eval(un, (1 / dt) * du);
      work -= 0.5 * dot(Fold + FB(), du);
      u = un;
      each();
    }
  }
  void move_to(Vec3 target, int n) {
    move_to(target, n, [] {});
  }
};

real o_peak(const Ce6Params& p) {
  return 2 * kH * p.ft / p.P_open;
}
real o_final(const Ce6Params& p) {
  return o_peak(p) + (p.GI - 2.0 / 3 * p.ft * o_peak(p)) / (p.ft * p.Z);
}
real s_peak(const Ce6Params& p, real fs) {
  return 2 * kH * fs / p.P_tan;
}
real s_final(const Ce6Params& p, real fs) {
  return s_peak(p, fs) + (p.GII - 2.0 / 3 * fs * s_peak(p, fs)) / (fs * p.Z);
}

/// Closes the CE6 to a normal stress -sn in 100 increments; its Mohr-Coulomb shear strength there.
real compress(Driver& dr, const Material& m, real sn) {
  dr.move_to((-sn * kH / m.cohesive_penalty_overlap) * dr.tri.n, 100);
  return m.cohesion + sn * std::tan(m.friction_angle * M_PI / 180);
}

real max_abs_force(const Vec3 (&f)[6]) {
  real m = 0;
  for (const Vec3& v : f) m = std::max(m, norm(v));
  return m;
}

}  // namespace

TEST(Cohesive6, SofteningCurves) {
  for (int sc : {0, 1}) {
    EXPECT_DOUBLE_EQ(softening_z(0, sc), 1.0);
    EXPECT_DOUBLE_EQ(softening_z(1, sc), 0.0);
    real prev = 1;
    for (int i = 1; i <= 100; ++i) {  // strictly decreasing
      const real z = softening_z(i / 100.0, sc);
      EXPECT_LT(z, prev);
      prev = z;
    }
  }
  // Z of the Munjiza curve against a much finer midpoint rule.
  const int n = 200000;
  real Zf = 0;
  for (int i = 0; i < n; ++i) Zf += softening_z((i + 0.5) / n, 0) / n;
  EXPECT_NEAR(softening_integral(0), Zf, 1e-9);
  EXPECT_DOUBLE_EQ(softening_integral(1), 0.5);
  Material m;
  EXPECT_EQ(make_ce6_params(m).softening, 0);
  EXPECT_NEAR(make_ce6_params(m).tan_phi, std::tan(25 * M_PI / 180), 1e-15);
  m.softening = Softening::linear;
  EXPECT_EQ(make_ce6_params(m).softening, 1);
  EXPECT_DOUBLE_EQ(make_ce6_params(m).Z, 0.5);
}

// 1. Mode I to full separation dissipates G_I A.
TEST(Cohesive6, ModeIDissipatesGI) {
  for (const char* soft : {"munjiza", "linear"}) {
    SCOPED_TRACE(soft);
    Material m;
    m.softening = test::named<Softening>(soft);
    Driver dr(m);
    const real op = o_peak(dr.p), orr = o_final(dr.p);
    ASSERT_GT(orr, 100 * op);
    dr.move_to(2 * op * dr.tri.n, 2000);
    EXPECT_FALSE(ce6_broken(dr.s));
    EXPECT_GT(ce6_max_damage(dr.s), 0.0);
    dr.move_to(0.999 * orr * dr.tri.n, 20000);
    EXPECT_FALSE(ce6_broken(dr.s));
    dr.move_to(1.2 * orr * dr.tri.n, 200);
    EXPECT_TRUE(ce6_broken(dr.s));
    EXPECT_EQ(dr.s.mode, 1);
    EXPECT_DOUBLE_EQ(ce6_max_damage(dr.s), 1.0);
    EXPECT_EQ(max_abs_force(dr.f), 0.0);
    EXPECT_EQ(dr.ev.stored, 0.0);
    const real G = m.fracture_energy_I * dr.tri.area;
    EXPECT_NEAR(dr.dissipated(), G, 0.01 * G);
    // Further opening costs nothing.
    const real w = dr.work;
    dr.move_to(3 * orr * dr.tri.n, 10);
    EXPECT_EQ(dr.work, w);
  }
}

// 1b. A strength factor (a heterogeneous rock's draw) scales the peak and keeps G_I A.
TEST(Cohesive6, AStrengthFactorScalesThePeakAndKeepsTheFractureEnergy) {
  for (const real factor : {0.5, 1.7}) {
    SCOPED_TRACE(factor);
    Material m;
    Driver dr(m);
    dr.strength = factor;
    Ce6Params scaled = dr.p;
    scaled.ft *= factor;
    const real op = o_peak(scaled), orr = o_final(scaled);
    real peak = 0;
    dr.move_to(1.2 * orr * dr.tri.n, 40000, [&] { peak = std::max(peak, dr.sigma()); });
    EXPECT_TRUE(ce6_broken(dr.s));
    EXPECT_NEAR(peak, factor * m.tensile_strength, 1e-3 * factor * m.tensile_strength);
    const real G = m.fracture_energy_I * dr.tri.area;
    EXPECT_NEAR(dr.dissipated(), G, 0.01 * G);
    EXPECT_GT(orr, 10 * op);
  }
}

// 2. Mode II sliding under zero normal stress dissipates G_II A.
TEST(Cohesive6, ModeIIDissipatesGII) {
  for (const char* soft : {"munjiza", "linear"}) {
    SCOPED_TRACE(soft);
    Material m;
    m.softening = test::named<Softening>(soft);
    Driver dr(m);
    const real sp = s_peak(dr.p, m.cohesion), sr = s_final(dr.p, m.cohesion);
    dr.move_to(2 * sp * dr.tri.t1, 2000);
    dr.move_to(0.999 * sr * dr.tri.t1, 20000);
    EXPECT_FALSE(ce6_broken(dr.s));
    dr.move_to(1.2 * sr * dr.tri.t1, 200);
    EXPECT_TRUE(ce6_broken(dr.s));
    EXPECT_EQ(dr.s.mode, 2);
    EXPECT_LT(max_abs_force(dr.f), 1e-9 * m.cohesion * dr.tri.area);
    const real G = m.fracture_energy_II * dr.tri.area;
    EXPECT_NEAR(dr.dissipated(), G, 0.01 * G);
  }
}

// Opening and sliding together break in mixed mode.
TEST(Cohesive6, MixedModeBreak) {
  Material m;
  Driver dr(m);
  const real orr = o_final(dr.p), sr = s_final(dr.p, m.cohesion);
  dr.move_to(1.5 * (orr * dr.tri.n + sr * dr.tri.t2), 20000);
  EXPECT_EQ(dr.s.mode, 3);
  EXPECT_EQ(max_abs_force(dr.f), 0.0);
}

// 3. Peak shear traction = c + sigma_n tan(phi) under held compression.
TEST(Cohesive6, ShearStrengthRisesWithCompression) {
  Material m;
  const real tanphi = std::tan(m.friction_angle * M_PI / 180);
  for (real sn : {2e6, 5e6, 10e6}) {
    SCOPED_TRACE(sn);
    Driver dr(m);
    const real o = -sn * kH / m.cohesive_penalty_overlap;
    dr.move_to(o * dr.tri.n, 10);
    EXPECT_NEAR(dr.sigma(), -sn, 1e-6 * sn);
    const real fs = m.cohesion + sn * tanphi;
    const real sp = s_peak(dr.p, fs);
    real tmax = 0;
    dr.move_to(o * dr.tri.n + 3 * sp * dr.tri.t2, 3000, [&] {
      tmax = std::max(tmax, norm(dr.tau()));
      EXPECT_NEAR(dr.sigma(), -sn, 1e-6 * sn);  // normal stress held, never softened
    });
    EXPECT_NEAR(tmax, fs, 0.01 * fs);
    EXPECT_NEAR(tmax, fs, 1e-5 * fs);  // the discrete maximum lands on the peak
    EXPECT_GT(ce6_max_damage(dr.s), 0.0);
  }
}

// 4. Force balance, no moment for uniform opening, initial normal stiffness, signs and power.
TEST(Cohesive6, ForcesBalanceAndStiffness) {
  Material m;
  const Ce6Params p = make_ce6_params(m);
  const Triangle tri;
  const real op = o_peak(p);
  // General configuration: forces sum to zero, power = -sum f.v.
  {
    Vec3 x[6], v[6], f[6];
    const Vec3 du[3] = {{1.1e-6, -0.4e-6, 0.7e-6}, {-0.3e-6, 0.9e-6, 0.2e-6}, {0.5e-6, 0.1e-6, -0.6e-6}};
    for (int i = 0; i < 3; ++i) {
      x[i] = tri.X[i];
      x[i + 3] = tri.X[i] + du[i];
      v[i] = {0.01 * i, -0.02, 0.03};
      v[i + 3] = {-0.01, 0.02 * i, 0.05};
    }
    Ce6State s{};
    const Ce6Eval ev = cohesive6_forces(p, x, v, kH, s, f);
    Vec3 sum{0, 0, 0};
    real fv = 0;
    for (int i = 0; i < 6; ++i) {
      sum += f[i];
      fv += dot(f[i], v[i]);
    }
    const real fmax = max_abs_force(f);
    ASSERT_GT(fmax, 0.0);
    EXPECT_LT(norm(sum), 1e-14 * fmax);
    EXPECT_NEAR(ev.power, -fv, 1e-13 * std::abs(fv));
    EXPECT_GT(ce6_max_damage(s), 0.0);  // past peak somewhere: the damaged law balances too
  }
  // Uniform small opening: stiffness P_open/h per unit area, zero moment, B pulled back.
  {
    Driver dr(m);
    const real o = 1e-3 * op;
    dr.eval(o * tri.n, {0, 0, 0});
    const real xo = o / op;
    EXPECT_NEAR(dr.sigma() / o, m.cohesive_penalty_open / kH * (1 - xo / 2), 1e-6 * m.cohesive_penalty_open / kH);
    EXPECT_NEAR(dr.sigma() / o, m.cohesive_penalty_open / kH, 1e-3 * m.cohesive_penalty_open / kH);
    Vec3 x[6];
    for (int i = 0; i < 3; ++i) {
      x[i] = tri.X[i];
      x[i + 3] = tri.X[i] + o * tri.n;
    }
    Vec3 sum{0, 0, 0}, mom{0, 0, 0};
    for (int i = 0; i < 6; ++i) {
      sum += dr.f[i];
      mom += cross(x[i], dr.f[i]);
    }
    const real fmax = max_abs_force(dr.f);
    EXPECT_LT(norm(sum), 1e-14 * fmax);
    EXPECT_LT(norm(mom), 1e-12 * fmax * norm(tri.X[1]));
    // Each pair carries a third of the load, along the normal. The opening (3e-12 m) is
    // resolved from mm coordinates only to ~1e-7 relative, hence the tolerance.
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(dot(dr.f[i + 3], tri.n), -dr.sigma() * tri.area / 3, 1e-6 * fmax);
      EXPECT_NEAR(norm(dr.f[i + 3] + dr.f[i]), 0.0, 1e-14 * fmax);
    }
    EXPECT_LT(dot(dr.FB(), tri.n), 0.0);  // opening pulls B back toward A
  }
  // Overlap pushes B out; sliding is resisted.
  {
    Driver dr(m);
    dr.eval(-1e-3 * op * tri.n, {0, 0, 0});
    EXPECT_GT(dot(dr.FB(), tri.n), 0.0);
    EXPECT_NEAR(dr.sigma(), m.cohesive_penalty_overlap * (-1e-3 * op) / kH, 1e-9 * m.tensile_strength);
    dr.eval(0.1 * op * tri.t1, {0, 0, 0});
    EXPECT_LT(dot(dr.FB(), tri.t1), 0.0);
  }
}

// 5. Rotating positions and velocities rotates the forces; energies unchanged.
TEST(Cohesive6, RotationInvariance) {
  Material m;
  const Ce6Params p = make_ce6_params(m);
  const Triangle tri;
  const Mat3 R = rotation({-0.6, 0.2, 0.9}, 2.1);
  // Opening (intact case) or overlap (broken case) plus sliding, all of order 1e-6 m so that
  // the relative displacements are resolved from mm coordinates to ~1e-13. (The broken case's
  // 1e-6 m overlap is far beyond a physical one; objectivity does not care.)
  Vec3 du[3];
  for (int i = 0; i < 3; ++i)
    du[i] = (1.5e-6 + 0.3e-6 * i) * tri.n + (0.8e-6 - 0.5e-6 * i) * tri.t1 + 0.4e-6 * i * tri.t2;
  for (int broken = 0; broken < 2; ++broken) {
    SCOPED_TRACE(broken);
    Vec3 x[6], v[6], xr[6], vr[6], f[6], fr[6];
    for (int i = 0; i < 3; ++i) {
      x[i] = tri.X[i];
      // broken case: overlap of the B face plus sliding
      x[i + 3] = broken ? tri.X[i] - 2 * dot(du[i], tri.n) * tri.n + du[i] : tri.X[i] + du[i];
      v[i] = {0.01 * i, -0.02, 0.03};
      v[i + 3] = {-0.01, 0.02 * i, 0.05};
    }
    for (int i = 0; i < 6; ++i) {
      xr[i] = R * x[i];
      vr[i] = R * v[i];
    }
    Ce6State s{}, sr{};
    if (broken) {
      s.mode = sr.mode = 1;
      for (int k = 0; k < 3; ++k) {
        s.D[k] = sr.D[k] = 1;
        s.slip[k] = {0.3e-6 * k, -0.2e-6, 0.1e-6};
        sr.slip[k] = R * s.slip[k];
      }
    } else {
      s.D[0] = sr.D[0] = 0.2;  // some prior damage
    }
    const Ce6Eval e = cohesive6_forces(p, x, v, kH, s, f);
    const Ce6Eval er = cohesive6_forces(p, xr, vr, kH, sr, fr);
    const real fmax = max_abs_force(f);
    ASSERT_GT(fmax, 0.0);
    for (int i = 0; i < 6; ++i) EXPECT_LT(norm(fr[i] - R * f[i]), 1e-12 * fmax) << i;
    EXPECT_NEAR(er.stored, e.stored, 1e-12 * e.stored);
    EXPECT_NEAR(er.power, e.power, 1e-12 * std::abs(e.power));
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(sr.D[k], s.D[k], 1e-12);
      EXPECT_LT(norm(sr.slip[k] - R * s.slip[k]), 1e-12 * norm(du[0]));
    }
    EXPECT_EQ(sr.mode, s.mode);
    if (!broken) {
      for (int k = 0; k < 3; ++k) EXPECT_GT(s.D[k], 0.0);
    }
    EXPECT_GT(e.stored, 0.0);
  }
}

TEST(Cohesive6, InSituOffsetsGiveATractionAtZeroGapThatTurnsWithTheFace) {
  // Offsets of compression and shear: at zero gap the faces carry a traction, balanced between
  // the two sides, with no damage; rotating the pair rotates the forces.
  Material m;
  const Ce6Params p = make_ce6_params(m);
  const Triangle tri;
  const Mat3 R = rotation({-0.6, 0.2, 0.9}, 2.1);
  Ce6Prestress pre;
  for (int k = 0; k < 3; ++k) pre.at[k] = {-2e-9 * (1 + k), 3e-9, -1e-9 * k};
  Vec3 x[6], v[6] = {}, xr[6], f[6], fr[6];
  for (int i = 0; i < 3; ++i) x[i] = x[i + 3] = tri.X[i];
  for (int i = 0; i < 6; ++i) xr[i] = R * x[i];
  Ce6State s{}, sr{};
  const Ce6Eval e = cohesive6_forces(p, x, v, kH, s, f, 1, &pre);
  cohesive6_forces(p, xr, v, kH, sr, fr, 1, &pre);
  Vec3 onA{0, 0, 0}, onB{0, 0, 0};
  for (int i = 0; i < 3; ++i) onA += f[i], onB += f[i + 3];
  EXPECT_LT(norm(onA + onB), 1e-12 * norm(onA));
  // Compression: B pushes A back against n; the mean normal traction is the overlap penalty's.
  const real mean_o = -2e-9 * 2;
  EXPECT_NEAR(dot(onA, tri.n) / tri.area, p.P_overlap / kH * mean_o, 1e-9 * p.P_overlap / kH * 4e-9);
  // The shear: per point the pre-peak curve at the offset's length, along e1 = unit(X1 - X0) and
  // e2 = n x e1, with the shear strength its compression gives.
  const Vec3 e1 = (1 / norm(tri.X[1] - tri.X[0])) * (tri.X[1] - tri.X[0]), e2 = cross(tri.n, e1);
  Vec3 shear{0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    const real sigma = p.P_overlap / kH * pre.at[k].x;
    const real fs = p.cohesion + -sigma * p.tan_phi, sp = 2 * kH * fs / p.P_tan;
    const Vec3 sv = pre.at[k].y * e1 + pre.at[k].z * e2;
    const real y = norm(sv) / sp;
    ASSERT_LT(y, 1.0);
    shear += (tri.area / 3 * fs * (2 * y - y * y) / norm(sv)) * sv;
  }
  EXPECT_LT(norm(onA - dot(onA, tri.n) * tri.n - shear), 1e-9 * norm(shear));
  EXPECT_EQ(ce6_max_damage(s), 0.0);
  EXPECT_GT(e.stored, 0.0);
  for (int i = 0; i < 6; ++i) EXPECT_LT(norm(fr[i] - R * f[i]), 1e-12 * max_abs_force(f)) << i;
}

// 6. Damage never decreases; unloading follows z(D) sigma_pre; work - stored >= 0.
TEST(Cohesive6, DamageMonotoneAndUnloading) {
  Material m;
  Driver dr(m);
  const real op = o_peak(dr.p), orr = o_final(dr.p);
  const real G = m.fracture_energy_I * dr.tri.area;
  const real tol = 1e-7 * G;
  real Dprev = 0;
  bool ok_mono = true, ok_diss = true;
  auto check = [&] {
    const real D = ce6_max_damage(dr.s);
    ok_mono = ok_mono && D >= Dprev;
    ok_diss = ok_diss && dr.dissipated() >= -tol;
    Dprev = D;
  };
  // Pre-peak: elastic, work = stored = ft o_p (x^2 - x^3/3) A.
  dr.move_to(0.99 * op * dr.tri.n, 2000, check);
  EXPECT_EQ(ce6_max_damage(dr.s), 0.0);
  EXPECT_NEAR(dr.work, dr.ev.stored, 1e-5 * dr.ev.stored);
  const real xs = 0.99;
  EXPECT_NEAR(dr.ev.stored, m.tensile_strength * op * (xs * xs - xs * xs * xs / 3) * dr.tri.area, 1e-8 * dr.ev.stored);
  // Past peak to D ~ 0.3.
  const real o1 = op + 0.3 * (orr - op);
  dr.move_to(o1 * dr.tri.n, 10000, check);
  const real D1 = ce6_max_damage(dr.s);
  EXPECT_NEAR(D1, 0.3, 1e-9);
  const real diss1 = dr.dissipated();
  EXPECT_GT(diss1, 0.2 * G);
  // Close to half the peak opening: D unchanged, traction z(D) sigma_pre.
  dr.move_to(0.5 * op * dr.tri.n, 10000, check);
  EXPECT_EQ(ce6_max_damage(dr.s), D1);
  const real z = softening_z(D1, dr.p.softening);
  EXPECT_NEAR(dr.sigma(), z * m.tensile_strength * 0.75, 1e-9 * m.tensile_strength);
  EXPECT_LT(z, 0.9);
  // Into overlap and back out: elastic, no extra dissipation.
  dr.move_to(-0.5 * op * dr.tri.n, 2000, check);
  EXPECT_LT(dr.sigma(), 0.0);
  EXPECT_GT(dr.ev.stored, 1e-3 * diss1);  // overlap energy, stored not dissipated
  EXPECT_NEAR(dr.dissipated(), diss1, 1e-4 * diss1);
  dr.move_to(o1 * dr.tri.n, 10000, check);
  EXPECT_EQ(ce6_max_damage(dr.s), D1);
  EXPECT_NEAR(dr.dissipated(), diss1, 1e-4 * diss1);
  // Further opening damages again.
  dr.move_to(1.1 * o1 * dr.tri.n, 1000, check);
  EXPECT_GT(ce6_max_damage(dr.s), D1);
  EXPECT_TRUE(ok_mono);
  EXPECT_TRUE(ok_diss);
}

// 7. Broken: tangential traction limited by mu |sigma_n|; open faces carry nothing.
TEST(Cohesive6, BrokenFrictionLimit) {
  Material m;
  Driver dr(m);
  const real orr = o_final(dr.p);
  dr.move_to(1.1 * orr * dr.tri.n, 5000);
  ASSERT_TRUE(ce6_broken(dr.s));
  const real mu = m.friction_rock;
  const real sn = 5e6;
  const real o = -sn * kH / m.cohesive_penalty_overlap;
  dr.move_to(0.5 * orr * dr.tri.n, 100);
  EXPECT_EQ(max_abs_force(dr.f), 0.0);  // open: no cohesion left
  dr.move_to(o * dr.tri.n, 1000);
  EXPECT_NEAR(dr.sigma(), -sn, 1e-6 * sn);
  const real kt = m.cohesive_penalty_tangential / kH;
  const real s_stick = mu * sn / kt;  // elastic slip at the friction limit
  // Stick: tau = k_t s.
  dr.move_to(o * dr.tri.n + 0.5 * s_stick * dr.tri.t1, 100);
  EXPECT_NEAR(norm(dr.tau()), kt * 0.5 * s_stick, 1e-6 * mu * sn);
  EXPECT_GT(dot(dr.tau(), dr.tri.t1), 0.0);  // t along the slide: B is pulled back
  // Slip: tau = mu |sigma|.
  bool limited = true;
  dr.move_to(o * dr.tri.n + 20 * s_stick * dr.tri.t1, 2000,
             [&] { limited = limited && norm(dr.tau()) <= mu * std::abs(dr.sigma()) * (1 + 1e-9); });
  EXPECT_TRUE(limited);
  EXPECT_NEAR(norm(dr.tau()) / std::abs(dr.sigma()), mu, 1e-9 * mu);
  // Reverse: back to stick, then slip the other way at the same limit.
  dr.move_to(o * dr.tri.n + 10 * s_stick * dr.tri.t1, 2000);
  EXPECT_LT(dot(dr.tau(), dr.tri.t1), 0.0);
  EXPECT_NEAR(norm(dr.tau()) / std::abs(dr.sigma()), mu, 1e-9 * mu);
  // Friction dissipates.
  EXPECT_GE(dr.dissipated(), 0.0);
  EXPECT_EQ(dr.s.mode, 1);
  // The anchor enters only through its projection on the current tangent plane: a normal
  // component (as left by a rotation of the faces) changes nothing.
  const Ce6State before = dr.s;
  const Vec3 u0 = dr.u;
  dr.move_to(u0 + 0.2 * s_stick * dr.tri.t2, 1);
  const real sig2 = dr.sigma();
  const Vec3 tau2 = dr.tau();
  dr.s = before;
  dr.u = u0;
  for (Vec3& a : dr.s.slip) a += 1e-6 * dr.tri.n;
  dr.move_to(u0 + 0.2 * s_stick * dr.tri.t2, 1);
  EXPECT_NEAR(dr.sigma(), sig2, 1e-9 * sn);
  EXPECT_LT(norm(dr.tau() - tau2), 1e-6 * mu * sn);
}

// An undamaged CE6 neither reads nor writes its friction anchors (the device loop keeps them
// apart and moves them only for damaged or broken CE6s): along a path of compression, sliding
// to a mode II break and sliding on, anchors holding NaN give the same forces, bit for bit, as
// anchors holding zero, and stay NaN until the first damage.
TEST(Cohesive6, AnchorsUnusedUntilDamaged) {
  Material m;
  Driver dr(m);
  Driver nan_anchors(m);
  const real nan = std::numeric_limits<real>::quiet_NaN();
  for (Vec3& a : nan_anchors.s.slip) a = {nan, nan, nan};
  const real sn = 5e6;
  const real o = -sn * kH / m.cohesive_penalty_overlap;
  const real fs = m.cohesion + sn * std::tan(m.friction_angle * M_PI / 180);
  const real sr = s_final(dr.p, fs);
  const int n = 4000;
  bool same = true, nan_while_undamaged = true;
  int undamaged_steps = 0;
  for (int i = 1; i <= n; ++i) {  // compress, then slide along t1 to 2 s_r
    const Vec3 u =
        (std::min(i, 100) / 100.0) * o * dr.tri.n + (i > 100 ? (i - 100) * 2 * sr / (n - 100) : 0.0) * dr.tri.t1;
    dr.move_to(u, 1);
    nan_anchors.move_to(u, 1);
    for (int j = 0; j < 6; ++j)
      same =
          same && dr.f[j].x == nan_anchors.f[j].x && dr.f[j].y == nan_anchors.f[j].y && dr.f[j].z == nan_anchors.f[j].z;
    same = same && dr.ev.stored == nan_anchors.ev.stored && dr.ev.power == nan_anchors.ev.power;
    if (ce6_max_damage(nan_anchors.s) == 0) {
      ++undamaged_steps;
      for (const Vec3& a : nan_anchors.s.slip) nan_while_undamaged = nan_while_undamaged && std::isnan(a.x + a.y + a.z);
    }
  }
  ASSERT_TRUE(ce6_broken(dr.s));
  EXPECT_EQ(dr.s.mode, 2);
  EXPECT_GT(undamaged_steps, 100);
  EXPECT_TRUE(same);
  EXPECT_TRUE(nan_while_undamaged);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(norm(nan_anchors.s.slip[k] - dr.s.slip[k]), 0.0) << k;
}

// A CE6 that breaks straight from undamaged (one step far past its strength) stored no
// anchor: its friction starts from zero on the step of the break.
TEST(Cohesive6, BreakStraightFromUndamagedStartsFrictionFromZero) {
  Material m;
  Driver dr(m);
  const real sn = 5e6;
  const real o = -sn * kH / m.cohesive_penalty_overlap;
  const real fs = compress(dr, m, sn);
  ASSERT_EQ(ce6_max_damage(dr.s), 0.0);
  const real nan = std::numeric_limits<real>::quiet_NaN();
  for (Vec3& a : dr.s.slip) a = {nan, nan, nan};
  dr.move_to(o * dr.tri.n + 1.5 * s_final(dr.p, fs) * dr.tri.t1, 1);
  ASSERT_TRUE(ce6_broken(dr.s));
  EXPECT_EQ(dr.s.mode, 2);
  EXPECT_LT(norm(dr.tau()), 1e-9 * sn);  // round-off of the projection only
  EXPECT_NEAR(dr.sigma(), -sn, 1e-6 * sn);
}

// A broken CE6 whose faces tet-tet contact takes over (broken_inert): no force, and its
// damage, mode and anchors stay as they were, so loops may skip it (ce6_carries_force).
TEST(Cohesive6, InertWhenBrokenUnderContact) {
  Material m;
  Driver dr(m);
  dr.move_to(1.1 * o_final(dr.p) * dr.tri.n, 5000);
  ASSERT_TRUE(ce6_broken(dr.s));
  EXPECT_TRUE(ce6_carries_force(dr.p, dr.s));
  dr.p.broken_inert = 1;
  EXPECT_FALSE(ce6_carries_force(dr.p, dr.s));
  const Ce6State before = dr.s;
  dr.move_to(-1e-6 * dr.tri.n + 1e-6 * dr.tri.t1, 10);
  EXPECT_EQ(max_abs_force(dr.f), 0.0);
  EXPECT_EQ(dr.ev.stored, 0.0);
  EXPECT_EQ(std::memcmp(&before, &dr.s, sizeof(Ce6State)), 0);
}

// Sliding to a mode II break under compression: the friction anchor is the slip at the
// break, so friction builds up elastically from zero and then saturates at mu |sigma_n|.
TEST(Cohesive6, BreakUnderCompressionFrictionStartsFromAnchor) {
  Material m;
  Driver dr(m);
  const real sn = 5e6;
  const real o = -sn * kH / m.cohesive_penalty_overlap;
  const real fs = compress(dr, m, sn);
  const real sr = s_final(dr.p, fs);
  const int n = 20000;
  const real ds = 1.2 * sr / n;
  const real kt = m.cohesive_penalty_tangential / kH;
  bool seen = false;
  for (int i = 1; i <= n && !seen; ++i) {
    dr.move_to(o * dr.tri.n + (i * ds) * dr.tri.t1, 1);
    if (ce6_broken(dr.s)) {
      seen = true;
      EXPECT_EQ(dr.s.mode, 2);
      EXPECT_LE(norm(dr.tau()), kt * ds * (1 + 1e-6));  // one increment of elastic friction
      EXPECT_NEAR(dr.sigma(), -sn, 1e-6 * sn);          // overlap penalty survives the break
    }
  }
  ASSERT_TRUE(seen);
  const real s_stick = m.friction_rock * sn / kt;
  dr.move_to(dr.u + 3 * s_stick * dr.tri.t1, 300);
  EXPECT_NEAR(norm(dr.tau()) / std::abs(dr.sigma()), m.friction_rock, 1e-9 * m.friction_rock);
}
