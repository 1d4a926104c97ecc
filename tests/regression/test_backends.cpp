// The device time loop (solver/device_loop_impl.hpp) run by the debug backend on the host,
// against the CPU backend: the same colour order makes every node force the same sum, so the
// states agree bit for bit; energies come from other reduction trees and agree to round-off.
// The debug backend poisons the host copy while the device holds the state, so a missing copy
// shows up here without a GPU.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "backend_support.hpp"
#include "cli_support.hpp"
#include "io/checkpoint.hpp"

using namespace fdem;
using namespace fdem::test;

namespace {

bool same_bits(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
}

}  // namespace

// Both schedules of the device loop's element passes: "auto" fuses TET4 and CE6 in one pass (a
// CE6 on every internal face: every node is one tet's), "colour" keeps the colour passes.
class DebugSchedule : public ::testing::TestWithParam<const char*> {};
INSTANTIATE_TEST_SUITE_P(Schedule, DebugSchedule, ::testing::Values("auto", "colour"));

TEST_P(DebugSchedule, ElasticBoxIsBitIdenticalToCpu) {
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_elastic_scene("cpu"));
  auto dbg = backend_solver(backend_elastic_scene("debug"));
  ASSERT_EQ(dbg->backend(), Backend::debug);
  EXPECT_EQ(dbg->device_loop()->fused(), std::string(GetParam()) == "auto");
  for (int i = 0; i < 3000; ++i) cpu->step(), dbg->step();
  dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->x, dbg->x));
  EXPECT_TRUE(same_bits(cpu->v, dbg->v));
  EXPECT_TRUE(same_bits(cpu->f, dbg->f));
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.axial_stress, 1e6) << "the box should be loaded";
  EXPECT_EQ(a.axial_stress, b.axial_stress);
  EXPECT_NEAR(a.strain, b.strain, 1e-12 * a.strain);
  EXPECT_NEAR(a.external_work, b.external_work, 1e-12 * a.external_work);
  EXPECT_NEAR(a.viscous, b.viscous, 1e-10 * a.viscous);
}

TEST_P(DebugSchedule, FracturingBoxWithContactAndPressureMatchesCpu) {
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_fracture_scene("cpu"));
  auto dbg = backend_solver(backend_fracture_scene("debug"));
  EXPECT_EQ(dbg->device_loop()->fused(), std::string(GetParam()) == "auto");
  const FractureResult ra = run_fracture(*cpu, 4000), rb = run_fracture(*dbg, 4000);
  EXPECT_GT(ra.broken, 20) << "the run should fracture";
  RecordProperty("broken_ce6", std::to_string(ra.broken));
  RecordProperty("peak_Pa", std::to_string(ra.peak));
  EXPECT_EQ(ra.broken, rb.broken);
  EXPECT_EQ(ra.peak, rb.peak);
  dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->x, dbg->x)) << "max relative difference " << max_rel_diff(cpu->x, dbg->x, 1e-9);
  EXPECT_TRUE(same_bits(cpu->v, dbg->v));
  long anchored = 0;  // CE6s whose friction anchors are kept (damaged or broken)
  for (std::size_t i = 0; i < cpu->ce6.size(); ++i) {
    ASSERT_EQ(cpu->ce6[i].mode, dbg->ce6[i].mode) << "CE6 " << i;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(cpu->ce6[i].D[k], dbg->ce6[i].D[k]) << "CE6 " << i;
    if (ce6_max_damage(cpu->ce6[i]) > 0) {
      ++anchored;
      ASSERT_EQ(std::memcmp(cpu->ce6[i].slip, dbg->ce6[i].slip, sizeof(cpu->ce6[i].slip)), 0) << "CE6 " << i;
    }
  }
  EXPECT_GT(anchored, ra.broken) << "damaged CE6s that did not break keep anchors too";
  EXPECT_EQ(cpu->contacts.active(), dbg->contacts.active());
  // The candidate lists built on the device (broad phase, filters, order) are the host's.
  ASSERT_EQ(cpu->contacts.pair_count(), dbg->contacts.pair_count());
  for (long k = 0; k < cpu->contacts.pair_count(); ++k) {
    const ContactPair &p = cpu->contacts.pairs()[k], &q = dbg->contacts.pairs()[k];
    ASSERT_TRUE(p.a == q.a && p.b == q.b && p.joint == q.joint) << "pair " << k;
  }
  EXPECT_TRUE(same_bits(cpu->contacts.spring, dbg->contacts.spring));
  EXPECT_GT(cpu->contacts.times.rebuilds, 1);
  EXPECT_EQ(cpu->contacts.times.rebuilds, dbg->contacts.times.rebuilds);
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.contacts, 0) << "fragments should touch";
  EXPECT_EQ(a.contacts, b.contacts);
  EXPECT_NEAR(a.contact_friction, b.contact_friction, 1e-9 * std::fabs(a.contact_friction) + 1e-15);
  EXPECT_NEAR(a.cohesive_dissipated, b.cohesive_dissipated, 1e-10 * a.cohesive_dissipated);
  EXPECT_NEAR(a.confining_pressure, b.confining_pressure, 0);
}

