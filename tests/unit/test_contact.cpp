// contact_tet_pair and contact_friction (physics/contact.hpp): the potential contact force
// between two TET4s against its definition P int (grad phi_a - grad phi_b) dV (checked by an
// independent Monte Carlo volume integral), its symmetry, balance and torque, and the
// Coulomb friction law of a pair.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "physics/contact.hpp"

using namespace fdem;

namespace {

constexpr real P = 122e9;  // Pa, the reference contact penalty (10 E)

using Tet = Vec3[4];

void copy(const Tet& s, Tet& d) {
  for (int i = 0; i < 4; ++i) d[i] = s[i];
}

/// A well-shaped tet of edge about 1 mm, positively oriented, around the origin.
void base_tet(Tet& t) {
  t[0] = {0, 0, 0};
  t[1] = {1e-3, 0, 0};
  t[2] = {0.4e-3, 0.9e-3, 0};
  t[3] = {0.45e-3, 0.3e-3, 0.85e-3};
}

/// The mirror image of base_tet through the plane z = 0 (its face z = 0 shared), shifted by s.
void mirrored_tet(Tet& t, Vec3 s) {
  base_tet(t);
  for (auto& p : t) p = Vec3{p.x, p.y, -p.z} + s;
}

Vec3 sum(const Tet& f) {
  return f[0] + f[1] + f[2] + f[3];
}

real scale_of(const Tet& f) {
  real s = 0;
  for (const auto& v : f) s = std::fmax(s, norm(v));
  return s;
}

/// phi of a tet at p (min over the four sub-tet potentials) and its gradient there;
/// returns false if p is outside the tet.
bool potential(const Tet& x, Vec3 p, real& phi, Vec3& grad) {
  const Vec3 C = 0.25 * (x[0] + x[1] + x[2] + x[3]);
  phi = 2;
  for (int k = 0; k < 4; ++k) {
    const Vec3 p0 = x[(k + 1) % 4], p1 = x[(k + 2) % 4], p2 = x[(k + 3) % 4];
    Vec3 n = cross(p1 - p0, p2 - p0);
    if (dot(n, x[k] - p0) < 0) n = -n;
    const real s = dot(n, p - p0);
    if (s < 0) return false;
    const real q = s / dot(n, C - p0);
    if (q < phi) phi = q, grad = (1 / dot(n, C - p0)) * n;
  }
  return true;
}

/// Monte Carlo estimate of P int_{a cap b} (grad phi_a - grad phi_b) dV.
Vec3 volume_integral(const Tet& a, const Tet& b, int samples) {
  Vec3 lo = a[0], hi = a[0];
  for (int i = 1; i < 4; ++i)
    for (int d = 0; d < 3; ++d) lo[d] = std::fmin(lo[d], a[i][d]), hi[d] = std::fmax(hi[d], a[i][d]);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<real> u(0, 1);
  Vec3 acc{0, 0, 0};
  for (int s = 0; s < samples; ++s) {
    const Vec3 p{lo.x + u(rng) * (hi.x - lo.x), lo.y + u(rng) * (hi.y - lo.y), lo.z + u(rng) * (hi.z - lo.z)};
    real pa, pb;
    Vec3 ga, gb;
    if (potential(a, p, pa, ga) && potential(b, p, pb, gb)) acc += ga - gb;
  }
  const real vol = (hi.x - lo.x) * (hi.y - lo.y) * (hi.z - lo.z);
  return (P * vol / samples) * acc;
}

}  // namespace

TEST(ContactTetPair, ForceGrowsWithOverlapIsBalancedAndVanishesApart) {
  Tet a, b, fa, fb;
  base_tet(a);
  real last = 0;
  for (real depth : {1e-7, 1e-6, 1e-5, 5e-5, 1e-4}) {
    mirrored_tet(b, {0.05e-3, 0.02e-3, depth});  // b pushed up into a through the shared face
    const ContactEval e = contact_tet_pair(a, b, P, fa, fb);
    const Vec3 Fa = sum(fa), Fb = sum(fb);
    EXPECT_GT(e.normal.z, last) << "depth " << depth;  // a is pushed up (+z), more with depth
    last = e.normal.z;
    EXPECT_NEAR(Fa.z, e.normal.z, 1e-12 * e.normal.z);
    // Equal and opposite, to round-off.
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(Fa[d] + Fb[d], 0, 1e-12 * e.normal.z);
    // Mostly normal to the shared face.
    EXPECT_LT(std::hypot(Fa.x, Fa.y), 0.3 * Fa.z);
  }
  // Separated by a small gap, or just touching: exactly no force.
  for (real gap : {0.0, 1e-9, 1e-4}) {
    mirrored_tet(b, {0.05e-3, 0.02e-3, -gap});
    const ContactEval e = contact_tet_pair(a, b, P, fa, fb);
    EXPECT_EQ(e.weight, 0);
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(norm(fa[i]), 0);
      EXPECT_EQ(norm(fb[i]), 0);
    }
  }
}

TEST(ContactTetPair, EqualsTheVolumeIntegralOfThePotentialGradients) {
  // Independent check of the surface-integral evaluation: a Monte Carlo integral over the
  // overlap of P (grad phi_a - grad phi_b), 2 million samples (statistical error ~0.3 %).
  Tet a, b, fa, fb;
  base_tet(a);
  const Mat3 R = rotation({0.36, 0.48, 0.8}, 0.7);
  const Vec3 c{0.5e-3, 0.3e-3, 0.3e-3};
  for (int i = 0; i < 4; ++i) b[i] = R * (a[i] - c) + Vec3{0.75e-3, 0.45e-3, 0.4e-3};  // deep, skew overlap
  const ContactEval e = contact_tet_pair(a, b, P, fa, fb);
  const Vec3 ref = volume_integral(a, b, 2000000);
  ASSERT_GT(norm(ref), 0);
  EXPECT_LT(norm(e.normal - ref), 0.01 * norm(ref))
      << e.normal.x << " " << e.normal.y << " " << e.normal.z << " vs " << ref.x << " " << ref.y << " " << ref.z;
}

