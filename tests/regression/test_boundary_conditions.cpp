// Kinematic boundary conditions on surface groups (scene boundary_conditions: fixed, roller,
// velocity with a time function): a closed-form answer, their reactions and works in the
// energy balance, every schedule and the debug backend alike, a restart bit for bit, and the
// errors a scene gets for conditions that cannot hold.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "backend_support.hpp"
#include "cli_support.hpp"
#include "core/error.hpp"
#include "model/structured.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// A 10 x 10 x 20 mm intact box (structured, 4 x 4 x 8 cells) on rollers at xmin, ymin and
/// zmin; zmax pressed down at 0.05 m/s along a table: up over 20 us, held 40 us, down over 20 us,
/// so it moves 3 um in all and then rests. `extra`: more conditions, as YAML list entries.
std::string box_scene(const std::string& extra = "", const std::string& backend = "cpu",
                      const std::string& fracture = "none") {
  return "name: bc_box\n"
         "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
         "fracture_regions: " +
         fracture +
         "\n"
         "platens: none\n"
         "contact: {activation: none}\n"
         "boundary_conditions:\n"
         "  - {surface: xmin, type: roller}\n"
         "  - {surface: ymin, type: roller}\n"
         "  - {surface: zmin, type: roller}\n"
         "  - {surface: zmax, type: velocity, velocity: [~, ~, -0.05],\n"
         "     time_function: {table: [[0, 0], [2e-5, 1], [6e-5, 1], [8e-5, 0]]}}\n" +
         extra + "solver: {threads: 1, backend: " + backend +
         ", end: {time: 3e-4}}\n"
         "output: {progress_interval: 0, plot: false}\n";
}

Mesh box_mesh() {
  return structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8);
}

std::unique_ptr<Solver> box_solver(const Scene& s) {
  return std::make_unique<Solver>(s, build_model(box_mesh(), s));
}

/// The reaction component d (N) and work (J) of condition c in a monitor row.
real reaction(const Monitors& r, int c, int d) {
  return r.conditions[4 * c + d];
}
real work(const Monitors& r, int c) {
  return r.conditions[4 * c + 3];
}