TEST(DebugBackend, NodesSharedByTetsKeepTheColourPasses) {
  // CE6s in the lower half of the box only: above, tets share nodes, so one tet's pass cannot
  // own its nodes' forces and the loop keeps the colour passes, still the CPU's bits.
  Scene elastic = backend_elastic_scene("debug");
  elastic.fracture.everywhere = false;
  elastic.fracture.boxes.push_back({{-1, -1, -1}, {1, 1, 0.006}});
  Scene cpu_scene = elastic;
  cpu_scene.solver.backend = "cpu";
  auto cpu = backend_solver(cpu_scene);
  auto dbg = backend_solver(elastic);
  ASSERT_GT(dbg->model().ce6_nodes.size(), 0u);
  EXPECT_FALSE(dbg->device_loop()->fused());
  for (int i = 0; i < 1000; ++i) cpu->step(), dbg->step();
  dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->x, dbg->x));
  EXPECT_TRUE(same_bits(cpu->f, dbg->f));
  EXPECT_GT(cpu->measure().axial_stress, 1e5) << "loaded";
  // The plan refuses such a model.
  FusedPlan plan;
  EXPECT_FALSE(plan_fused_pass(dbg->model(), plan));
  EXPECT_TRUE(plan_fused_pass(backend_solver(backend_elastic_scene("debug"))->model(), plan));
}

TEST(DebugBackend, GravityHydrostaticPressureAndPrescribedNodesMatchCpu) {
  // The parts the boxes above leave out. Hydrostatic pressure follows the platen reaction,
  // a sum whose order differs between the backends, so agreement is to round-off.
  auto cpu = backend_gravity_solver("cpu"), dbg = backend_gravity_solver("debug");
  for (int i = 0; i < 1500; ++i) cpu->step(), dbg->step();
  dbg->sync_host();
  EXPECT_LT(max_rel_diff(cpu->x, dbg->x, 1e-6), 1e-12);
  EXPECT_LT(max_rel_diff(cpu->v, dbg->v, 1e-3), 1e-9);
  EXPECT_EQ(dbg->v[0].x, 0.015);
  EXPECT_EQ(dbg->v[0].y, -0.02);
  EXPECT_EQ(cpu->v[0].x, 0.015);
  EXPECT_EQ(cpu->v[0].y, -0.02);
  EXPECT_NE(cpu->v[0].z, 7.0);
  EXPECT_NE(cpu->v[0].z, 0.0) << "z is free: gravity and the pressure move it";
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.confining_pressure, 1e5) << "the pressure should follow the axial stress";
  EXPECT_NEAR(a.confining_pressure, b.confining_pressure, 1e-9 * a.confining_pressure);
  EXPECT_NEAR(a.external_work, b.external_work, 1e-9 * std::fabs(a.external_work));
}

