// Several materials on volume groups (scene `materials`, `interfaces`): each tet's density and
// elasticity, each CE6's law between two materials. Closed-form answers for two layers in series,
// an interface that breaks at its own strength and dissipates its fracture energy, the tables
// against the one-material run on every schedule and the debug backend, and the errors a scene
// gets for materials that do not fit its mesh.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "backend_support.hpp"
#include "cli_support.hpp"
#include "core/error.hpp"
#include "model/laws.hpp"
#include "model/materials.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// The box on rollers at xmin, ymin and zmin, its top end moved by `top` (a velocity condition's
/// value and time function); `rock`: the material keys, `fracture`: the regions.
std::string layered_scene(const std::string& rock, const std::string& top, const std::string& fracture = "none",
                          const std::string& backend = "cpu", const std::string& end = "time: 3e-4") {
  test::RollerBox b;
  b.rock = rock, b.top = top, b.fracture = fracture, b.backend = backend, b.end = end;
  return test::roller_box_scene(b);
}

/// The top pressed down 3 um along a table, then at rest (the roller box's own).
const std::string kPressed = test::RollerBox{}.top;

/// A soft layer under a stiff, dense one, both of Poisson's ratio 0: under uniaxial stress
/// neither layer widens, so the interface carries no shear and the state is exact for TET4s.
const char* const kTwoLayers =
    "materials:\n"
    "  - {name: soft, groups: [lower], poisson_ratio: 0}\n"
    "  - {name: stiff, groups: [upper], youngs_modulus: 36.6e9, density: 2700, poisson_ratio: 0}\n";

std::unique_ptr<Solver> layered_solver(const Scene& s) {
  return std::make_unique<Solver>(s, build_model(test::layered_box(), s));
}

/// The InputError text of building the layered box model with scene text `yaml`, or "".
std::string model_error(const std::string& yaml, const Mesh& mesh = test::layered_box()) {
  return test::build_error(yaml, "rock.yaml", mesh);
}

}  // namespace

TEST(Materials, TwoLayersInSeriesCarryTheSeriesStiffnessAtRest) {
  // Uniaxial stress through two layers of 10 mm: at rest the end force is A d / (L1/E1 + L2/E2)
  // and the interface plane has moved F L1 / (E1 A), the soft layer's share of the 3 um.
  const Scene scene = parse_scene(layered_scene(kTwoLayers, kPressed), "rock.yaml");
  auto s = layered_solver(scene);
  const Model& m = s->model();
  real mass = 0;
  for (real mn : m.mass) mass += mn;
  EXPECT_NEAR(mass, (1800 + 2700) * 1e-6, 1e-12) << "each layer's density times its volume";
  while (s->time() < 3e-4) s->step();
  const Monitors r = s->measure();
  const real E1 = scene.materials[0].youngs_modulus, E2 = scene.materials[1].youngs_modulus, A = 1e-4;
  const real d = 0.05 * (1e-5 + 4e-5 + 1e-5), force = A * d / (0.01 / E1 + 0.01 / E2);
  RecordProperty("series_force_ratio", std::to_string(-r.conditions[4 * 3 + 2] / force));
  EXPECT_NEAR(r.conditions[4 * 2 + 2], force, 1e-3 * force) << "the rollers at zmin push up";
  EXPECT_NEAR(r.conditions[4 * 3 + 2], -force, 1e-3 * force) << "the pressed end pushes down";
  const real u_mid = -force * 0.01 / (E1 * A);
  int at_mid = 0;
  real worst_mid = 0;
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (std::fabs(m.X[n].z - 0.01) < 1e-9) {
      EXPECT_NEAR(s->state.x[n].z - m.X[n].z, u_mid, 2e-3 * std::fabs(u_mid)) << "node " << n;
      worst_mid = std::max(worst_mid, std::fabs((s->state.x[n].z - m.X[n].z) / u_mid - 1));
      ++at_mid;
    }
  EXPECT_EQ(at_mid, 25);
  RecordProperty("interface_displacement_worst_error", std::to_string(worst_mid));
  EXPECT_NEAR(r.strain, 0.5 * force * d, 1e-3 * 0.5 * force * d);
  EXPECT_LT(r.kinetic, 1e-9 * r.strain) << "at rest";
}

