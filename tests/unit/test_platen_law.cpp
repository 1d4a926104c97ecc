// Platen node-to-plane penalty with Coulomb friction (physics/platen.hpp).
#include <gtest/gtest.h>

#include <cmath>

#include "physics/platen.hpp"

using namespace fdem;

namespace {
const real k = 2.0e6, mu = 0.1;  // N/m, -
const Vec3 up{0, 0, 1};
}  // namespace

TEST(Platen, NoPenetrationNoForceAndTheAnchorFollows) {
  Vec3 anchor{5, 5, 0};
  const PlatenEval e = platen_node_force({0.001, -0.002, 1e-6}, up, k, mu, anchor);
  EXPECT_EQ(norm(e.force), 0);
  EXPECT_EQ(e.stored, 0);
  EXPECT_EQ(anchor.x, 0.001);
  EXPECT_EQ(anchor.y, -0.002);
}

TEST(Platen, NormalForceIsPenaltyTimesPenetration) {
  Vec3 anchor{0.001, 0, 0};
  const real g = 3e-7;
  const PlatenEval e = platen_node_force({0.001, 0, -g}, up, k, mu, anchor);
  EXPECT_NEAR(e.force.z, k * g, 1e-12 * k * g);
  EXPECT_EQ(e.force.x, 0);
  EXPECT_NEAR(e.stored, 0.5 * k * g * g, 1e-12 * k * g * g);
}

TEST(Platen, StickingThenSlidingAtMuTimesNormalForce) {
  const real g = 1e-6, fn = k * g;
  Vec3 anchor{0, 0, 0};
  // Stick: a tangential offset below mu g.
  const real d = 0.5 * mu * g;
  PlatenEval e = platen_node_force({d, 0, -g}, up, k, mu, anchor);
  EXPECT_NEAR(e.force.x, -k * d, 1e-9 * k * d);
  EXPECT_EQ(e.dissipated, 0);
  EXPECT_NEAR(e.stored, 0.5 * k * (g * g + d * d), 1e-9 * e.stored);
  // Slide: an offset of 5 mu g in y; the force is capped at mu fn against the slip.
  const Vec3 x{0, 5 * mu * g, -g};
  anchor = {0, 0, 0};
  e = platen_node_force(x, up, k, mu, anchor);
  EXPECT_NEAR(std::hypot(e.force.x, e.force.y), mu * fn, 1e-12 * fn);
  EXPECT_LT(e.force.y, 0);
  EXPECT_NEAR(anchor.y, 5 * mu * g - mu * g, 1e-15);  // the stick point moved to the slip limit
  EXPECT_NEAR(e.dissipated, mu * fn * anchor.y, 1e-12 * mu * fn * g);
  // Holding the node there, the spring stays at the limit and nothing more slides.
  const Vec3 a_before = anchor;
  e = platen_node_force(x, up, k, mu, anchor);
  EXPECT_EQ(e.dissipated, 0);
  EXPECT_EQ(norm(anchor - a_before), 0);
}

TEST(Platen, TopPlatenPushesDown) {
  Vec3 anchor{0, 0, 0};
  const PlatenEval e = platen_node_force({0, 0, 2e-7}, {0, 0, -1}, k, mu, anchor);  // above the top plane
  EXPECT_NEAR(e.force.z, -k * 2e-7, 1e-12 * k * 2e-7);
}
