// contact_tet_pair and contact_friction (physics/contact.hpp). Both normal laws: symmetry,
// balance, torque, rigid motions, and zero when apart. The overlap-volume law against its
// energy (the exact volume of a tet and its translate, and finite differences of W), and a
// closed loop of deforming tets that returns no work, which Munjiza's law fails. Munjiza's
// law against its definition P int (grad phi_a - grad phi_b) dV (an independent Monte Carlo
// volume integral). The Coulomb friction law of a pair.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/format.hpp"
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

namespace fdem {
/// A law's word in the test names.
void PrintTo(ContactLaw law, std::ostream* os) {
  *os << name_of(law);
}
}  // namespace fdem

/// The tests every normal law passes, run for each.
class EachLaw : public ::testing::TestWithParam<ContactLaw> {};
INSTANTIATE_TEST_SUITE_P(ContactLaws, EachLaw, ::testing::Values(ContactLaw::volume, ContactLaw::munjiza),
                         [](const auto& info) { return std::string(name_of(info.param)); });

TEST_P(EachLaw, ForceGrowsWithOverlapIsBalancedAndVanishesApart) {
  const ContactLaw law = GetParam();
  Tet a, b, fa, fb;
  base_tet(a);
  real last = 0;
  for (real depth : {1e-7, 1e-6, 1e-5, 5e-5, 1e-4}) {
    mirrored_tet(b, {0.05e-3, 0.02e-3, depth});  // b pushed up into a through the shared face
    const ContactEval e = contact_tet_pair(law, a, b, P, fa, fb);
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
    const ContactEval e = contact_tet_pair(law, a, b, P, fa, fb);
    EXPECT_EQ(e.weight, 0);
    for (int i = 0; i < 4; ++i) {
      EXPECT_EQ(norm(fa[i]), 0);
      EXPECT_EQ(norm(fb[i]), 0);
    }
  }
}

TEST(MunjizaLaw, EqualsTheVolumeIntegralOfThePotentialGradients) {
  // Independent check of the surface-integral evaluation: a Monte Carlo integral over the
  // overlap of P (grad phi_a - grad phi_b), 2 million samples (statistical error ~0.3 %).
  Tet a, b, fa, fb;
  base_tet(a);
  const Mat3 R = rotation({0.36, 0.48, 0.8}, 0.7);
  const Vec3 c{0.5e-3, 0.3e-3, 0.3e-3};
  for (int i = 0; i < 4; ++i) b[i] = R * (a[i] - c) + Vec3{0.75e-3, 0.45e-3, 0.4e-3};  // deep, skew overlap
  const ContactEval e = contact_munjiza_pair(a, b, P, fa, fb);
  const Vec3 ref = volume_integral(a, b, 2000000);
  ASSERT_GT(norm(ref), 0);
  EXPECT_LT(norm(e.normal - ref), 0.01 * norm(ref))
      << e.normal.x << " " << e.normal.y << " " << e.normal.z << " vs " << ref.x << " " << ref.y << " " << ref.z;
}

TEST_P(EachLaw, SwappingContactorAndTargetSwapsTheForces) {
  const ContactLaw law = GetParam();
  Tet a, b, fa, fb, ga, gb;
  base_tet(a);
  const Mat3 R = rotation({0, 0.6, 0.8}, 1.1);
  for (int i = 0; i < 4; ++i) b[i] = R * a[i] + Vec3{0.3e-3, 0.2e-3, 0.1e-3};
  const ContactEval e1 = contact_tet_pair(law, a, b, P, fa, fb);
  const ContactEval e2 = contact_tet_pair(law, b, a, P, gb, ga);
  const real s = scale_of(fa);
  ASSERT_GT(s, 0);
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(fa[i][d], ga[i][d], 1e-12 * s);
      EXPECT_NEAR(fb[i][d], gb[i][d], 1e-12 * s);
    }
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(e1.normal[d], -e2.normal[d], 1e-12 * s);
}

