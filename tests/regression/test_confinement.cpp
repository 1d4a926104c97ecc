// Confining pressure, a follower load on the lateral surface: an intact elastic cylinder
// under lateral pressure alone shrinks radially by the analytic p (1 - nu) / E; on the
// hydrostatic path the pressure follows the axial stress up to sigma_3 and is then held,
// and while it follows, the compression is isotropic (lateral strain = axial strain).
#include <gtest/gtest.h>

#include <cmath>

#include "io/mesh_io.hpp"
#include "support.hpp"

using namespace fdem;

TEST(Confinement, LateralPressureGivesTheAnalyticRadialStrain) {
  // Ends free (no platens), pressure p on the curved surface: plane stress in r-theta with
  // sigma_r = sigma_theta = -p, sigma_z = 0, so the radial strain is -p (1 - nu) / E
  // (reported compression positive). Continuous mesh (no CE6): the TET4 response alone.
  Scene scene = test::test_scene();
  scene.fracture.everywhere = false;
  scene.platens.enabled = false;
  scene.contact.activation = Activation::none;
  scene.confinement.enabled = true;
  scene.confinement.path = ConfinementPath::constant;
  scene.confinement.pressure = 5e6;
  scene.solver.mass_scaling = 10;
  Solver s(scene, build_model(generate_mesh(test::cylinder(0.02, 0.04, 0.003)), scene));
  // Ramp over the automatic 10 transits, then hold as long again for the vibration to settle.
  const real c = std::sqrt((scene.material().lame_lambda() + 2 * scene.material().lame_mu()) /
                           (scene.solver.mass_scaling * scene.material().density));
  const real ramp = 10 * s.model().height0 / c;
  Monitors row;
  while (s.time() < 3 * ramp) s.step();
  row = s.measure();
  EXPECT_DOUBLE_EQ(row.confining_pressure, 5e6);
  const Material& mat = scene.material();
  const real expect = 5e6 * (1 - mat.poisson_ratio) / mat.youngs_modulus;
  EXPECT_NEAR(row.lateral_strain, expect, 0.02 * expect) << "measured " << row.lateral_strain;
  EXPECT_LT(row.energy_error, 0.01);
  RecordProperty("radial_strain_ratio", std::to_string(row.lateral_strain / expect));
}

TEST(Confinement, HydrostaticPathThenHeldWhileTheAxialLoadGrows) {
  Scene scene = test::test_scene();
  scene.fracture.everywhere = false;
  scene.contact.activation = Activation::none;
  scene.material().friction_platen = 0;  // no end restraint: the hydrostatic stage is uniform
  scene.confinement.enabled = true;
  scene.confinement.path = ConfinementPath::hydrostatic;
  scene.confinement.pressure = 2e6;
  scene.solver.mass_scaling = 10;
  scene.platens.velocity = 0.1;
  Solver s(scene, build_model(generate_mesh(test::cylinder(0.02, 0.04, 0.003)), scene));
  bool held = false;
  int hydro_rows = 0;
  Monitors row;
  while (s.platen_travel() / s.model().height0 < 6e-4) {
    s.step();
    if (s.step_count() % 50) continue;
    row = s.measure();
    const real p = row.confining_pressure, axial = row.axial_stress;
    if (axial < 0.5 * 2e6) continue;  // the start of the ramp is dynamic
    if (axial < 0.98 * 2e6) {
      // Following the axial stress (hydrostatic): p = axial, and the strain is isotropic.
      EXPECT_NEAR(p, axial, 0.02 * axial);
      EXPECT_NEAR(row.lateral_strain, row.axial_strain, 0.05 * row.axial_strain)
          << "isotropic compression expected at axial stress " << axial;
      ++hydro_rows;
    } else if (axial > 1.02 * 2e6) {
      EXPECT_NEAR(p, 2e6, 1e-9 * 2e6);  // held at sigma_3
      held = true;
    }
  }
  EXPECT_GT(hydro_rows, 3);
  EXPECT_TRUE(held) << "the axial stress never passed sigma_3";
  // Triaxial stage: the axial stress keeps growing beyond sigma_3 with the confinement held.
  EXPECT_GT(row.axial_stress, 3e6);
  EXPECT_LT(row.energy_error, 0.01);
}
