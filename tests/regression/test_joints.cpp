// Joint sets (scene `joints`): CE6s of a joint's own law on the faces of a surface group inside
// the rock, counted apart from the rock's. Closed-form answers: a joint that breaks alone at its
// own strength and dissipates its fracture energy, a block sliding on a frictional joint at
// a = g (sin psi - cos psi tan phi) and sticking below phi (through the joint's CE6s and
// through tet-tet contact), and the errors a scene gets for joints that do not fit its mesh.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "analysis/run_comparison.hpp"
#include "cli_support.hpp"
#include "core/error.hpp"
#include "io/mesh_io.hpp"
#include "model/joints.hpp"
#include "model/laws.hpp"
#include "model/materials.hpp"
#include "support.hpp"

using namespace fdem;
namespace fs = std::filesystem;

namespace {

/// The jointed box at rest under gravity g inclined by psi (degrees) from -z towards +x, its
/// bottom fixed: the upper layer rests on the joint. `joints`: the joints key's value, `contact`:
/// the activation.
std::string block_scene(real psi, const std::string& joints, const std::string& contact, const std::string& end) {
  const real g = 9.81, r = psi * M_PI / 180;
  return "name: sliding_block\n"
         "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
         "material: {friction_rock: 0.9}\n"
         "joints: " +
         joints +
         "\n"
         "fracture_regions: none\n"
         "platens: none\n"
         "contact: {activation: " +
         contact +
         "}\n"
         "gravity: [" +
         std::to_string(g * std::sin(r)) + ", 0, " + std::to_string(-g * std::cos(r)) +
         "]\n"
         "boundary_conditions: [{surface: zmin, type: fixed}]\n"
         "solver: {threads: 1, end: {" +
         end +
         "}}\n"
         "output: {progress_interval: 0, plot: false}\n";
}

/// The upper layer's mass-weighted mean velocity along x, m/s.
real upper_velocity(const Solver& s) {
  const Model& m = s.model();
  std::vector<char> upper(m.X.size(), 0);
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
    if (m.tet_material.size() &&
        m.X[m.tet_nodes[t][0]].z + m.X[m.tet_nodes[t][1]].z + m.X[m.tet_nodes[t][2]].z + m.X[m.tet_nodes[t][3]].z >
            0.04)
      for (int n : m.tet_nodes[t]) upper[n] = 1;
  real p = 0, mass = 0;
  for (std::size_t n = 0; n < m.X.size(); ++n)
    if (upper[n]) p += m.mass[n] * s.state.v[n].x, mass += m.mass[n];
  return p / mass;
}

/// The least-squares slope of the upper layer's velocity over [t0, t1] (s): its acceleration.
real upper_acceleration(Solver& s, real t0, real t1) {
  real n = 0, st = 0, sv = 0, stt = 0, stv = 0;
  while (s.time() < t1) {
    s.step();
    if (s.time() < t0 || s.step_count() % 20) continue;
    const real t = s.time(), v = upper_velocity(s);
    n += 1, st += t, sv += v, stt += t * t, stv += t * v;
  }
  return (n * stv - st * sv) / (n * stt - st * st);
}

std::string joint_error(const std::string& joints, const Mesh& mesh = test::jointed_box()) {
  return test::build_error(block_scene(30, joints, "none", "time: 1e-3"), "rock.yaml", mesh);
}

}  // namespace

TEST(Joints, AJointBreaksAloneAtItsOwnStrengthAndDissipatesItsFractureEnergy) {
  // A strong rock with no fracture region, and a joint of 1 MPa and G_I = 5 J/m^2 across its
  // mid-plane, pulled apart: the joint's 32 CE6s are the only ones, all break in mode I and
  // count as the joint's, and the cohesive dissipation is G_I times the 1e-4 m^2 of the plane.
  test::RollerBox b;
  b.rock =
      "material: {tensile_strength: 20e6, cohesion: 40e6}\n"
      "joints: [{name: bedding, surfaces: [joint], tensile_strength: 1e6, fracture_energy_I: 5}]\n";
  b.top = "velocity: [~, ~, 0.5], time_function: {shape: smooth, duration: 1e-5}";
  b.end = "time: 6e-5";
  const Scene scene = parse_scene(test::roller_box_scene(b), "rock.yaml");
  Solver s(scene, build_model(test::jointed_box(), scene));
  const Model& m = s.model();
  ASSERT_EQ(m.ce6_nodes.size(), 32u) << "4 x 4 cells, two triangles each";
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) EXPECT_EQ(m.ce6_law[c], joint_law(scene, 0));
  ASSERT_EQ(m.tet_joint.size(), m.tet_nodes.size());
  long beside = 0;
  for (std::uint8_t j : m.tet_joint) beside += j == 1;
  EXPECT_EQ(beside, 64) << "each CE6's two tets";
  const std::string listing = describe_joints(scene, m, "");
  EXPECT_TRUE(cli_test::has(listing, "joint 'bedding' (surfaces joint): 32 CE6s, cohesive, tensile strength 1e+06 Pa"))
      << listing;
  while (s.time() < 6e-5) s.step();
  const Monitors r = s.measure();
  EXPECT_EQ(r.joint_broken, 32);
  EXPECT_EQ(r.broken, 0) << "the rock's count leaves the joint out";
  EXPECT_EQ(r.broken_I + r.broken_II + r.broken_mixed, 0);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) EXPECT_EQ(s.state.ce6.damage[c].mode, 1) << "CE6 " << c;
  const real G = 5 * 1e-4;
  RecordProperty("dissipated_over_GA", std::to_string(r.cohesive_dissipated / G));
  EXPECT_NEAR(r.cohesive_dissipated, G, 0.02 * G);
  EXPECT_LT(r.energy_error, 0.01);
}

