// platen_node_force: node-to-plane penalty with Coulomb friction (tangential elastic
// predictor with a sliding anchor). Every expected value is worked out by hand from the
// law in physics/platen.hpp and docs/physics.md.
#include <gtest/gtest.h>

#include <cmath>

#include "physics/platen.hpp"

using namespace fdem;

namespace {

constexpr real k = 2.5e6;  // N/m
constexpr real mu = 0.3;
const Vec3 ez{0, 0, 1};  // platen normal, pointing into the rock (a bottom platen)

void expect_vec(Vec3 a, Vec3 b, real tol) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

}  // namespace

TEST(PlatenNodeForce, NoForceWithoutPenetrationAndAnchorFollowsNode) {
  // The node is 0.1 mm outside the platen (on the rock side): no contact.
  Vec3 anchor{5, 5, 5};
  const Vec3 xr{0.3e-3, -0.2e-3, 0.1e-3};
  PlatenEval e = platen_node_force(xr, ez, k, mu, anchor);
  EXPECT_EQ(e.force.x, 0);
  EXPECT_EQ(e.force.y, 0);
  EXPECT_EQ(e.force.z, 0);
  EXPECT_EQ(e.stored, 0);
  EXPECT_EQ(e.dissipated, 0);
  // The anchor is the node's tangential position on the platen plane.
  expect_vec(anchor, {0.3e-3, -0.2e-3, 0}, 1e-18);

  // Exactly on the plane (g = 0) is not contact either.
  anchor = {1, 1, 1};
  e = platen_node_force({2e-3, 1e-3, 0}, ez, k, mu, anchor);
  EXPECT_EQ(e.force.z, 0);
  EXPECT_EQ(e.stored, 0);
  expect_vec(anchor, {2e-3, 1e-3, 0}, 1e-18);

  // Out of contact, the node moving tangentially drags the anchor with it: touching down
  // afterwards at the same tangential position gives no tangential force.
  for (int i = 1; i <= 5; ++i) platen_node_force({0.1e-3 * i, 0, 1e-3}, ez, k, mu, anchor);
  e = platen_node_force({0.5e-3, 0, -1e-6}, ez, k, mu, anchor);
  EXPECT_NEAR(e.force.x, 0, 1e-12);
  EXPECT_NEAR(e.force.y, 0, 1e-12);
  EXPECT_NEAR(e.force.z, k * 1e-6, 1e-9);
}

TEST(PlatenNodeForce, NormalForceIsPenaltyTimesGap) {
  for (real g : {1e-9, 3e-6, 2e-4}) {
    Vec3 anchor{0.7e-3, 0.1e-3, 0};
    const PlatenEval e = platen_node_force({0.7e-3, 0.1e-3, -g}, ez, k, mu, anchor);
    EXPECT_NEAR(e.force.z, k * g, 1e-12 * k * g);
    EXPECT_EQ(e.force.x, 0);
    EXPECT_EQ(e.force.y, 0);
    EXPECT_NEAR(e.stored, 0.5 * k * g * g, 1e-12 * k * g * g);
    EXPECT_EQ(e.dissipated, 0);
  }
  // A top platen (normal -z, pointing down into the rock): the node is above its plane.
  Vec3 anchor{0, 0, 0};
  const PlatenEval e = platen_node_force({0, 0, 4e-6}, {0, 0, -1}, k, mu, anchor);
  EXPECT_NEAR(e.force.z, -k * 4e-6, 1e-18);
  EXPECT_NEAR(e.stored, 0.5 * k * 16e-12, 1e-20);
}

TEST(PlatenNodeForce, StickingIsAnElasticSpringToTheAnchor) {
  const real g = 1e-5;  // friction limit mu k g = 7.5 N, spring length limit mu g = 3e-6 m
  const Vec3 a0{1e-3, 2e-3, 0};
  // Tangential offsets below the limit, in several directions.
  for (Vec3 d : {Vec3{1e-6, 0, 0}, Vec3{0, -2e-6, 0}, Vec3{2e-6, 2e-6, 0}, Vec3{-2.9e-6, 0.5e-6, 0}}) {
    ASSERT_LT(norm(d), mu * g);
    Vec3 anchor = a0;
    const PlatenEval e = platen_node_force(a0 + d + Vec3{0, 0, -g}, ez, k, mu, anchor);
    expect_vec(e.force, {-k * d.x, -k * d.y, k * g}, 1e-9);
    expect_vec(anchor, a0, 0);  // no slip: the anchor stays
    EXPECT_EQ(e.dissipated, 0);
    EXPECT_NEAR(e.stored, 0.5 * k * (g * g + dot(d, d)), 1e-12 * k * g * g);
    EXPECT_LE(std::hypot(e.force.x, e.force.y), mu * k * g * (1 + 1e-12));
  }
  // Moving back and forth inside the stick range is reversible: nothing dissipated and the
  // force returns to zero when the node comes back.
  Vec3 anchor = a0;
  real dissipated = 0;
  for (real s : {1e-6, 2e-6, 2.5e-6, 1e-6, -2e-6, 0.0})
    dissipated += platen_node_force(a0 + Vec3{s, 0, -g}, ez, k, mu, anchor).dissipated;
  EXPECT_EQ(dissipated, 0);
  const PlatenEval e = platen_node_force(a0 + Vec3{0, 0, -g}, ez, k, mu, anchor);
  EXPECT_NEAR(e.force.x, 0, 1e-12);
  EXPECT_NEAR(e.force.y, 0, 1e-12);
}