TEST(Materials, IdenticalMaterialsGiveTheOneMaterialRunOnEverySchedule) {
  // Two materials with the same values take the tables' path (a byte per tet and per CE6), one
  // material the single law's: the same arithmetic, so the same run, on the colour passes and
  // the fused pass, on the cpu and the debug backends.
  const std::string two = "materials: [{name: a, groups: [lower]}, {name: b}]\n";
  auto run = [&](const std::string& rock, const std::string& backend, const char* schedule) {
    test::EnvSetting env("FDEM_DEVICE_SCHEDULE", schedule);
    auto s = layered_solver(parse_scene(layered_scene(rock, kPressed, "all", backend), "rock.yaml"));
    for (int k = 0; k < 1500; ++k) s->step();
    s->sync_host();
    return std::make_pair(s->state.x, s->measure());
  };
  const auto [x, row] = run("", "cpu", "colour");
  EXPECT_GT(std::fabs(row.conditions[4 * 3 + 2]), 1) << "the end is loaded by step 1500";
  for (const char* schedule : {"colour", "fused"})
    for (const char* backend : {"cpu", "debug"}) {
      SCOPED_TRACE(std::string(backend) + ", " + schedule);
      const auto [y, other] = run(two, backend, schedule);
      EXPECT_LT(test::largest_distance(x, y), 1e-18) << "m";
      EXPECT_NEAR(row.strain, other.strain, 1e-9 * row.strain);
      EXPECT_NEAR(row.cohesive_stored, other.cohesive_stored, 1e-9 * row.cohesive_stored);
    }
}

TEST(Materials, AWeakInterfaceBreaksAloneAndDissipatesItsFractureEnergy) {
  // Two strong layers joined by an interface of 1 MPa and G_I = 5 J/m^2, pulled apart: only the
  // 32 CE6s of the mid-plane break, in mode I, and the cohesive dissipation is G_I times the
  // 1e-4 m^2 of the plane. Without the interface entry the weaker layer's law would hold there.
  const std::string rock =
      "materials:\n"
      "  - {name: lower, groups: [lower], tensile_strength: 20e6, cohesion: 40e6}\n"
      "  - {name: upper, groups: [upper], tensile_strength: 25e6, cohesion: 40e6}\n"
      "interfaces:\n"
      "  - {between: [lower, upper], tensile_strength: 1e6, fracture_energy_I: 5}\n";
  const std::string pull = "velocity: [~, ~, 0.5], time_function: {shape: smooth, duration: 1e-5}";
  const Scene scene = parse_scene(layered_scene(rock, pull, "all", "cpu", "time: 6e-5"), "rock.yaml");
  auto s = layered_solver(scene);
  const Model& m = s->model();
  long interface_ce6 = 0;
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    const auto& ab = m.ce6_tets[c];
    const bool across = m.tet_material[ab[0]] != m.tet_material[ab[1]];
    EXPECT_EQ(m.ce6_law[c], across ? 2 : m.tet_material[ab[0]]) << "CE6 " << c;
    interface_ce6 += across;
  }
  ASSERT_EQ(interface_ce6, 32) << "4 x 4 cells, two triangles each";
  while (s->time() < 6e-5) s->step();
  const Monitors r = s->measure();
  EXPECT_EQ(r.broken, 32);
  EXPECT_EQ(r.broken_I, 32);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c)
    if (s->state.ce6.damage[c].mode != 0) {
      EXPECT_EQ(m.ce6_law[c], 2) << "CE6 " << c << " broke off the interface";
    }
  const real G = 5 * 1e-4;
  RecordProperty("dissipated_over_GA", std::to_string(r.cohesive_dissipated / G));
  RecordProperty("energy_error", std::to_string(r.energy_error));
  EXPECT_NEAR(r.cohesive_dissipated, G, 0.02 * G);
  EXPECT_LT(r.energy_error, 0.01);
}

TEST(Materials, ACe6BetweenTwoMaterialsTakesTheWeakerLawWithoutAnInterface) {
  const std::string rock =
      "materials:\n"
      "  - {name: strong, groups: [lower], tensile_strength: 5e6}\n"
      "  - {name: weak, groups: [upper], tensile_strength: 2e6}\n";
  const Scene scene = parse_scene(layered_scene(rock, kPressed, "all"), "rock.yaml");
  const Model m = build_model(test::layered_box(), scene);
  const ElementLaws laws = make_element_laws(scene);
  ASSERT_EQ(laws.ce6.size(), 2u);
  EXPECT_EQ(laws.ce6[1].ft, 2e6);
  long across = 0;
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c)
    if (m.tet_material[m.ce6_tets[c][0]] != m.tet_material[m.ce6_tets[c][1]]) {
      EXPECT_EQ(m.ce6_law[c], 1) << "the weak material's law";
      ++across;
    }
  EXPECT_EQ(across, 32);
  EXPECT_EQ(ce6_law_between(scene, 0, 0), 0);
  ASSERT_EQ(m.tet_group.size(), m.tet_nodes.size()) << "each tet's volume group, for ParaView";
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    real z = 0;
    for (int n : m.tet_nodes[t]) z += 0.25 * m.X[n].z;
    EXPECT_EQ(m.tet_group[t], z < 0.01 ? 1 : 2) << "tet " << t;
  }
  const std::string listing = describe_materials(scene, m, "");
  EXPECT_TRUE(cli_test::has(listing, "material 'strong' (volume groups lower): 384 tets")) << listing;
  EXPECT_TRUE(cli_test::has(listing, "material 'weak' (volume groups upper): 384 tets")) << listing;
}