TEST(Joints, ABlockSlidesOnAFrictionalJointAtTheClosedFormAcceleration) {
  // The upper layer on a frictional joint of phi = 20 degrees under gravity inclined by 30:
  // a = g (sin 30 - cos 30 tan 20) = 1.813 m/s^2. The rock's own friction (0.9) would hold it,
  // so the joint's friction must be the one that acts: through its CE6s (no contact), and
  // through tet-tet contact by either law, which takes over a broken joint's faces. The joint's
  // faces coincide, and so do the side faces of the structured mesh's tets beside them.
  const real mu = std::tan(20 * M_PI / 180), psi = 30 * M_PI / 180;
  const real expected = 9.81 * (std::sin(psi) - std::cos(psi) * mu);
  const std::string joint =
      "[{name: bedding, surfaces: [joint], frictional: true, friction: " + std::to_string(mu) + "}]";
  for (const char* contact : {"none", "adaptive, law: munjiza", "adaptive, law: volume"}) {
    SCOPED_TRACE(contact);
    const Scene scene = parse_scene(block_scene(30, joint, contact, "time: 1e-3"), "rock.yaml");
    Solver s(scene, build_model(test::jointed_box(), scene));
    const Monitors start = s.measure();
    EXPECT_EQ(start.joint_broken, 32) << "a frictional joint is broken from the start";
    EXPECT_EQ(start.broken, 0);
    const real a = contact[0] == 'n' ? upper_acceleration(s, 0.25e-3, 1e-3) : upper_acceleration(s, 0.1e-3, 0.4e-3);
    RecordProperty(std::string("acceleration_over_closed_form_") + (contact[0] == 'n' ? "ce6" : contact + 15),
                   std::to_string(a / expected));
    EXPECT_NEAR(a, expected, 0.03 * expected) << "m/s^2";
    EXPECT_EQ(s.measure().broken, 0) << "no rock CE6 exists to break";
  }
}

TEST(Joints, ABlockSticksOnAFrictionalJointBelowItsFrictionAngle) {
  // Inclined by 15 degrees on the same joint of 20: the block stays. Without friction it would
  // gain g sin 15 = 2.54 m/s^2.
  const real mu = std::tan(20 * M_PI / 180), free = 9.81 * std::sin(15 * M_PI / 180);
  const std::string joint =
      "[{name: bedding, surfaces: [joint], frictional: true, friction: " + std::to_string(mu) + "}]";
  for (const char* contact : {"none", "adaptive, law: munjiza", "adaptive, law: volume"}) {
    SCOPED_TRACE(contact);
    const Scene scene = parse_scene(block_scene(15, joint, contact, "time: 1e-3"), "rock.yaml");
    Solver s(scene, build_model(test::jointed_box(), scene));
    const real a = contact[0] == 'n' ? upper_acceleration(s, 0.25e-3, 1e-3) : upper_acceleration(s, 0.1e-3, 0.4e-3);
    RecordProperty(std::string("acceleration_over_free_") + (contact[0] == 'n' ? "ce6" : contact + 15),
                   std::to_string(a / free));
    EXPECT_LT(std::fabs(a), 0.01 * free) << "m/s^2";
  }
}