TEST(DebugBackend, OnlyAFewScalarsCrossToTheHostBetweenMonitorRows) {
  // The device loop keeps the state on the device: between monitor rows a step sends the host
  // only its reductions (energies, the platen reaction, counts), and nothing goes to the device,
  // whatever the model's size. Counted by the debug backend as the CUDA backend would copy.
  struct Seen {
    device::Traffic traffic;
    long steps = 0, rebuilds = 0, broken = 0;
  };
  auto run = [](int cells, real velocity, int steps) {
    Scene s = backend_fracture_scene("debug");
    s.platens.velocity = velocity;
    Solver solver(s, build_model(structured_box_mesh({0.006, 0.006, 0.012}, cells, cells, 2 * cells), s));
    solver.step();  // the first step uploads the state
    device::reset_traffic();
    const long rebuilds0 = solver.contacts.times.rebuilds;
    for (int i = 0; i < steps; ++i) solver.step();
    Seen seen{device::traffic(), steps, solver.contacts.times.rebuilds - rebuilds0, 0};
    seen.broken = solver.measure().broken;
    return seen;
  };
  // Elastic: 324 tets and 2,592 tets send the host the same bytes, step for step.
  const Seen small = run(3, 0.5, 200), big = run(6, 0.5, 200);
  EXPECT_EQ(small.broken, 0);
  EXPECT_GT(small.traffic.host_bytes, 0u) << "the reductions are counted";
  EXPECT_EQ(small.traffic.to_host, big.traffic.to_host);
  EXPECT_EQ(small.traffic.host_bytes, big.traffic.host_bytes);
  EXPECT_EQ(small.traffic.to_device + big.traffic.to_device, 0);
  // One copy a step: the broad phase's decision after the CE6 pass, with the integration's sums
  // and the last force evaluation's scalars (platen reactions, powers) in the same copy.
  EXPECT_EQ(small.traffic.to_host, small.steps);
  // Through fracture, activation and broad-phase rebuilds on the device: still a few hundred
  // bytes per step, none larger than one block of sums.
  const Seen frac = run(3, 4.0, 4000);
  EXPECT_GT(frac.broken, 20) << "the run should fracture";
  EXPECT_GT(frac.rebuilds, 1);
  RecordProperty("bytes_to_host_per_step", std::to_string(double(frac.traffic.host_bytes) / frac.steps));
  RecordProperty("copies_to_host_per_step", std::to_string(double(frac.traffic.to_host) / frac.steps));
  EXPECT_LE(frac.traffic.largest_to_host, 40 * sizeof(real));  // the step's sums: 24 + the forces' 16
  EXPECT_LE(double(frac.traffic.host_bytes) / frac.steps, 1024);
  // Nothing to the device, rebuilds of the candidate list on the device included.
  EXPECT_EQ(frac.traffic.to_device, 0);
}

TEST(DebugBackend, HostCopyIsPoisonedUntilSynced) {
  auto dbg = backend_solver(backend_elastic_scene("debug"));
  dbg->step();
  // The device holds the state: the host copy must not be read as if current.
  EXPECT_TRUE(std::isnan(dbg->x[0].x));
  EXPECT_TRUE(std::isnan(dbg->v[5].z));
  EXPECT_TRUE(std::isnan(dbg->ce6[0].D[0]));
  dbg->sync_host();
  EXPECT_EQ(dbg->x[0].x, dbg->model().X[0].x + 0 * dbg->x[0].x);  // node 0 is on the bottom: still in place
  for (const Vec3& p : dbg->x) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  // A monitor row is summed on the device: the host copy stays as it was, and the row is the
  // CPU backend's to round-off.
  auto cpu = backend_solver(backend_elastic_scene("cpu"));
  for (int i = 0; i < 400; ++i) cpu->step();
  for (int i = 0; i < 399; ++i) dbg->step();
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_TRUE(std::isnan(dbg->x[3].z));
  EXPECT_GT(a.strain, 0);
  EXPECT_NEAR(a.strain, b.strain, 1e-12 * a.strain);
  EXPECT_NEAR(a.kinetic, b.kinetic, 1e-12 * a.kinetic);
  EXPECT_NEAR(a.lateral_strain, b.lateral_strain, 1e-12 * std::fabs(a.lateral_strain));
  EXPECT_NEAR(a.lateral_stress, b.lateral_stress, 1e-12 * std::fabs(a.lateral_stress) + 1e-6);
  EXPECT_NEAR(a.platen_stored, b.platen_stored, 1e-12 * a.platen_stored);
  EXPECT_EQ(a.damaged, b.damaged);
}

TEST(DebugBackend, HostChangesAndCheckpointsReachTheDevice) {
  // A velocity set on the host between steps (host_changed), and a checkpoint written by one
  // debug solver and loaded into another, continue exactly as the CPU backend does.
  auto cpu = backend_solver(backend_fracture_scene("cpu"));
  auto dbg = backend_solver(backend_fracture_scene("debug"));
  for (int i = 0; i < 1000; ++i) cpu->step(), dbg->step();
  dbg->sync_host();
  for (Solver* s : {cpu.get(), dbg.get()}) {
    s->v[7] = s->v[7] + Vec3{0.01, 0, 0};
    s->host_changed();
  }
  for (int i = 0; i < 1000; ++i) cpu->step(), dbg->step();
  CheckpointOut out;
  dbg->save(out);
  auto resumed = backend_solver(backend_fracture_scene("debug"));
  CheckpointIn in(out.payload(), "(test checkpoint)");
  resumed->load(in);
  for (int i = 0; i < 2000; ++i) cpu->step(), dbg->step(), resumed->step();
  dbg->sync_host();
  resumed->sync_host();
  EXPECT_GT(cpu->measure().broken, 0);
  EXPECT_TRUE(same_bits(cpu->x, dbg->x));
  EXPECT_TRUE(same_bits(cpu->x, resumed->x));
  EXPECT_TRUE(same_bits(cpu->v, resumed->v));
}

