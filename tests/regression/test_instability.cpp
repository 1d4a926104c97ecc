// A time step above the stable one is detected and stopped with a clear message.
#include <gtest/gtest.h>

#include "core/error.hpp"
#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

TEST(Instability, TooLargeTimeStepStopsWithAMessageNamingTheFix) {
  Scene scene = test::test_scene();
  scene.solver.time_step_safety = 4.0;  // four times the stable-step bound
  scene.platens.velocity = 0.5;
  Solver s(scene, build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene));
  std::string message;
  long steps = 0;
  try {
    for (; steps < 200000; ++steps) {
      s.step();
      if (s.step_count() % 10 == 0) s.measure();
    }
  } catch (const RunError& e) {
    message = e.what();
  }
  ASSERT_FALSE(message.empty()) << "ran " << steps << " steps without being stopped";
  EXPECT_NE(message.find("time_step_safety"), std::string::npos) << message;
  EXPECT_NE(message.find("unstable"), std::string::npos) << message;
  // Every node position is still finite: the run was stopped before NaN spread.
  for (const Vec3& x : s.state.x) ASSERT_TRUE(std::isfinite(x.x) && std::isfinite(x.y) && std::isfinite(x.z));
}

TEST(Instability, StableStepRunsWithoutBeingStopped) {
  Scene scene = test::test_scene();
  scene.solver.time_step_safety = 0.9;
  scene.platens.velocity = 0.5;
  Solver s(scene, build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene));
  for (int i = 0; i < 3000; ++i) {
    s.step();
    if (s.step_count() % 10 == 0) s.measure();
  }
  EXPECT_GT(s.measure().axial_stress, 0);
}