/// The InputError text of building the box model with scene text `yaml`, or "".
std::string model_error(const std::string& yaml, const Mesh& mesh = box_mesh()) {
  try {
    const Scene s = parse_scene(yaml, "bc.yaml");
    build_model(mesh, s);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(BoundaryConditions, RollersAndAPressedEndGiveEATimesTheStrainAtRest) {
  // Rollers on three faces leave the box free to expand sideways: uniaxial stress, a state a
  // TET4 mesh holds exactly. At rest the end's reaction is E A d / L, with d the 3 um the table
  // moves the end (to the step's round-off of the table's integral).
  const Scene scene = parse_scene(box_scene(), "bc.yaml");
  auto s = box_solver(scene);
  while (s->time() < 3e-4) s->step();
  const Monitors r = s->measure();
  ASSERT_EQ(r.condition_columns, 16);
  const Material& m = scene.material;
  const real d = 0.05 * (1e-5 + 4e-5 + 1e-5), force = m.youngs_modulus * 1e-4 * d / 0.02;
  EXPECT_NEAR(reaction(r, 2, 2), force, 1e-3 * force) << "the rollers at zmin push up";
  EXPECT_NEAR(reaction(r, 3, 2), -force, 1e-3 * force) << "the pressed end pushes down";
  EXPECT_NEAR(reaction(r, 2, 2), -reaction(r, 3, 2), 1e-6 * force) << "at rest the two ends balance";
  EXPECT_LT(std::fabs(reaction(r, 0, 0)), 1e-4 * force) << "the side rollers carry no load";
  EXPECT_LT(std::fabs(reaction(r, 1, 1)), 1e-4 * force);
  // The work the pressed end did is all stored (rollers do no work); the ledger counts it.
  EXPECT_NEAR(r.strain, 0.5 * force * d, 1e-3 * 0.5 * force * d);
  EXPECT_NEAR(r.external_work, work(r, 0) + work(r, 1) + work(r, 2) + work(r, 3), 1e-9 * r.external_work);
  EXPECT_EQ(work(r, 0), 0);
  EXPECT_EQ(work(r, 2), 0);
  EXPECT_LT(r.energy_error, 5e-3) << "the ledger's step integration (measured 1.2e-3)";
  EXPECT_LT(r.kinetic, 1e-9 * r.strain) << "at rest";
}

TEST(BoundaryConditions, TheSchedulesAndTheDebugBackendGiveTheCpuRun) {
  // The fused pass prescribes inside its node step (CE6s on every face: each node is one tet's),
  // the colour passes after the integration: the same arithmetic, the same run; the debug
  // backend's separate memory holds the lists. A fixed face on a roller's face and along the
  // rollers' edges: where both hold the velocity at zero they agree.
  const std::string extra = "  - {surface: zmin, type: fixed}\n";
  auto run = [&](const std::string& backend, const char* schedule) {
    test::EnvSetting env("FDEM_DEVICE_SCHEDULE", schedule);
    auto s = box_solver(parse_scene(box_scene(extra, backend, "all"), "bc.yaml"));
    for (int k = 0; k < 1500; ++k) s->step();
    s->sync_host();
    return std::make_pair(s->state.x, s->measure());
  };
  const auto [x, row] = run("cpu", "colour");
  EXPECT_GT(std::fabs(reaction(row, 3, 2)), 1) << "the end is loaded by step 1500";
  for (const char* schedule : {"colour", "fused", "auto"}) {
    for (const char* backend : {"cpu", "debug"}) {
      SCOPED_TRACE(std::string(backend) + ", " + schedule);
      const auto [y, other] = run(backend, schedule);
      real worst = 0;
      for (std::size_t n = 0; n < x.size(); ++n) worst = std::max(worst, norm(x[n] - y[n]));
      EXPECT_LT(worst, 1e-18) << "m";
      for (int k = 0; k < row.condition_columns; ++k)
        EXPECT_NEAR(row.conditions[k], other.conditions[k], 1e-9 * std::fabs(row.conditions[k]) + 1e-15) << k;
      EXPECT_NEAR(row.external_work, other.external_work, 1e-9 * row.external_work);
    }
  }
}

TEST(BoundaryConditions, ARestartContinuesBitForBit) {
  // The reactions and works are state: a run saved and loaded at step 700 (mid-table) goes on
  // as the uninterrupted one.
  const Scene scene = parse_scene(box_scene(), "bc.yaml");
  auto a = box_solver(scene), b = box_solver(scene);
  for (int k = 0; k < 700; ++k) a->step();
  CheckpointOut out;
  a->save(out);
  CheckpointIn in(out.payload(), "memory");
  b->load(in);
  for (int k = 0; k < 800; ++k) a->step(), b->step();
  const Monitors ra = a->measure(), rb = b->measure();
  for (int k = 0; k < ra.condition_columns; ++k) EXPECT_EQ(ra.conditions[k], rb.conditions[k]) << k;
  EXPECT_EQ(ra.external_work, rb.external_work);
  EXPECT_EQ(ra.strain, rb.strain);
}

TEST(BoundaryConditions, ConditionsThatCannotHoldAreRefusedWithTheFix) {
  // A group the mesh does not have: the ones it has are listed.
  std::string e = model_error(box_scene("  - {surface: top, type: fixed}\n"));
  EXPECT_TRUE(cli_test::has(e, "bc.yaml: boundary_conditions[4].surface: the mesh")) << e;
  EXPECT_TRUE(cli_test::has(e, "has no group 'top'; its surface groups: xmin, xmax, ymin, ymax, zmin, zmax")) << e;
  // Two conditions prescribing different velocities to the nodes they share.
  e = model_error(box_scene("  - {surface: xmax, type: velocity, velocity: [0.01, 0, 0]}\n"));
  EXPECT_TRUE(cli_test::has(e, "boundary_conditions[3] and boundary_conditions[4] both prescribe the z velocity at"))
      << e;
  EXPECT_TRUE(cli_test::has(e, "with different values; give the shared edge to one of them")) << e;
  // A roller on faces that are not one plane normal to an axis.
  Mesh bent = box_mesh();
  MeshGroup corner = bent.groups[0];  // xmin and ymin as one group
  corner.name = "corner", corner.tag = 7;
  corner.faces.insert(corner.faces.end(), bent.groups[2].faces.begin(), bent.groups[2].faces.end());
  bent.groups.push_back(corner);
  e = model_error(box_scene("  - {surface: corner, type: roller}\n"), bent);
  EXPECT_TRUE(cli_test::has(e, "surface 'corner' is not one plane normal to x, y or z")) << e;
  // A face inside the rock.
  Mesh inner = box_mesh();
  MeshGroup mid{"middle", 2, 8, {}, {}};
  for (const auto& t : inner.tets) mid.faces.push_back({t[0], t[1], t[2]});
  inner.groups.push_back(mid);
  e = model_error(box_scene("  - {surface: middle, type: fixed}\n"), inner);
  EXPECT_TRUE(cli_test::has(e, "surface 'middle' has a face inside the rock")) << e;
  // A volume group where a surface is needed.
  Mesh vol = box_mesh();
  vol.groups.push_back(MeshGroup{"rock", 3, 9, {0, 1}, {}});
  e = model_error(box_scene("  - {surface: rock, type: fixed}\n"), vol);
  EXPECT_TRUE(cli_test::has(e, "'rock' is a volume, and a boundary condition acts on a surface")) << e;
}

TEST(BoundaryConditions, TheSceneKeysAreCheckedWithTheFix) {
  auto error_of = [](const std::string& yaml) {
    try {
      parse_scene(yaml, "bc.yaml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string head =
      "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
      "solver: {end: {steps: 10}}\nboundary_conditions:\n";
  std::string e = error_of(head +
                           "  - {surface: zmax, type: velocity, velocity: [~, ~, -1],\n"
                           "     time_function: {table: [[0, 0], [2e-5, 1], [1e-5, 0]]}}\n");
  EXPECT_TRUE(cli_test::has(e, "boundary_conditions[0].time_function.table[2]: t = 1e-05 s does not increase")) << e;
  e = error_of(head + "  - {surface: zmin, type: fixed, time_function: {shape: smooth, duration: 1e-4}}\n");
  EXPECT_TRUE(cli_test::has(e, "boundary_conditions[0].time_function: a fixed condition holds its value at zero")) << e;
  e = error_of(head + "  - {surface: zmax, type: velocity, velocity: [~, ~, ~]}\n");
  EXPECT_TRUE(cli_test::has(e, "boundary_conditions[0].velocity: leaves every component free")) << e;
  e = error_of(head + "  - {surface: zmax, type: velocity}\n");
  EXPECT_TRUE(cli_test::has(e, "boundary_conditions[0].velocity: missing")) << e;
  e = error_of(head + "  - {surface: zmax, type: glued}\n");
  EXPECT_TRUE(cli_test::has(e, "allowed: fixed | roller | velocity")) << e;
  e = error_of(head + "  - {surface: zmax, type: velocity, velocity: [0, 0, 1], time_function: {shape: linear}}\n");
  EXPECT_TRUE(cli_test::has(e, "time_function.duration: missing")) << e;
}

TEST(BoundaryConditions, TimeFunctionsRiseAndFollowTheirTables) {
  TimeFunction f;
  EXPECT_EQ(f.at(5), 1);
  f.shape = TimeShape::linear, f.duration = 2;
  EXPECT_EQ(f.at(-1), 0);
  EXPECT_EQ(f.at(0.5), 0.25);
  EXPECT_EQ(f.at(3), 1);
  f.shape = TimeShape::smooth;
  EXPECT_EQ(f.at(1), 0.5);  // the smoothstep's middle
  EXPECT_EQ(f.at(2), 1);
  f.shape = TimeShape::table, f.table = {{1, 2}, {3, -2}};
  EXPECT_EQ(f.at(0), 2);  // held before the first row
  EXPECT_EQ(f.at(2), 0);
  EXPECT_EQ(f.at(9), -2);  // and after the last
}
