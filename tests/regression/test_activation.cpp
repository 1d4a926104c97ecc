// Adaptive against full contact activation on a small fracturing UCS run: the same peak
// stress (within 2 %) and broken-CE6 count (within 5 %), with fewer pairs checked by the
// adaptive run; flags start at the platens and never clear.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "io/mesh_io.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

struct Outcome {
  real peak = 0;
  long broken = 0;
  double pair_steps = 0;  // candidate pairs summed over the monitor rows
  long active_start = 0, active_end = 0;
};

Outcome run(const std::string& activation) {
  MeshSpec spec;
  spec.shape = MeshShape::cylinder;
  spec.diameter = 0.02;
  spec.height = 0.04;
  spec.element_size = 0.008;  // 160 tets: full activation stays affordable in CI
  Scene scene = test::test_scene();
  scene.solver.mass_scaling = 5;
  scene.platens.velocity = 0.2;
  scene.contact.activation = test::named<Activation>(activation);
  Solver s(scene, build_model(generate_mesh(spec), scene));
  Outcome o;
  Monitors row = s.measure();
  o.active_start = row.active_tets;
  long last_active = row.active_tets;
  if (activation == "adaptive") {
    // From the start: exactly the tets with a node on a loaded end.
    const Model& m = s.model();
    std::vector<char> end_node(m.X.size(), 0);
    for (int n : m.top_nodes) end_node[n] = 1;
    for (int n : m.bottom_nodes) end_node[n] = 1;
    long at_ends = 0;
    for (const auto& q : m.tet_nodes) at_ends += end_node[q[0]] || end_node[q[1]] || end_node[q[2]] || end_node[q[3]];
    EXPECT_EQ(row.active_tets, at_ends);
  }
  while (s.platen_travel() / s.model().height0 < 0.006) {
    s.step();
    if (s.step_count() % 50) continue;
    row = s.measure();
    EXPECT_GE(row.active_tets, last_active) << "an activation flag cleared";
    last_active = row.active_tets;
    o.pair_steps += row.contact_pairs;
    o.peak = std::max(o.peak, row.axial_stress);
    if (row.axial_stress < 0.5 * o.peak) break;
  }
  EXPECT_LT(row.axial_stress, 0.5 * o.peak) << activation << ": no failure by 0.6 % axial strain";
  o.broken = row.broken;
  o.active_end = row.active_tets;
  EXPECT_LT(row.energy_error, 0.01) << activation;
  return o;
}

}  // namespace

TEST(Activation, AdaptiveMatchesFullWithFewerPairs) {
  const Outcome adaptive = run("adaptive"), full = run("full");
  ASSERT_GT(full.broken, 10) << "the run must fracture for the comparison to mean anything";
  EXPECT_NEAR(adaptive.peak, full.peak, 0.02 * full.peak);
  EXPECT_NEAR(adaptive.broken, full.broken, 0.05 * full.broken);
  EXPECT_LT(adaptive.pair_steps, 0.7 * full.pair_steps);
  EXPECT_LT(adaptive.active_start, full.active_start);
  EXPECT_GT(adaptive.active_end, adaptive.active_start) << "broken CE6s activate their vicinity";
  EXPECT_EQ(full.active_start, full.active_end);
  RecordProperty("peak_ratio", std::to_string(adaptive.peak / full.peak));
  RecordProperty("broken_adaptive", std::to_string(adaptive.broken));
  RecordProperty("broken_full", std::to_string(full.broken));
  RecordProperty("pair_ratio", std::to_string(adaptive.pair_steps / full.pair_steps));
}
