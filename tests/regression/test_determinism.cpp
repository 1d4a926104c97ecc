// The cpu backend's result does not depend on the thread count: colour classes fix the
// order of every addition into node forces. Checked bit for bit through fracture.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstring>
#include <memory>

#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

std::unique_ptr<Solver> run_steps(int threads, int steps) {
  Scene scene = test::test_scene();
  scene.solver.threads = threads;
  scene.platens.velocity = 2.0;  // fast, so CE6s damage and break within the run
  scene.material().tensile_strength = 0.3e6;
  scene.material().cohesion = 1.0e6;
  // Violent on purpose; contact puts about 15 % of the work in by step 6000 (docs/stability.md),
  // which the energy watch would stop. This test is about the thread count only.
  scene.solver.max_energy_error = 0;
  auto s = std::make_unique<Solver>(scene, build_model(structured_box_mesh({0.006, 0.006, 0.012}, 3, 3, 6), scene));
  for (int i = 0; i < steps; ++i) s->step();
  s->sync_host();
  return s;
}

}  // namespace

TEST(Determinism, OneAndTwoThreadsGiveBitIdenticalStates) {
  const int steps = 6000;
  const auto pa = run_steps(1, steps);
  const auto pb = run_steps(2, steps);
  Solver &a = *pa, &b = *pb;
  omp_set_num_threads(omp_get_num_procs());
  ASSERT_EQ(a.state.x.size(), b.state.x.size());
  EXPECT_EQ(std::memcmp(a.state.x.data(), b.state.x.data(), a.state.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.state.v.data(), b.state.v.data(), a.state.v.size() * sizeof(Vec3)), 0);
  long damaged = 0;
  for (std::size_t i = 0; i < a.state.ce6.size(); ++i) {
    EXPECT_EQ(a.state.ce6[i].mode, b.state.ce6[i].mode);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(a.state.ce6[i].D[k], b.state.ce6[i].D[k]);
    damaged += ce6_max_damage(a.state.ce6[i]) > 0;
  }
  EXPECT_GT(damaged, 0) << "the run should reach damage for the check to cover the CE6 law";
  RecordProperty("damaged_ce6", std::to_string(damaged));
  RecordProperty("broken_ce6", std::to_string(a.measure().broken));
}