TEST(ContactTetPair, SwappingContactorAndTargetSwapsTheForces) {
  Tet a, b, fa, fb, ga, gb;
  base_tet(a);
  const Mat3 R = rotation({0, 0.6, 0.8}, 1.1);
  for (int i = 0; i < 4; ++i) b[i] = R * a[i] + Vec3{0.3e-3, 0.2e-3, 0.1e-3};
  const ContactEval e1 = contact_tet_pair(a, b, P, fa, fb);
  const ContactEval e2 = contact_tet_pair(b, a, P, gb, ga);
  const real s = scale_of(fa);
  ASSERT_GT(s, 0);
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(fa[i][d], ga[i][d], 1e-12 * s);
      EXPECT_NEAR(fb[i][d], gb[i][d], 1e-12 * s);
    }
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(e1.normal[d], -e2.normal[d], 1e-12 * s);
}

TEST(ContactTetPair, NoNetTorqueAndRotatesWithTheBodies) {
  Tet a, b, fa, fb;
  base_tet(a);
  const Mat3 R = rotation({0.6, 0, 0.8}, 2.0);
  for (int i = 0; i < 4; ++i) b[i] = R * a[i] + Vec3{0.2e-3, 0.5e-3, 0.2e-3};
  contact_tet_pair(a, b, P, fa, fb);
  const real s = scale_of(fa);
  ASSERT_GT(s, 0);
  Vec3 torque{0, 0, 0};
  for (int i = 0; i < 4; ++i) torque += cross(a[i], fa[i]) + cross(b[i], fb[i]);
  EXPECT_LT(norm(torque), 1e-12 * s * 1e-3);

  // Rigid motion of both tets: the nodal forces rotate with them.
  const Mat3 Q = rotation({0.48, 0.6, 0.64}, -0.9);
  Tet qa, qb, ga, gb;
  for (int i = 0; i < 4; ++i) qa[i] = Q * a[i] + Vec3{5, -3, 2}, qb[i] = Q * b[i] + Vec3{5, -3, 2};
  contact_tet_pair(qa, qb, P, ga, gb);
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(ga[i][d], (Q * fa[i])[d], 1e-8 * s);
      EXPECT_NEAR(gb[i][d], (Q * fb[i])[d], 1e-8 * s);
    }
}

TEST(ContactFriction, SticksElasticallyThenSlidesAtMuN) {
  Tet a, b, fa, fb, va, vb;
  base_tet(a);
  mirrored_tet(b, {0.05e-3, 0.02e-3, 2e-5});
  const ContactEval e = contact_tet_pair(a, b, P, fa, fb);
  const real N = norm(e.normal);
  ASSERT_GT(N, 0);
  const real mu = 0.5, kt = 1e7, dt = 1e-8;
  for (int i = 0; i < 4; ++i) va[i] = {0.1, 0, 0}, vb[i] = {0, 0, 0};  // a slides along +x
  const Vec3 n = (1 / N) * e.normal;
  const Vec3 vt = va[0] - dot(va[0], n) * n;  // the tangential part of the sliding velocity
  Vec3 u{0, 0, 0};
  // Sticking: the spring grows by v_t dt a step and pulls a back; no dissipation.
  for (int s = 1; s <= 3; ++s) {
    Tet ga, gb;
    copy(fa, ga);
    copy(fb, gb);
    const real w = contact_friction(a, b, va, vb, e, mu, kt, dt, u, ga, gb);
    const Vec3 T = sum(ga) - sum(fa);
    const Vec3 expect = -(kt * dt * s) * vt;
    ASSERT_LT(norm(expect), mu * N);
    const Vec3 Tb = sum(gb) - sum(fb);
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(T[d], expect[d], 1e-9 * norm(expect));
      EXPECT_NEAR(Tb[d], -expect[d], 1e-9 * norm(expect));
    }
    EXPECT_EQ(w, 0);
  }
  // Sliding: a long step takes the trial force past mu N; it is returned to mu N and the
  // excess spring length is dissipated at mu N.
  Tet ga, gb;
  copy(fa, ga);
  copy(fb, gb);
  const real dt_long = 10 * mu * N / (kt * norm(vt));
  const real u_before = norm(u);
  const real w = contact_friction(a, b, va, vb, e, mu, kt, dt_long, u, ga, gb);
  const Vec3 T = sum(ga) - sum(fa);
  EXPECT_NEAR(norm(T), mu * N, 1e-9 * mu * N);
  EXPECT_LT(T.x, 0);
  const real trial = kt * (u_before + norm(vt) * dt_long);
  EXPECT_NEAR(w, mu * N * (trial - mu * N) / kt, 1e-9 * w);
  EXPECT_NEAR(norm(u), mu * N / kt, 1e-9 * norm(u));
  // Out of contact the spring is forgotten.
  Tet c;
  mirrored_tet(c, {0.05e-3, 0.02e-3, -1e-5});
  const ContactEval apart = contact_tet_pair(a, c, P, ga, gb);
  EXPECT_EQ(contact_friction(a, c, va, vb, apart, mu, kt, dt, u, ga, gb), 0);
  EXPECT_EQ(norm(u), 0);
}