TEST(Materials, MaterialsThatDoNotFitTheMeshAreRefusedWithTheFix) {
  auto build = [](const std::string& rock) { return model_error(layered_scene(rock, kPressed)); };
  std::string e = build("materials: [{name: a, groups: [lower]}, {name: b, groups: [middle]}]\n");
  EXPECT_TRUE(cli_test::has(e, "rock.yaml: materials[1] ('b').groups: the mesh")) << e;
  EXPECT_TRUE(cli_test::has(e, "has no group 'middle'; its volume groups: lower, upper")) << e;
  e = build("materials: [{name: a, groups: [lower]}, {name: b, groups: [zmax]}]\n");
  EXPECT_TRUE(cli_test::has(e, "'zmax' is a surface, and a material fills volumes")) << e;
  e = build("materials: [{name: a, groups: [lower]}, {name: b, groups: [lower, upper]}]\n");
  EXPECT_TRUE(cli_test::has(e, "is in group 'lower' and also in a group of materials[0] ('a')")) << e;
  e = build("materials: [{name: a, groups: [lower]}]\n");
  EXPECT_TRUE(cli_test::has(e, "is in no material's volume groups; give its group to a material")) << e;
  e = build("materials: [{name: a, groups: [lower, upper]}, {name: rest}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[1] ('rest'): no tet is made of it")) << e;
  // By gmsh tag where the group has no name.
  Mesh tagged = test::layered_box();
  tagged.groups[1].name = "";
  EXPECT_EQ(
      model_error(layered_scene("materials: [{name: a, groups: [lower]}, {name: b, groups: [2]}]\n", kPressed), tagged),
      "");
}

TEST(Materials, TheSceneKeysAreCheckedWithTheFix) {
  auto error_of = [](const std::string& rock) { return model_error(layered_scene(rock, kPressed)); };
  std::string e = error_of("material: {density: 2000}\nmaterials: [{name: a}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials: given with material")) << e;
  e = error_of("interfaces: [{between: [a, b]}]\n");
  EXPECT_TRUE(cli_test::has(e, "interfaces: given without materials")) << e;
  e = error_of("materials: [{name: a, groups: [lower]}, {name: a}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[1].name: 'a' names two materials")) << e;
  e = error_of("materials: [{name: a}, {name: b}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[1].groups: missing, and materials[0] has none either")) << e;
  e = error_of("materials: [{groups: [lower]}, {name: b}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[0].name: missing")) << e;
  e = error_of("materials: [{name: a, groups: [lower], density: -1}, {name: b}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[0].density: -1 is out of range")) << e;
  e = error_of("materials: [{name: a, groups: [lower], contact_penalty: 1e9}, {name: b}]\n");
  EXPECT_TRUE(cli_test::has(e, "materials[1].contact_penalty: differs from materials[0]'s")) << e;
  e = error_of("materials: [{name: a, groups: [lower]}, {name: b}]\ninterfaces: [{between: [a, c]}]\n");
  EXPECT_TRUE(cli_test::has(e, "interfaces[0].between[1]: 'c' is not a material; the materials: a, b")) << e;
  e = error_of("materials: [{name: a, groups: [lower]}, {name: b}]\ninterfaces: [{between: [a, b], density: 1}]\n");
  EXPECT_TRUE(cli_test::has(e, "interfaces[0].density: unknown key")) << e;
  e = error_of(
      "materials: [{name: a, groups: [lower]}, {name: b}]\n"
      "interfaces: [{between: [a, b], fracture_energy_I: 1e-6}]\n");
  EXPECT_TRUE(cli_test::has(e, "interfaces[0].fracture_energy_I: 1e-06 J/m^2 is too small")) << e;
  // An interface's keys not given are the weaker material's.
  const Scene s = parse_scene(layered_scene("materials:\n"
                                            "  - {name: a, groups: [lower], tensile_strength: 3e6, cohesion: 9e6}\n"
                                            "  - {name: b, tensile_strength: 2e6, cohesion: 8e6}\n"
                                            "interfaces: [{between: [b, a], tensile_strength: 1e6}]\n",
                                            kPressed),
                              "rock.yaml");
  ASSERT_EQ(s.interfaces.size(), 1u);
  EXPECT_EQ(s.interfaces[0].law.tensile_strength, 1e6);
  EXPECT_EQ(s.interfaces[0].law.cohesion, 8e6);
}
