// Elastic loading of a small cylinder between platens: effective modulus against E
// (and its dependence on the CE6 penalty, the reference paper's Fig. 5 trend), the
// energy balance, and mass scaling with critical damping.
#include <gtest/gtest.h>

#include <cmath>

#include "io/mesh_io.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

const Mesh& cylinder() {
  static const Mesh mesh = [] {
    MeshSpec spec;
    spec.shape = MeshShape::cylinder;
    spec.diameter = 0.02;
    spec.height = 0.04;
    spec.element_size = 0.005;
    return generate_mesh(spec);
  }();
  return mesh;
}

/// An elastic UCS scene: strengths raised far above the stresses reached, frictionless platens
/// (uniaxial stress, so the slope is E itself).
Scene elastic_scene(real penalty_factor, real mass_scaling) {
  Scene s = test::test_scene();
  Material& m = s.material();
  m.tensile_strength = m.cohesion = 1e9;
  m.fracture_energy_I = m.fracture_energy_II = 1e6;
  m.friction_platen = 0;
  m.cohesive_penalty_open = m.cohesive_penalty_tangential = penalty_factor * m.youngs_modulus;
  m.cohesive_penalty_overlap = 10 * penalty_factor * m.youngs_modulus;
  s.platens.velocity = 0.05;
  s.solver.mass_scaling = mass_scaling;
  return s;
}

real measured_modulus(const Scene& scene, std::vector<Monitors>* rows_out = nullptr) {
  Solver s(scene, build_model(cylinder(), scene));
  const std::vector<Monitors> rows = test::load_to_strain(s, 3e-4, 20);
  if (rows_out) *rows_out = rows;
  return test::secant_modulus(rows, 1e-4, 3e-4);
}

}  // namespace

TEST(ElasticUcs, ModulusWithinThreePercentOfEAtHundredE) {
  const Scene scene = elastic_scene(100, 5);
  const real E = measured_modulus(scene);
  EXPECT_NEAR(E / scene.material().youngs_modulus, 1.0, 0.03) << "effective modulus " << E / 1e9 << " GPa";
  RecordProperty("effective_modulus_GPa", std::to_string(E / 1e9));
}

TEST(ElasticUcs, SoftCohesivePenaltyIsVisiblyMoreCompliant) {
  const Scene stiff = elastic_scene(100, 5), soft = elastic_scene(1, 5);
  const real E100 = measured_modulus(stiff), E1 = measured_modulus(soft);
  EXPECT_LT(E1, 0.8 * E100) << "1 E: " << E1 / 1e9 << " GPa, 100 E: " << E100 / 1e9 << " GPa";
  RecordProperty("modulus_1E_GPa", std::to_string(E1 / 1e9));
}

TEST(ElasticUcs, MassScalingFiveGivesTheSameQuasiStaticModulus) {
  const real E1 = measured_modulus(elastic_scene(100, 1));
  const real E5 = measured_modulus(elastic_scene(100, 5));
  EXPECT_NEAR(E5 / E1, 1.0, 0.02) << "m = 1: " << E1 / 1e9 << " GPa, m = 5: " << E5 / 1e9 << " GPa";
  RecordProperty("modulus_m1_GPa", std::to_string(E1 / 1e9));
  RecordProperty("modulus_m5_GPa", std::to_string(E5 / 1e9));
}

TEST(ElasticUcs, EnergyBalanceErrorBelowOnePercentOfExternalWork) {
  std::vector<Monitors> rows;
  measured_modulus(elastic_scene(100, 5), &rows);
  const Monitors& last = rows.back();
  ASSERT_GT(last.external_work, 0);
  EXPECT_LT(last.energy_error, 0.01) << "external " << last.external_work << " J, strain " << last.strain
                                     << " J, kinetic " << last.kinetic << " J, viscous " << last.viscous << " J";
  // Quasi-static: the work went mostly into strain energy, not motion.
  EXPECT_LT(last.kinetic, 0.05 * last.external_work);
  EXPECT_EQ(last.broken, 0);
  RecordProperty("energy_error", std::to_string(last.energy_error));
}
