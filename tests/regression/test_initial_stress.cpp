// In-situ stress (scene `initial_stress`): a rock that starts in the stress it is given stays at
// rest in it, uniform or geostatic under gravity, with every CE6 carrying its share intact; the
// device loop's schedules agree once it moves; the errors a scene gets where the stress cannot be
// held or does not balance gravity.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <utility>

#include "core/error.hpp"
#include "core/format.hpp"
#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// A box of the given size (m), 4 x 4 x 8 cells, CE6s on every internal face, no contact, with
/// rollers on the faces listed, the in-situ stress `in_situ` and `more` top-level keys.
std::string box_scene(const std::string& rollers, const std::string& in_situ, const std::string& more = "",
                      const std::string& backend = "cpu") {
  std::string conditions;
  std::string list = rollers;
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    conditions += "  - {surface: " + list.substr(0, comma) + ", type: roller}\n";
    list = comma == std::string::npos ? "" : list.substr(comma + 1);
  }
  return "name: in_situ_box\n"
         "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
         "platens: none\n"
         "contact: {activation: none}\n"
         "boundary_conditions:\n" +
         conditions + "initial_stress: " + in_situ + "\n" + more + "solver: {threads: 1, backend: " + backend +
         ", end: {time: 1}}\n"
         "output: {progress_interval: 0, plot: false}\n";
}

/// J, the elastic energy of the in-situ stress s in a volume V of linear rock (E, nu):
/// V (s:s (1 + nu) - nu tr(s)^2) / (2 E).
real in_situ_energy(const Sym3& s, real V, real E, real nu) {
  const real ss = s.xx * s.xx + s.yy * s.yy + s.zz * s.zz + 2 * (s.yz * s.yz + s.xz * s.xz + s.xy * s.xy);
  const real tr = s.xx + s.yy + s.zz;
  return V * ((1 + nu) * ss - nu * tr * tr) / (2 * E);
}

/// The largest kinetic energy over `steps` steps, J.
real largest_kinetic(Solver& solver, int steps) {
  real ke = 0;
  for (int i = 0; i < steps; ++i) {
    solver.step();
    if (i % 50 == 49) ke = std::max(ke, solver.measure().kinetic);
  }
  return ke;
}

/// The largest difference between each tet's stress and the prescribed field at its reference
/// centroid, over the field's largest component, Pa/Pa.
real largest_stress_error(Solver& solver, const InitialStress& field, real scale) {
  std::vector<Sym3> stress;
  std::vector<real> vm;
  solver.tet_stress(solver.state.x, solver.state.v, stress, vm);
  const Model& m = solver.model();
  real worst = 0;
  for (std::size_t t = 0; t < stress.size(); ++t) {
    Vec3 c{0, 0, 0};
    for (int n : m.tet_nodes[t]) c += real(0.25) * m.X[n];
    const Sym3 want = field.at(c), got = stress[t];
    const real d[6] = {got.xx - want.xx, got.yy - want.yy, got.zz - want.zz,
                       got.yz - want.yz, got.xz - want.xz, got.xy - want.xy};
    for (real x : d) worst = std::max(worst, std::fabs(x) / scale);
  }
  return worst;
}

