// A fracturing UCS run through its peak: CE6s break, the stress falls, the specimen
// dilates, and the energy balance still closes (work = stored + dissipated).
#include <gtest/gtest.h>

#include "io/mesh_io.hpp"
#include "support.hpp"

using namespace fdem;

TEST(FracturingUcs, PeakThenFailureWithTheEnergyBalanceClosed) {
  MeshSpec spec;
  spec.shape = MeshShape::cylinder;
  spec.diameter = 0.02;
  spec.height = 0.04;
  spec.element_size = 0.005;
  Scene scene = test::test_scene();
  scene.solver.mass_scaling = 5;
  scene.platens.velocity = 0.2;
  Solver s(scene, build_model(generate_mesh(spec), scene));
  Monitors peak, row;
  while (s.platen_travel() / s.model().height0 < 0.004) {
    s.step();
    if (s.step_count() % 100) continue;
    row = s.measure();
    if (row.axial_stress > peak.axial_stress) peak = row;
    if (peak.axial_stress > 0 && row.axial_stress < 0.5 * peak.axial_stress) break;
  }
  ASSERT_LT(row.axial_stress, 0.5 * peak.axial_stress) << "no failure by 0.4 % axial strain";
  EXPECT_GT(row.broken, 20);
  EXPECT_EQ(row.broken, row.broken_I + row.broken_II + row.broken_mixed);
  // The peak is a compressive failure: far above the tensile strength, and well past the
  // linear range: the secant modulus at the peak is below E.
  EXPECT_GT(peak.axial_stress, 5 * scene.material().tensile_strength);
  EXPECT_LT(peak.axial_stress / peak.axial_strain, scene.material().youngs_modulus);
  // Dilation after the peak: the lateral strain (compression positive) is negative and its
  // magnitude has grown past the elastic nu * axial strain.
  EXPECT_LT(row.lateral_strain, -scene.material().poisson_ratio * 0.5 * row.axial_strain);
  EXPECT_GT(row.cohesive_dissipated, 0);
  EXPECT_LT(row.energy_error, 0.01) << "external " << row.external_work << " J";
  RecordProperty("peak_MPa", std::to_string(peak.axial_stress / 1e6));
  RecordProperty("broken", std::to_string(row.broken));
  RecordProperty("energy_error", std::to_string(row.energy_error));
}