TEST_P(EachLaw, NoNetTorqueAndRotatesWithTheBodies) {
  const ContactLaw law = GetParam();
  Tet a, b, fa, fb;
  base_tet(a);
  const Mat3 R = rotation({0.6, 0, 0.8}, 2.0);
  for (int i = 0; i < 4; ++i) b[i] = R * a[i] + Vec3{0.2e-3, 0.5e-3, 0.2e-3};
  contact_tet_pair(law, a, b, P, fa, fb);
  const real s = scale_of(fa);
  ASSERT_GT(s, 0);
  Vec3 torque{0, 0, 0};
  for (int i = 0; i < 4; ++i) torque += cross(a[i], fa[i]) + cross(b[i], fb[i]);
  EXPECT_LT(norm(torque), 1e-12 * s * 1e-3);

  // Rigid motion of both tets: the nodal forces rotate with them.
  const Mat3 Q = rotation({0.48, 0.6, 0.64}, -0.9);
  Tet qa, qb, ga, gb;
  for (int i = 0; i < 4; ++i) qa[i] = Q * a[i] + Vec3{5, -3, 2}, qb[i] = Q * b[i] + Vec3{5, -3, 2};
  contact_tet_pair(law, qa, qb, P, ga, gb);
  for (int i = 0; i < 4; ++i)
    for (int d = 0; d < 3; ++d) {
      EXPECT_NEAR(ga[i][d], (Q * fa[i])[d], 1e-8 * s);
      EXPECT_NEAR(gb[i][d], (Q * fb[i])[d], 1e-8 * s);
    }
}

TEST_P(EachLaw, FrictionSticksElasticallyThenSlidesAtMuN) {
  const ContactLaw law = GetParam();
  Tet a, b, fa, fb, va, vb;
  base_tet(a);
  mirrored_tet(b, {0.05e-3, 0.02e-3, 2e-5});
  const ContactEval e = contact_tet_pair(law, a, b, P, fa, fb);
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
  const ContactEval apart = contact_tet_pair(law, a, c, P, ga, gb);
  EXPECT_EQ(contact_friction(a, c, va, vb, apart, mu, kt, dt, u, ga, gb), 0);
  EXPECT_EQ(norm(u), 0);
}

namespace {

/// The overlap law's energy for an overlap volume V: (2P/3) V^2 (1/V_a + 1/V_b).
real volume_law_energy(real V, const Tet& a, const Tet& b) {
  return 2.0 / 3 * P * V * V * (1 / std::fabs(tet4_volume(a)) + 1 / std::fabs(tet4_volume(b)));
}

/// A deformed copy of base_tet: each node moved by up to `amount` (m), reproducibly.
void deformed_tet(Tet& t, unsigned seed, real amount) {
  base_tet(t);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<real> u(-amount, amount);
  for (auto& p : t) p += Vec3{u(rng), u(rng), u(rng)};
}

}  // namespace

TEST(VolumeLaw, EnergyIsThatOfTheExactOverlapOfATetAndItsTranslate) {
  // A tet and its translate by s overlap in a copy of the tet scaled by 1 - sum_i max(0, d_i),
  // d_i the change of node i's barycentric weight along s: an exact overlap volume.
  Tet a, b, fa, fb;
  base_tet(a);
  const Mat3 Einv = inverse(Mat3::from_columns(a[1] - a[0], a[2] - a[0], a[3] - a[0]));
  for (const Vec3 s : {Vec3{0.1e-3, 0.05e-3, 0.02e-3}, Vec3{-0.2e-3, 0.1e-3, 0.15e-3}, Vec3{0, 0, -0.3e-3}}) {
    for (int i = 0; i < 4; ++i) b[i] = a[i] + s;
    const Vec3 l = Einv * s;
    const real d[4] = {-l.x - l.y - l.z, l.x, l.y, l.z};
    real shrink = 1;
    for (real di : d) shrink -= std::fmax(di, 0);
    ASSERT_GT(shrink, 0.2);
    const real V = std::fabs(tet4_volume(a)) * shrink * shrink * shrink;
    const ContactEval e = contact_volume_pair(a, b, P, fa, fb);
    EXPECT_NEAR(e.energy, volume_law_energy(V, a, b), 1e-9 * e.energy) << "shift " << s.x << " " << s.y << " " << s.z;
    // The normal force on a points away from b (against the shift).
    EXPECT_LT(dot(e.normal, s), 0);
  }
}