std::string setup_error(const std::string& yaml, const Mesh& mesh) {
  try {
    const Scene s = parse_scene(yaml, "box.yaml");
    Solver solver(s, build_model(mesh, s));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(InitialStress, AnAnisotropicStressHeldByRollersStaysAtRest) {
  // Rollers on all six faces hold the principal stresses (along x, y, z) at rest. The CE6s on
  // the cells' diagonal faces carry shear in-situ tractions, on their own frames' offsets. The
  // second stress puts the faces normal to x in tension, on the inverted pre-peak curve.
  for (const char* stress : {"{xx: -9e6, yy: -3e6, zz: -6e6}", "{xx: 0.9e6, yy: -3e6, zz: -6e6}"}) {
    SCOPED_TRACE(stress);
    const Scene s =
        parse_scene(box_scene("xmin,xmax,ymin,ymax,zmin,zmax", std::string("{stress: ") + stress + "}"), "box.yaml");
    Solver solver(s, build_model(structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8), s));
    ASSERT_GT(solver.model().ce6_nodes.size(), 1000u);
    const real energy = in_situ_energy(s.initial_stress.stress, 0.01 * 0.01 * 0.02, 12.2e9, 0.25);
    const real ke = largest_kinetic(solver, 2000);
    const std::string tag = s.initial_stress.stress.xx > 0 ? "_tension" : "";
    RecordProperty("kinetic_over_in_situ_energy" + tag, fmt(ke / energy, 3));
    EXPECT_LT(ke, 1e-6 * energy) << "J";
    const real err = largest_stress_error(solver, s.initial_stress, 9e6);
    RecordProperty("stress_error" + tag, fmt(err, 3));
    EXPECT_LT(err, 1e-6);
    const Monitors r = solver.measure();
    EXPECT_EQ(r.damaged, 0);
    EXPECT_EQ(r.broken, 0);
    EXPECT_LT(std::fabs(r.strain), 1e-6 * energy) << "J: the in-situ state stores no strain energy of its own";
    EXPECT_LT(std::fabs(r.cohesive_stored), 1e-6 * energy) << "J: nor do the CE6s";
    EXPECT_LT(std::fabs(r.cohesive_dissipated), 1e-6 * energy) << "J";
  }
}

TEST(InitialStress, AFrictionalJointHoldsTheStressAcrossIt) {
  // The box's mid-plane a frictional joint, no contact: its CE6s hold the compression across it
  // on their overlap penalty. Tension across it, or shear beyond its friction, is refused, also
  // with contact (which would carry the faces).
  const std::string joints = "[{name: joint, surfaces: [joint], frictional: true, friction: 0.5}]\n";
  const std::string all = "xmin,xmax,ymin,ymax,zmin,zmax";
  const Scene s =
      parse_scene(box_scene(all, "{stress: {xx: -2e6, yy: -1e6, zz: -4e6}}", "joints: " + joints), "b.yaml");
  Solver solver(s, build_model(test::jointed_box(), s));
  ASSERT_EQ(solver.measure().joint_broken, 32);
  const real energy = in_situ_energy(s.initial_stress.stress, 0.01 * 0.01 * 0.02, 12.2e9, 0.25);
  const real ke = largest_kinetic(solver, 1000);
  RecordProperty("joint_kinetic_over_in_situ_energy", fmt(ke / energy, 3));
  EXPECT_LT(ke, 1e-6 * energy) << "J";
  EXPECT_LT(largest_stress_error(solver, s.initial_stress, 4e6), 1e-6);
  const std::string no_contact = "contact: {activation: none}\n";
  for (const bool contact : {false, true}) {
    SCOPED_TRACE(contact);
    const std::pair<const char*, const char*> cases[] = {
        {"{zz: 1e5}", "tension 1e+05 Pa across a frictional joint"},
        {"{zz: -1e6, xz: 0.6e6}", "shear traction 6e+05 Pa above the joint's friction 5e+05 Pa"}};
    for (const auto& [stress, want] : cases) {
      std::string scene = box_scene(all, std::string("{stress: ") + stress + "}", "joints: " + joints);
      if (contact) scene.replace(scene.find(no_contact), no_contact.size(), "contact: {activation: adaptive}\n");
      const std::string e = setup_error(scene, test::jointed_box());
      EXPECT_NE(e.find(want), std::string::npos) << e;
    }
  }
}

TEST(InitialStress, AGeostaticStressStaysAtRestUnderGravity) {
  // A 10 x 10 x 20 m column under its own weight: sigma_zz = -rho g (20 m - z), with unequal
  // horizontal ratios, rollers on the sides and the base, the top free. The field is linear, so
  // each tet's centroid value and the CE6s' three points give every node its exact share.
  Scene s = parse_scene(box_scene("xmin,xmax,ymin,ymax,zmin", "{geostatic: {surface_z: 20, k_x: 0.5, k_y: 1.5}}",
                                  "gravity: [0, 0, -9.81]\n"),
                        "box.yaml");
  Solver solver(s, build_model(structured_box_mesh({10, 10, 20}, 4, 4, 8), s));
  const real rho_g = 1800 * 9.81;
  EXPECT_NEAR(s.initial_stress.gradient.zz, -rho_g, 1e-9 * rho_g);
  EXPECT_NEAR(s.initial_stress.gradient.xx, -0.5 * rho_g, 1e-9 * rho_g);
  // The in-situ energy: the mean of sigma_zz^2 over the column's height, times the ratios' sum.
  const Sym3 bottom{-0.5 * rho_g * 20, -1.5 * rho_g * 20, -rho_g * 20, 0, 0, 0};
  const real energy = in_situ_energy(bottom, 10 * 10 * 20, 12.2e9, 0.25) / 3;
  const real ke = largest_kinetic(solver, 2000);
  RecordProperty("kinetic_over_in_situ_energy", fmt(ke / energy, 3));
  EXPECT_LT(ke, 1e-6 * energy) << "J";
  const real err = largest_stress_error(solver, s.initial_stress, rho_g * 20);
  RecordProperty("stress_error", fmt(err, 3));
  EXPECT_LT(err, 1e-6);
  EXPECT_EQ(solver.measure().damaged, 0);
}

TEST(InitialStress, BothSchedulesMoveTheSameWhereTheStressIsNotHeld) {
  // Rollers on three faces only: the free faces let the in-situ stress go, and the box expands.
  // The cpu backend's colour passes and the debug backend's fused pass give the same motion.
  unsetenv("FDEM_DEVICE_SCHEDULE");  // each backend's own schedule: cpu colours, debug fused
  const std::string in_situ = "{stress: {xx: -4e6, yy: -2e6, zz: -3e6, yz: 5e5, xz: -3e5, xy: 2e5}}";
  const Mesh mesh = structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8);
  const Scene a = parse_scene(box_scene("xmin,ymin,zmin", in_situ), "box.yaml");
  const Scene b = parse_scene(box_scene("xmin,ymin,zmin", in_situ, "", "debug"), "box.yaml");
  Solver cpu(a, build_model(mesh, a)), debug(b, build_model(mesh, b));
  for (int i = 0; i < 300; ++i) cpu.step(), debug.step();
  real moved = 0;
  for (std::size_t n = 0; n < cpu.state.x.size(); ++n) moved = std::max(moved, norm(cpu.state.x[n] - cpu.model().X[n]));
  EXPECT_GT(moved, 1e-7) << "m: the free faces released the stress";
  debug.sync_host();
  EXPECT_LT(test::largest_distance(cpu.state.x, debug.state.x), 1e-12 * moved);
  // The released stress's energy went into motion and damping: the balance holds against it.
  const Monitors r = cpu.measure();
  RecordProperty("energy_error", fmt(r.energy_error, 3));
  EXPECT_GT(r.kinetic, 0.0);
  EXPECT_LT(r.strain, 0.0) << "J: the rock gave up in-situ energy";
  EXPECT_LT(r.energy_error, 1e-3);
}