TEST(PlatenNodeForce, SlidingForceIsCoulombLimitOpposingTheSlip) {
  const real g = 2e-5;
  const real limit = mu * k * g;  // 15 N
  const Vec3 a0{0, 0, 0};
  // Offset (3, 4) x 1e-5 m: length 5e-5 m, far beyond the spring limit mu g = 6e-6 m.
  const Vec3 d{3e-5, 4e-5, 0};
  const Vec3 dir{0.6, 0.8, 0};
  Vec3 anchor = a0;
  const PlatenEval e = platen_node_force(d + Vec3{0, 0, -g}, ez, k, mu, anchor);
  const real ft = std::hypot(e.force.x, e.force.y);
  EXPECT_NEAR(ft, limit, 1e-12 * limit);
  expect_vec(e.force, {-limit * dir.x, -limit * dir.y, k * g}, 1e-9);
  // The anchor slid along the slip so that the spring is exactly at the limit length.
  const Vec3 expected_anchor = d - (mu * g) * dir;
  expect_vec(anchor, expected_anchor, 1e-15);
  EXPECT_NEAR(e.dissipated, limit * norm(expected_anchor - a0), 1e-12 * limit * norm(d));
  EXPECT_NEAR(e.dissipated, limit * (5e-5 - 6e-6), 1e-15);
  EXPECT_NEAR(e.stored, 0.5 * k * (g * g + (mu * g) * (mu * g)), 1e-9 * k * g * g);
}

TEST(PlatenNodeForce, SteadySlidingDissipatesLimitTimesAnchorTravel) {
  // A node pressed in by g and dragged along -x in equal steps: after the stick phase the
  // anchor trails the node by mu g, the friction force is +x at the Coulomb limit, and the
  // dissipated work equals limit x anchor travel.
  const real g = 1e-5, limit = mu * k * g, step = 1e-6;
  Vec3 anchor{0, 0, 0};
  real dissipated = 0;
  PlatenEval e{};
  const int n = 40;
  for (int i = 1; i <= n; ++i) {
    e = platen_node_force({-step * i, 0, -g}, ez, k, mu, anchor);
    dissipated += e.dissipated;
    if (step * i <= mu * g * (1 - 1e-9)) {
      EXPECT_EQ(e.dissipated, 0) << "still sticking at step " << i;
    }
  }
  EXPECT_NEAR(e.force.x, limit, 1e-12 * limit);
  EXPECT_NEAR(anchor.x, -step * n + mu * g, 1e-15);
  const real travel = step * n - mu * g;  // the anchor moved from 0 to -(n step - mu g)
  EXPECT_NEAR(dissipated, limit * travel, 1e-12 * limit * travel);
  EXPECT_NEAR(e.stored, 0.5 * k * (g * g + mu * g * mu * g), 1e-9 * k * g * g);
}

TEST(PlatenNodeForce, FrictionlessPlatenHasNoTangentialForce) {
  Vec3 anchor{0, 0, 0};
  const PlatenEval e = platen_node_force({1e-4, -2e-4, -3e-6}, ez, k, 0, anchor);
  EXPECT_NEAR(e.force.x, 0, 1e-15);
  EXPECT_NEAR(e.force.y, 0, 1e-15);
  EXPECT_NEAR(e.force.z, k * 3e-6, 1e-12);
  expect_vec(anchor, {1e-4, -2e-4, 0}, 1e-18);
  EXPECT_NEAR(e.stored, 0.5 * k * 9e-12, 1e-18);
}

TEST(PlatenNodeForce, RotatedPlaneGivesRotatedForces) {
  const real g = 1e-5;
  // Reference evaluations with n = z: one sticking, one sliding.
  const Vec3 x_stick{1e-6, -1e-6, -g}, x_slide{4e-5, 1e-5, -g};
  const Vec3 a_ref{2e-7, 3e-7, 0};
  const real c = 1 / std::sqrt(real(3));
  const Mat3 R = rotation({c, -c, c}, 1.1);
  for (Vec3 x : {x_stick, x_slide}) {
    Vec3 a1 = a_ref;
    const PlatenEval e1 = platen_node_force(x, ez, k, mu, a1);
    Vec3 a2 = R * a_ref;
    const Vec3 n2 = R * ez;
    const PlatenEval e2 = platen_node_force(R * x, n2, k, mu, a2);
    expect_vec(e2.force, R * e1.force, 1e-9);
    expect_vec(a2, R * a1, 1e-15);
    EXPECT_NEAR(e2.stored, e1.stored, 1e-9 * e1.stored);
    EXPECT_NEAR(e2.dissipated, e1.dissipated, 1e-9 * (e1.dissipated + 1e-30));
    // The normal part is k g along the rotated normal.
    EXPECT_NEAR(dot(e2.force, n2), k * g, 1e-9);
  }
}