TEST(VolumeLaw, ForcesAreTheExactGradientOfTheEnergy) {
  // Central differences of W in every coordinate of every node, deformed and rotated tets.
  for (unsigned seed = 1; seed <= 6; ++seed) {
    Tet a, b, fa, fb, ga, gb;
    deformed_tet(a, seed, 0.1e-3);
    deformed_tet(b, 100 + seed, 0.1e-3);
    const Mat3 R = rotation({0.36, 0.48, 0.8}, 0.3 * seed);
    for (auto& p : b) p = R * p + Vec3{0.3e-3, 0.2e-3, 0.1e-3 * seed - 0.3e-3};
    const ContactEval e = contact_volume_pair(a, b, P, fa, fb);
    ASSERT_GT(e.energy, 0) << "seed " << seed;
    const real s = scale_of(fa) + scale_of(fb);
    const real h = 1e-9;  // m
    for (int t = 0; t < 2; ++t)
      for (int i = 0; i < 4; ++i)
        for (int d = 0; d < 3; ++d) {
          Tet pa, pb, ma, mb;
          copy(a, pa), copy(b, pb), copy(a, ma), copy(b, mb);
          (t == 0 ? pa : pb)[i][d] += h;
          (t == 0 ? ma : mb)[i][d] -= h;
          const real dW = contact_volume_pair(pa, pb, P, ga, gb).energy - contact_volume_pair(ma, mb, P, ga, gb).energy;
          const real f = (t == 0 ? fa : fb)[i][d];
          EXPECT_NEAR(f, -dW / (2 * h), 1e-6 * s) << "seed " << seed << " tet " << t << " node " << i << " axis " << d;
        }
  }
}

namespace {

/// The net work of the contact forces on a closed loop where a node of each tet circles out of
/// phase (one node of a in the xy plane, one of b in the yz plane, amplitude r, m), over
/// the sum of |f| |dx| along the loop: 0 for a conservative law.
real closed_loop_work(ContactLaw law, int steps, real r) {
  Tet a0, b0;
  base_tet(a0);
  mirrored_tet(b0, {0.05e-3, 0.02e-3, 1e-4});  // b pushed 0.1 mm into a through the shared face
  auto place = [&](real th, Tet& a, Tet& b) {
    copy(a0, a), copy(b0, b);
    a[0] += r * Vec3{std::cos(th) - 1, std::sin(th), 0};
    b[1] += r * Vec3{0, std::sin(th + 1.0), std::cos(th + 1.0) - std::cos(1.0)};
  };
  real work = 0, scale = 0;
  const real two_pi = 2 * std::acos(real(-1));
  for (int k = 0; k < steps; ++k) {
    Tet a1, b1, a2, b2, am, bm, fa, fb;
    place(two_pi * k / steps, a1, b1);
    place(two_pi * (k + 1) / steps, a2, b2);
    place(two_pi * (k + 0.5) / steps, am, bm);  // forces at the midpoint: a second-order rule
    contact_tet_pair(law, am, bm, P, fa, fb);
    const Vec3 da = a2[0] - a1[0], db = b2[1] - b1[1];
    work += dot(fa[0], da) + dot(fb[1], db);
    scale += norm(fa[0]) * norm(da) + norm(fb[1]) * norm(db);
  }
  return work / scale;
}

}  // namespace

TEST(VolumeLaw, AClosedLoopOfDeformingTetsReturnsNoWork) {
  // Munjiza's law returns about 1 % of |F| x path per cycle here (docs/physics.md): the test
  // fails on it, and passes on the overlap-volume law to the quadrature's error.
  const real volume = closed_loop_work(ContactLaw::volume, 4000, 50e-6);
  const real munjiza = closed_loop_work(ContactLaw::munjiza, 4000, 50e-6);
  EXPECT_LT(std::fabs(volume), 1e-6) << "volume law: net work / (|F| x path) " << volume;
  EXPECT_GT(std::fabs(munjiza), 1e-3) << "Munjiza's law: net work / (|F| x path) " << munjiza;
}