TEST(Joints, TheReadySceneSlidesItsBlockDownTheDippingJoint) {
  // scenes/block_on_joint.yaml: the joint's 66 CE6s dip 30 degrees, and the base's reaction
  // (bc0's force, 4 columns from the first) gives the block's acceleration, m a = R + M g.
  Scene scene = load_scene(std::string(FDEM_SOURCE_DIR) + "/scenes/block_on_joint.yaml");
  scene.solver.threads = 1;
  Solver s(scene, build_model(load_mesh(scene.mesh), scene));
  const Model& m = s.model();
  ASSERT_EQ(m.ce6_nodes.size(), 66u);
  for (const auto& q : m.ce6_nodes) {
    const Vec3 n = cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
    EXPECT_NEAR(std::fabs(n.z) / norm(n), std::cos(M_PI / 6), 1e-9) << "a dip of 30 degrees";
  }
  const real block = 2700 * 5e-4, all = 2700 * 1.5e-3;
  while (s.time() < 4e-3) s.step();
  const Monitors r = s.measure();
  const Vec3 R{r.conditions[0], r.conditions[1], r.conditions[2]};
  const Vec3 a = (real(1) / block) * (R + all * scene.gravity);
  const real expected = 9.81 * (std::sin(M_PI / 6) - std::cos(M_PI / 6) * 0.364);
  RecordProperty("scene_acceleration_over_closed_form", std::to_string(norm(a) / expected));
  EXPECT_NEAR(norm(a), expected, 0.01 * expected) << "m/s^2";
  EXPECT_LT(a.z, 0) << "down the slope";
}

TEST(Joints, ListingsAndTheFracturePatternCountTheJointsApart) {
  // A named material beside a joint: the material's line counts its own CE6s (none here), the
  // joint's line the joint's. fdem study's set of broken CE6s holds the rock's rows only.
  const std::string joint = "[{name: bedding, surfaces: [joint], frictional: true}]";
  std::string text = block_scene(30, joint, "none", "time: 1e-3");
  text.replace(text.find("material: {friction_rock: 0.9}"), 30, "materials: [{name: granite}]");
  const Scene scene = parse_scene(text, "rock.yaml");
  const Model m = build_model(test::jointed_box(), scene);
  const std::string listing = describe_materials(scene, m, "") + describe_joints(scene, m, "");
  EXPECT_TRUE(cli_test::has(listing, "material 'granite' (every tet): 768 tets, 0 CE6s with its law")) << listing;
  EXPECT_TRUE(cli_test::has(listing, "joint 'bedding' (surfaces joint): 32 CE6s, frictional, friction 0.5")) << listing;
  const fs::path csv = fs::temp_directory_path() / ("fdem_joints_" + std::to_string(::getpid()) + ".csv");
  std::ofstream(csv) << "ce6,mode,joint\n3,1,\n5,4,bedding\n7,2,\n9,1,\"a, b\"\n";
  EXPECT_EQ(read_broken_ce6(csv.string()), (std::vector<long>{3, 7}));
  fs::remove(csv);
}

TEST(Joints, JointsThatDoNotFitTheMeshAreRefusedWithTheFix) {
  std::string e = joint_error("[{name: j, surfaces: [fault]}]");
  EXPECT_TRUE(cli_test::has(e, "rock.yaml: joints[0] ('j').surfaces: the mesh")) << e;
  EXPECT_TRUE(cli_test::has(e, "has no group 'fault'; its surface groups: xmin")) << e;
  e = joint_error("[{name: j, surfaces: [upper]}]");
  EXPECT_TRUE(cli_test::has(e, "'upper' is a volume, and a joint lies on a surface")) << e;
  e = joint_error("[{name: j, surfaces: [zmax]}]");
  EXPECT_TRUE(cli_test::has(e, "is not between two tets: it is on the outer surface, or the mesh does not conform"))
      << e;
  EXPECT_TRUE(cli_test::has(e, "embed its surface in the volume")) << e;
  e = joint_error("[{name: a, surfaces: [joint]}, {name: b, surfaces: [joint]}]");
  EXPECT_TRUE(cli_test::has(e, "is also on joints[0] ('a'); give each surface to one joint")) << e;
  Mesh tagged = test::jointed_box();
  tagged.groups.back().name = "";
  EXPECT_EQ(joint_error("[{name: j, surfaces: [7]}]", tagged), "") << "by gmsh tag";
  // The scene's keys.
  e = joint_error("[{surfaces: [joint]}]");
  EXPECT_TRUE(cli_test::has(e, "joints[0].name: missing")) << e;
  e = joint_error("[{name: j}]");
  EXPECT_TRUE(cli_test::has(e, "joints[0].surfaces: missing")) << e;
  e = joint_error("[{name: j, surfaces: [joint]}, {name: j, surfaces: [zmax]}]");
  EXPECT_TRUE(cli_test::has(e, "joints[1].name: 'j' names two joints")) << e;
  e = joint_error("[{name: j, surfaces: [joint], density: 2000}]");
  EXPECT_TRUE(cli_test::has(e, "joints[0]")) << e;
  EXPECT_TRUE(cli_test::has(e, "density")) << e;
  e = joint_error("[{name: j, surfaces: [joint], friction: -1}]");
  EXPECT_TRUE(cli_test::has(e, "joints[0].friction")) << e;
  e = joint_error("{name: j}");
  EXPECT_TRUE(cli_test::has(e, "joints: expected a list of joints")) << e;
}