TEST(DebugBackend, CliRunGivesTheCpuFiles) {
  using namespace cli_test;
  TempDir dir("backend_debug");
  const std::string scene = quote((kData / "cli" / "restart_box.yaml").string());
  const Outcome a = cli_test::fdem("run " + scene + " -q -o " + quote((dir.path / "cpu").string()));
  const Outcome b = cli_test::fdem("run " + scene + " -q --backend debug -o " + quote((dir.path / "debug").string()));
  ASSERT_EQ(a.code, 0) << a.text;
  ASSERT_EQ(b.code, 0) << b.text;
  EXPECT_TRUE(has(b.text, "backend debug"));
  // The pair buffers start at the first list's size and grow as fragments meet; each growth is
  // reported.
  EXPECT_TRUE(has(b.text, "device: contact pair buffers grew to hold")) << b.text;
  auto read = [](const fs::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  const std::string ma = read(dir.path / "cpu" / "monitors.csv"), mb = read(dir.path / "debug" / "monitors.csv");
  EXPECT_GT(ma.size(), 1000u);
  EXPECT_EQ(ma, mb);
  EXPECT_EQ(read(dir.path / "cpu" / "broken_ce6.csv"), read(dir.path / "debug" / "broken_ce6.csv"));
  EXPECT_EQ(read(dir.path / "cpu" / "fields.xdmf").size(), read(dir.path / "debug" / "fields.xdmf").size());
}

// A scene read from a mesh file: the input errors below are checked in builds without gmsh too
// (the GPU machine's).
const std::filesystem::path kNoGmshScene = cli_test::kData / "scenes" / "from_file.yaml";

TEST(DebugBackend, CudaWithoutAGpuIsAClearInputError) {
  if (cuda_device_count() > 0) GTEST_SKIP() << "a GPU is visible here: tests/gpu covers the CUDA backend";
  using namespace cli_test;
  TempDir dir("backend_cuda");
  const Outcome o = cli_test::fdem("run " + quote(kNoGmshScene.string()) + " -q --backend cuda -o " +
                                   quote((dir.path / "out").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, cuda_built() ? "no CUDA device is visible" : "built without CUDA")) << o.text;
  EXPECT_TRUE(has(o.text, "--backend cpu")) << o.text;
  EXPECT_FALSE(fs::exists(dir.path / "out" / "monitors.csv"));
}

TEST(DebugBackend, AnUnknownIterationOrderIsAClearInputError) {
  using namespace cli_test;
  TempDir dir("debug_order");
  const Outcome o =
      run_cmd("FDEM_DEBUG_ORDER=backwards " + kEnv + quote(kExe) + " run " + quote(kNoGmshScene.string()) +
              " -q --backend debug -o " + quote((dir.path / "out").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "FDEM_DEBUG_ORDER=backwards")) << o.text;
  EXPECT_TRUE(has(o.text, "scrambled (the default) or forward")) << o.text;
  EXPECT_FALSE(fs::exists(dir.path / "out" / "monitors.csv"));
}

TEST(DebugBackend, AnUnknownDeviceScheduleIsAClearInputError) {
  {
    EnvSetting schedule("FDEM_DEVICE_SCHEDULE", "fastest");
    try {
      backend_solver(backend_elastic_scene("debug"));
      ADD_FAILURE() << "FDEM_DEVICE_SCHEDULE=fastest was accepted";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("FDEM_DEVICE_SCHEDULE=fastest"), std::string::npos) << what;
      EXPECT_NE(what.find("auto"), std::string::npos) << what;
    }
  }
  using namespace cli_test;
  TempDir dir("device_schedule");
  const Outcome o =
      run_cmd("FDEM_DEVICE_SCHEDULE=fastest " + kEnv + quote(kExe) + " run " + quote(kNoGmshScene.string()) +
              " -q --backend debug -o " + quote((dir.path / "out").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "FDEM_DEVICE_SCHEDULE=fastest")) << o.text;
  EXPECT_FALSE(fs::exists(dir.path / "out" / "monitors.csv"));
}