TEST(VolumeLaw, TetsSharingAFaceOverlapByTheirGapWhateverTheRoundOff) {
  // Two tets of a structured mesh on either side of one face, as across a joint or a broken
  // CE6: an edge of the upper tet also lies in a side face of the lower one. Turned and moved
  // by random rigid motions, each node nudged by 1e-13 m: the gap is round-off, and so is the
  // overlap (at most the face's area times the nudges). Pressed together by d = 1e-7 m the
  // overlap is A d. Each face clipped on its own against the other tet kept the whole face
  // on one side and none on the other at some of these pairs, and the overlap was then off
  // by up to a tet's volume: the energy watch stopped a block on a joint.
  const real h = 2.5e-3;
  const Tet a0 = {{0, 0, -h}, {0, 0, 0}, {h, 0, 0}, {h, h, 0}}, b0 = {{0, 0, 0}, {h, 0, 0}, {h, h, 0}, {h, h, h}};
  const real area = h * h / 2, vol = h * h * h / 6, d = 1e-7;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<real> u(-1, 1);
  real worst_touching = 0, worst_pressed = 0;
  for (int k = 0; k < 50000; ++k) {
    // The first half on the mesh's own axes and grid, as a structured mesh has them.
    const bool grid = k < 25000;
    const Mat3 R = grid ? rotation({0, 0, 1}, 0) : rotation({u(rng), u(rng), u(rng) + 2}, 3 * u(rng));
    const Vec3 at = grid ? h * Vec3{std::floor(4 * u(rng)), std::floor(4 * u(rng)), std::floor(4 * u(rng))}
                         : Vec3{0.01 * u(rng), 0.01 * u(rng), 0.01 * u(rng)};
    const real nudge = 1e-13;
    for (const real press : {real(0), d}) {
      Tet a, b, fa, fb;
      for (int i = 0; i < 4; ++i) {
        a[i] = R * (a0[i] + Vec3{0, 0, press}) + at + nudge * Vec3{u(rng), u(rng), u(rng)};
        b[i] = R * b0[i] + at + nudge * Vec3{u(rng), u(rng), u(rng)};
      }
      const real V = contact_volume_pair(a, b, P, fa, fb, 0).overlap;
      if (press == 0)
        worst_touching = std::fmax(worst_touching, std::fabs(V) / vol);
      else
        worst_pressed = std::fmax(worst_pressed, std::fabs(V / (area * d) - 1));
    }
  }
  RecordProperty("touching_overlap_over_tet_volume", fmt(worst_touching, 3));
  RecordProperty("pressed_overlap_over_area_times_depth", fmt(worst_pressed, 3));
  EXPECT_LT(worst_touching, 1e-8) << "the overlap of two tets that only touch";
  EXPECT_LT(worst_pressed, 1e-3) << "relative error of A d";
}

TEST(VolumeLaw, EdgeAxesRejectOnlyPairsThatDoNotOverlap) {
  // Random pairs of deformed tets, b shifted by up to two edge lengths. Where the edge axes say
  // separated but no face plane does, clipping must find no overlap; and the edge axes must
  // spare some clippings that find none (the cheap test does work).
  using namespace contact_detail;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<real> u(-2e-3, 2e-3);
  int spared = 0, clipped_empty = 0, overlapping = 0;
  for (int k = 0; k < 20000; ++k) {
    Tet a, b;
    deformed_tet(a, 2 * k, 0.2e-3);
    deformed_tet(b, 2 * k + 1, 0.2e-3);
    const Vec3 shift{u(rng), u(rng), u(rng)};
    for (auto& p : b) p += shift;
    const Planes pa = tet_face_planes(a), pb = tet_face_planes(b);
    if (separated_by(pb, a) || separated_by(pa, b)) continue;
    Overlap ov{0, {}, {}, {0, 0, 0}, 0};
    overlap_of(a, b, pa, pb, ov);
    const bool empty = !(ov.volume > 1e-12 * std::fabs(tet4_volume(a)));
    if (separated_by_edges(a, b)) {
      ASSERT_TRUE(empty) << "pair " << k << ": separated by an edge axis but overlapping by " << ov.volume << " m^3";
      ++spared;
    } else if (empty) {
      ++clipped_empty;
    } else {
      ++overlapping;
    }
  }
  std::printf("past the face planes: %d overlap, %d spared by the edge axes, %d clipped to nothing\n", overlapping,
              spared, clipped_empty);
  EXPECT_GT(overlapping, 100);
  EXPECT_GT(spared, 100);
  EXPECT_LT(clipped_empty, spared / 10) << "the edge axes are all the separating axes there are";
}