TEST(InitialStress, StressTheRockCannotHoldOrThatDoesNotBalanceGravityIsRefused) {
  const Mesh mesh = structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8);
  const std::string all = "xmin,xmax,ymin,ymax,zmin,zmax";
  // Tension beyond the CE6s' tensile strength (1.2 MPa).
  std::string e = setup_error(box_scene(all, "{stress: {xx: 2e6}}"), mesh);
  EXPECT_NE(e.find("initial_stress: the in-situ traction reaches the strength of"), std::string::npos) << e;
  EXPECT_NE(e.find("tensile strength 1.2e+06 Pa"), std::string::npos) << e;
  EXPECT_NE(e.find("Fix: lower the initial stress"), std::string::npos) << e;
  // Without CE6s the same stress is no error: the TET4s hold it.
  EXPECT_EQ(setup_error(box_scene(all, "{stress: {xx: 2e6}}", "fracture_regions: none\n"), mesh), "");
  // A gradient without gravity, and geostatic without gravity.
  e = setup_error(box_scene(all, "{stress: {zz: 0}, gradient: {zz: -2e4}}"), mesh);
  EXPECT_NE(e.find("initial_stress.gradient: its change with depth"), std::string::npos) << e;
  EXPECT_NE(e.find("give gradient {xz: 0, yz: 0, zz: 0}"), std::string::npos) << e;
  e = setup_error(box_scene(all, "{geostatic: {surface_z: 0.02}}"), mesh);
  EXPECT_NE(e.find("initial_stress.geostatic: needs gravity along -z"), std::string::npos) << e;
  // Mass scaling makes gravity weigh more than the geostatic stress holds.
  std::string scaled = box_scene(all, "{geostatic: {surface_z: 0.02}}", "gravity: [0, 0, -9.81]\n");
  scaled.replace(scaled.find("threads: 1"), 10, "threads: 1, mass_scaling: 5");
  e = setup_error(scaled, mesh);
  EXPECT_NE(e.find("with mass scaling 5"), std::string::npos) << e;
  // A ground surface below the rock's top, and both forms at once.
  e = setup_error(box_scene(all, "{geostatic: {surface_z: 0.01}}", "gravity: [0, 0, -9.81]\n"), mesh);
  EXPECT_NE(e.find("surface_z 0.01 m lies below the top of the rock, 0.02 m"), std::string::npos) << e;
  e = setup_error(box_scene(all, "{stress: {xx: 1}, geostatic: {surface_z: 0.02}}", "gravity: [0, 0, -9.81]\n"), mesh);
  EXPECT_NE(e.find("give the geostatic form or the tensor form, not both"), std::string::npos) << e;
}
