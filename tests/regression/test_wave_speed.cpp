// P-wave speed in a laterally constrained bar of tets: sqrt((lambda + 2 mu) / rho).
#include <gtest/gtest.h>

#include <cmath>

#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// Position along the bar's axis line (y = z = 0) where the x-velocity falls through half
/// the driving speed, interpolated between the two nodes either side.
real front_position(const Solver& s, real v0) {
  const Model& m = s.model();
  real x_above = 0, v_above = v0, x_below = 1e30, v_below = 0;
  for (std::size_t n = 0; n < s.state.x.size(); ++n)
    if (m.X[n].y == 0 && m.X[n].z == 0 && s.state.v[n].x > 0.5 * v0 && m.X[n].x >= x_above)
      x_above = m.X[n].x, v_above = s.state.v[n].x;
  for (std::size_t n = 0; n < s.state.x.size(); ++n)
    if (m.X[n].y == 0 && m.X[n].z == 0 && m.X[n].x > x_above && m.X[n].x < x_below)
      x_below = m.X[n].x, v_below = s.state.v[n].x;
  return x_above + (x_below - x_above) * (v_above - 0.5 * v0) / (v_above - v_below);
}

}  // namespace

TEST(WaveSpeed, PWaveInConstrainedBarMatchesTheory) {
  const real L = 0.2;
  Scene scene = test::test_scene();
  scene.fracture.everywhere = false;  // a continuous bar: no cohesive elements
  scene.platens.enabled = false;
  scene.solver.damping_scale = 0;
  scene.solver.time_step_safety = 0.5;
  const Mesh mesh = structured_box_mesh({L, 0.005, 0.005}, 160, 2, 2);
  Solver s(scene, build_model(mesh, scene));
  ASSERT_EQ(s.model().ce6_nodes.size(), 0u);
  const real v0 = 0.01;  // m/s
  for (std::size_t n = 0; n < s.state.x.size(); ++n) {
    const bool end = s.model().X[n].x == 0;
    s.prescribe(int(n), end ? 7 : 6, {end ? v0 : 0, 0, 0});  // uniaxial strain: lateral motion blocked
  }
  const Material& mat = scene.material();
  const real c = std::sqrt((mat.lame_lambda() + 2 * mat.lame_mu()) / mat.density);
  auto run_until = [&](real t) {
    while (s.time() < t) s.step();
    return std::make_pair(s.time(), front_position(s, v0));
  };
  const auto [t1, x1] = run_until(0.25 * L / c);
  const auto [t2, x2] = run_until(0.75 * L / c);
  const real measured = (x2 - x1) / (t2 - t1);
  EXPECT_NEAR(measured / c, 1.0, 0.02) << "measured " << measured << " m/s, theory " << c << " m/s";
  RecordProperty("measured_over_theory", std::to_string(measured / c));
}
