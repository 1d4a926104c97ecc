// The device time loop (solver/device_loop_impl.hpp) run by the debug backend on the host,
// against the CPU backend: the same colour order makes every node force the same sum, so the
// states agree bit for bit; energies come from other reduction trees and agree to round-off.
// The debug backend poisons the host copy while the device holds the state, so a missing copy
// shows up here without a GPU.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <utility>

#include "backend_support.hpp"
#include "cli_support.hpp"
#include "io/checkpoint.hpp"
#include "solver/sum_slots.hpp"

using namespace fdem;
using namespace fdem::test;

// The schedules of the device loop's element passes: "auto" fuses TET4 and CE6 in one pass (a
// CE6 on every internal face: every node is one tet's) that takes the forces contact, platens
// and pressure put on its nodes and does the step too (one rank), "fused" the same pass without
// the step, "colour" keeps the colour passes.
class DebugSchedule : public ::testing::TestWithParam<const char*> {
 protected:
  /// The device loop of `s` is the one the schedule asks for.
  void expect_schedule(const Solver& s) const {
    const std::string name = GetParam();
    EXPECT_EQ(s.device_loop()->fused(), name != "colour");
    EXPECT_EQ(s.device_loop()->integrates(), name == "auto");
  }
};
INSTANTIATE_TEST_SUITE_P(Schedule, DebugSchedule, ::testing::Values("auto", "fused", "colour"));

TEST_P(DebugSchedule, ElasticBoxIsBitIdenticalToCpu) {
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_elastic_scene("cpu"));
  auto dbg = backend_solver(backend_elastic_scene("debug"));
  ASSERT_EQ(dbg->backend(), Backend::debug);
  for (int i = 0; i < 3000; ++i) cpu->step(), dbg->step();
  expect_schedule(*dbg);
  cpu->sync_host(), dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x));
  EXPECT_TRUE(same_bits(cpu->state.v, dbg->state.v));
  EXPECT_TRUE(same_bits(cpu->state.f, dbg->state.f));
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.axial_stress, 1e6) << "the box should be loaded";
  EXPECT_EQ(a.axial_stress, b.axial_stress);
  EXPECT_NEAR(a.strain, b.strain, 1e-12 * a.strain);
  EXPECT_NEAR(a.external_work, b.external_work, 1e-12 * a.external_work);
  EXPECT_NEAR(a.viscous, b.viscous, 1e-10 * a.viscous);
}

TEST_P(DebugSchedule, ANodeMovingHalfTheBufferRebuildsTheListAsOnTheCpu) {
  // A buffer of 2 um (the automatic one is a tenth of the mean edge, 0.2 mm here): the broad
  // phase's watch asks for rebuilds as the platen drives the top tets, and the device's watch
  // must ask at the CPU's steps (where the fused pass steps it runs in the launch of the new
  // velocities' powers and counts into a slot of its own: not reading that slot fails here).
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  Scene s = backend_fracture_scene("cpu");
  s.contact.buffer = 2e-6;  // m
  auto cpu = backend_solver(s);
  s.solver.backend = Backend::debug;
  auto dbg = backend_solver(s);
  for (int i = 0; i < 1500; ++i) {  // at the same steps
    cpu->step(), dbg->step();
    ASSERT_EQ(cpu->contacts.times.rebuilds, dbg->contacts.times.rebuilds) << "step " << i + 1;
  }
  EXPECT_GT(cpu->contacts.times.rebuilds, 2) << "nodes should move half the buffer";
  cpu->sync_host(), dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x));
  EXPECT_TRUE(same_bits(cpu->contacts.history, dbg->contacts.history));
}

TEST_P(DebugSchedule, FracturingBoxWithContactAndPressureMatchesCpu) {
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_fracture_scene("cpu"));
  auto dbg = backend_solver(backend_fracture_scene("debug"));
  const FractureResult ra = run_fracture(*cpu, 4000), rb = run_fracture(*dbg, 4000);
  expect_schedule(*dbg);
  EXPECT_GT(ra.broken, 20) << "the run should fracture";
  RecordProperty("broken_ce6", std::to_string(ra.broken));
  RecordProperty("peak_Pa", std::to_string(ra.peak));
  EXPECT_EQ(ra.broken, rb.broken);
  EXPECT_EQ(ra.peak, rb.peak);
  cpu->sync_host(), dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x))
      << "max relative difference " << max_rel_diff(cpu->state.x, dbg->state.x, 1e-9);
  EXPECT_TRUE(same_bits(cpu->state.v, dbg->state.v));
  long anchored = 0;  // CE6s whose friction anchors are kept (damaged or broken)
  for (std::size_t i = 0; i < cpu->state.ce6.size(); ++i) {
    ASSERT_EQ(cpu->state.ce6[i].mode, dbg->state.ce6[i].mode) << "CE6 " << i;
    for (int k = 0; k < 3; ++k) ASSERT_EQ(cpu->state.ce6[i].D[k], dbg->state.ce6[i].D[k]) << "CE6 " << i;
    if (ce6_max_damage(cpu->state.ce6[i]) > 0) {
      ++anchored;
      ASSERT_EQ(std::memcmp(cpu->state.ce6[i].slip, dbg->state.ce6[i].slip, sizeof(cpu->state.ce6[i].slip)), 0)
          << "CE6 " << i;
    }
  }
  EXPECT_GT(anchored, ra.broken) << "damaged CE6s that did not break keep anchors too";
  EXPECT_EQ(cpu->contacts.tet_flags, dbg->contacts.tet_flags);
  // Exactly the tets around the broken CE6s and at the loaded ends (the device raises each flag
  // once, raise_flag, whichever broken CE6s share it).
  const std::vector<std::uint8_t> expected = flags_from_breaks(*dbg);
  EXPECT_EQ(expected, dbg->contacts.tet_flags);
  EXPECT_GT(std::count_if(expected.begin(), expected.end(), [](std::uint8_t f) { return f & TetFlag::kCandidate; }),
            backend_solver(backend_fracture_scene("cpu"))->contacts.active_count())
      << "the breaks should activate tets beyond the loaded ends";
  // The candidate lists built on the device (broad phase, filters, order) are the host's.
  ASSERT_EQ(cpu->contacts.pair_count(), dbg->contacts.pair_count());
  for (long k = 0; k < cpu->contacts.pair_count(); ++k) {
    const ContactPair &p = cpu->contacts.pairs[k], &q = dbg->contacts.pairs[k];
    ASSERT_TRUE(p.a == q.a && p.b == q.b && p.joint == q.joint) << "pair " << k;
  }
  EXPECT_TRUE(same_bits(cpu->contacts.history, dbg->contacts.history));
  EXPECT_GT(cpu->contacts.times.rebuilds, 1);
  EXPECT_EQ(cpu->contacts.times.rebuilds, dbg->contacts.times.rebuilds);
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.contacts, 0) << "fragments should touch";
  EXPECT_EQ(a.contacts, b.contacts);
  EXPECT_NEAR(a.contact_friction, b.contact_friction, 1e-9 * std::fabs(a.contact_friction) + 1e-15);
  EXPECT_NEAR(a.cohesive_dissipated, b.cohesive_dissipated, 1e-10 * a.cohesive_dissipated);
  EXPECT_NEAR(a.confining_pressure, b.confining_pressure, 0);
}

TEST_P(DebugSchedule, GravityPrescribedNodesAndPressureAreBitIdenticalToCpu) {
  // Gravity (the first term of each node's force), prescribed velocity components and a constant
  // confining pressure (its forces added after the elements'): the fused pass integrating all
  // of them where the schedule lets it.
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto make = [](const std::string& backend) {
    auto solver = backend_gravity_solver(backend, "constant");
    solver->prescribe(5, 0b100, Vec3{0, 0, 0.03});
    return solver;
  };
  auto cpu = make("cpu"), dbg = make("debug");
  for (int i = 0; i < 1500; ++i) cpu->step(), dbg->step();
  expect_schedule(*dbg);
  cpu->sync_host(), dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x))
      << "max relative difference " << max_rel_diff(cpu->state.x, dbg->state.x, 1e-9);
  EXPECT_TRUE(same_bits(cpu->state.v, dbg->state.v));
  EXPECT_TRUE(same_bits(cpu->state.f, dbg->state.f));
  EXPECT_EQ(dbg->state.v[0].x, 0.015);
  EXPECT_EQ(dbg->state.v[0].y, -0.02);
  EXPECT_EQ(dbg->state.v[5].z, 0.03);
  EXPECT_NE(dbg->state.v[5].x, 0.0) << "x is free: the pressure moves it";
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_GT(a.confining_pressure, 1e5) << "the pressure should be rising";
  EXPECT_EQ(a.confining_pressure, b.confining_pressure);
  EXPECT_NEAR(a.external_work, b.external_work, 1e-12 * std::fabs(a.external_work));
  EXPECT_NEAR(a.kinetic, b.kinetic, 1e-12 * a.kinetic);
}

TEST_P(DebugSchedule, AnUnstableRunStopsAtTheCpusStep) {
  // 2 times the stable-step bound: the kinetic energy runs away slowly, and the check that
  // reads the integration's sums (m v.v, non-finite velocities) stops the run at the CPU
  // backend's step.
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto run = [](const std::string& backend, bool& integrates) {
    Scene s = backend_elastic_scene(backend);
    s.solver.time_step_safety = 2.0;
    auto solver = backend_solver(s);
    std::string message;
    try {
      for (int i = 0; i < 20000; ++i) solver->step();
    } catch (const RunError& e) {
      message = e.what();
    }
    integrates = solver->device_loop() && solver->device_loop()->integrates();
    return std::make_pair(solver->step_count(), message);
  };
  bool integrates = false;
  const auto cpu = run("cpu", integrates), dbg = run("debug", integrates);
  EXPECT_EQ(integrates, std::string(GetParam()) == "auto");
  ASSERT_NE(cpu.second.find("unstable"), std::string::npos) << cpu.second;
  EXPECT_NE(dbg.second.find("unstable"), std::string::npos) << dbg.second;
  EXPECT_EQ(cpu.first, dbg.first);
  EXPECT_GT(cpu.first, 20) << "a slow runaway";
  RecordProperty("stopped_at_step", std::to_string(cpu.first));
}

TEST_P(DebugSchedule, AnInvertedTetIsNamedAsTheCpuNamesIt) {
  // One node driven through its tet's opposite face: the run stops on the inverted TET4 with
  // the CPU backend's message (step, time, element, J: the state the elements were computed
  // in), where the fused pass integrates too (it finds the inversion a step after the CPU would
  // evaluate it, and names it in the state it read).
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto run = [](const std::string& backend) {
    auto solver = backend_solver(backend_elastic_scene(backend));
    const Model& m = solver->model();
    int top = 0;  // the highest node
    for (std::size_t n = 0; n < m.X.size(); ++n)
      if (m.X[n].z > m.X[top].z) top = int(n);
    solver->prescribe(top, 0b111, Vec3{0, 0, -400});
    std::string message;
    try {
      for (int i = 0; i < 20000; ++i) solver->step();
    } catch (const RunError& e) {
      message = e.what();
    }
    return std::make_pair(solver->step_count(), message);
  };
  const auto cpu = run("cpu"), dbg = run("debug");
  ASSERT_NE(cpu.second.find("inverted"), std::string::npos) << cpu.second;
  EXPECT_EQ(dbg.second, cpu.second);
  EXPECT_EQ(dbg.first, cpu.first);
}

TEST(DebugBackend, ElementsLeftToTheFusedPassAreDoneWhenTheStateIsRead) {
  // Where the fused pass integrates, a step's force evaluation leaves its elements to the next
  // step's pass; a read of the state before it (a download) completes them by the same pass
  // without the step, and the next step then integrates by the integration's own passes.
  // Against the fused pass without the integration, driven the same way: the same bits.
  auto make = [](const char* schedule) {
    EnvSetting s("FDEM_DEVICE_SCHEDULE", schedule);
    return backend_solver(backend_fracture_scene("debug"));
  };
  auto stepping = make("auto"), plain = make("fused");
  for (int i = 0; i < 2000; ++i) stepping->step(), plain->step();
  ASSERT_TRUE(stepping->device_loop()->integrates());
  ASSERT_FALSE(plain->device_loop()->integrates());
  // One step of each loop, its bookkeeping (the works of contact and pressure over it, with the
  // velocities after it) at its first copy, as on a step of the solver; then a read.
  EXPECT_FALSE(stepping->device_loop()->step(stepping->dt()));
  EXPECT_FALSE(plain->device_loop()->step(plain->dt()));
  stepping->device_loop()->download();
  plain->device_loop()->download();
  EXPECT_TRUE(same_bits(stepping->state.x, plain->state.x))
      << "max relative difference " << max_rel_diff(stepping->state.x, plain->state.x, 1e-9);
  EXPECT_TRUE(same_bits(stepping->state.v, plain->state.v));
  EXPECT_TRUE(same_bits(stepping->state.f, plain->state.f));
  for (int i = 0; i < 10; ++i) stepping->step(), plain->step();
  const Monitors ml = stepping->measure(), mp = plain->measure();
  EXPECT_GT(std::fabs(ml.external_work), 0);
  EXPECT_NEAR(ml.external_work, mp.external_work, 1e-12 * std::fabs(mp.external_work));
  EXPECT_NEAR(ml.contact, mp.contact, 1e-12 * std::fabs(mp.contact) + 1e-18);
  EXPECT_NEAR(ml.energy_error, mp.energy_error, 1e-9);
  // The loop's step moved the state: the positions now are not those 2000 steps left.
  auto again = make("fused");
  for (int i = 0; i < 2000; ++i) again->step();
  again->sync_host();
  EXPECT_FALSE(same_bits(again->state.x, plain->state.x));
}

TEST(DebugBackend, NodesSharedByTetsKeepTheColourPasses) {
  // CE6s in the lower half of the box only: above, tets share nodes, so one tet's pass cannot
  // own its nodes' forces and the loop keeps the colour passes, still the CPU's bits.
  Scene elastic = backend_elastic_scene("debug");
  elastic.fracture.everywhere = false;
  elastic.fracture.boxes.push_back({{-1, -1, -1}, {1, 1, 0.006}});
  Scene cpu_scene = elastic;
  cpu_scene.solver.backend = Backend::cpu;
  auto cpu = backend_solver(cpu_scene);
  auto dbg = backend_solver(elastic);
  ASSERT_GT(dbg->model().ce6_nodes.size(), 0u);
  EXPECT_FALSE(dbg->device_loop()->fused());
  for (int i = 0; i < 1000; ++i) cpu->step(), dbg->step();
  cpu->sync_host(), dbg->sync_host();
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x));
  EXPECT_TRUE(same_bits(cpu->state.f, dbg->state.f));
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
  EXPECT_TRUE(dbg->device_loop()->integrates()) << "the default schedule, one rank";
  cpu->sync_host(), dbg->sync_host();
  EXPECT_LT(max_rel_diff(cpu->state.x, dbg->state.x, 1e-6), 1e-12);
  EXPECT_LT(max_rel_diff(cpu->state.v, dbg->state.v, 1e-3), 1e-9);
  EXPECT_EQ(dbg->state.v[0].x, 0.015);
  EXPECT_EQ(dbg->state.v[0].y, -0.02);
  EXPECT_EQ(cpu->state.v[0].x, 0.015);
  EXPECT_EQ(cpu->state.v[0].y, -0.02);
  EXPECT_NE(cpu->state.v[0].z, 7.0);
  EXPECT_NE(cpu->state.v[0].z, 0.0) << "z is free: gravity and the pressure move it";
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
  auto run = [](int cells, real velocity, int steps, bool pressure = true) {
    Scene s = backend_fracture_scene("debug");
    s.platens.velocity = velocity;
    s.confinement.enabled = pressure;
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
  // Launches (a GPU spends microseconds on each, however small) do not grow with the model
  // either. Where the fused pass integrates, a step with contact, platens and a confining
  // pressure launches 5 passes: the fused pass (the sums' reset before it adds its own, the last
  // evaluation's elements, with the forces contact, platens and pressure held for it, and the
  // step), the powers of the last contact and pressure forces with the new velocities and the
  // broad phase's watch (one launch), the contact pairs (narrow phase, friction and their
  // power), their sum per node and the platens (one launch), and the pressure's faces (with
  // their power). (Activation: on the steps that break a CE6.) Without the pressure, as in a
  // UCS test, 4. The last three (two without the pressure) are queued behind the step's copy,
  // before the host waits for it: the device works while the host finishes the step.
  EXPECT_EQ(small.traffic.launches, big.traffic.launches);
  EXPECT_EQ(small.traffic.launches, 5 * small.steps);
  EXPECT_EQ(small.traffic.launches_ahead, 3 * small.steps);
  const Seen dry = run(3, 0.5, 200, false);
  EXPECT_EQ(dry.rebuilds, 0);
  EXPECT_EQ(dry.traffic.launches, 4 * dry.steps);
  EXPECT_EQ(dry.traffic.launches_ahead, 2 * dry.steps);
  // Through fracture, activation and broad-phase rebuilds on the device: still a few hundred
  // bytes per step, none larger than one block of sums.
  const Seen frac = run(3, 4.0, 4000);
  EXPECT_GT(frac.broken, 20) << "the run should fracture";
  // Queued ahead on every step through fracture too; the rebuilds' reruns and their gathers (a
  // launch of their own then) come after the host's wait.
  EXPECT_EQ(frac.traffic.launches_ahead, 3 * frac.steps);
  EXPECT_GT(frac.traffic.launches, 5 * frac.steps + 2 * frac.rebuilds);
  EXPECT_GT(frac.rebuilds, 1);
  RecordProperty("bytes_to_host_per_step", std::to_string(double(frac.traffic.host_bytes) / frac.steps));
  RecordProperty("copies_to_host_per_step", std::to_string(double(frac.traffic.to_host) / frac.steps));
  EXPECT_LE(frac.traffic.largest_to_host, SumSlots::kAll * sizeof(real));  // the step's sums and the forces'
  EXPECT_LE(SumSlots::kAll, 43);  // (43: the kinematic conditions' reaction power joined the step's sums)
  EXPECT_LE(double(frac.traffic.host_bytes) / frac.steps, 1024);
  // Nothing to the device, rebuilds of the candidate list on the device included.
  EXPECT_EQ(frac.traffic.to_device, 0);
}

TEST(DebugBackend, HostCopyIsPoisonedUntilSynced) {
  auto dbg = backend_solver(backend_elastic_scene("debug"));
  dbg->step();
  // The device holds the state: the host copy must not be read as if current.
  EXPECT_TRUE(std::isnan(dbg->state.x[0].x));
  EXPECT_TRUE(std::isnan(dbg->state.v[5].z));
  EXPECT_TRUE(std::isnan(dbg->state.ce6[0].D[0]));
  dbg->sync_host();
  EXPECT_EQ(dbg->state.x[0].x, dbg->model().X[0].x + 0 * dbg->state.x[0].x);  // node 0 is on the bottom: still in place
  for (const Vec3& p : dbg->state.x) ASSERT_TRUE(std::isfinite(p.x + p.y + p.z));
  // A monitor row is summed on the device: the host copy stays as it was, and the row is the
  // CPU backend's to round-off.
  auto cpu = backend_solver(backend_elastic_scene("cpu"));
  for (int i = 0; i < 400; ++i) cpu->step();
  for (int i = 0; i < 399; ++i) dbg->step();
  const Monitors a = cpu->measure(), b = dbg->measure();
  EXPECT_TRUE(std::isnan(dbg->state.x[3].z));
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
  cpu->sync_host(), dbg->sync_host();
  for (Solver* s : {cpu.get(), dbg.get()}) {
    s->state.v[7] = s->state.v[7] + Vec3{0.01, 0, 0};
    // A damage the CE6's opening does not give (the law keeps the larger): the device must
    // read it from the upload, not take the CE6 as intact.
    for (real& d : s->state.ce6.damage[5].D) d = std::max(d, real(0.5));
    s->host_changed();
  }
  for (int i = 0; i < 1000; ++i) cpu->step(), dbg->step();
  // The damage set above goes up with the checkpoint (the fused pass reads a CE6's damage only
  // where the upload marked it damaged).
  cpu->sync_host(), dbg->sync_host();
  EXPECT_GE(dbg->state.ce6[5].D[0], 0.5);
  CheckpointOut out;
  dbg->save(out);
  auto resumed = backend_solver(backend_fracture_scene("debug"));
  CheckpointIn in(out.payload(), "(test checkpoint)");
  resumed->load(in);
  for (int i = 0; i < 2000; ++i) cpu->step(), dbg->step(), resumed->step();
  cpu->sync_host(), dbg->sync_host();
  resumed->sync_host();
  EXPECT_GT(cpu->measure().broken, 0);
  EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x));
  EXPECT_TRUE(same_bits(cpu->state.x, resumed->state.x));
  EXPECT_TRUE(same_bits(cpu->state.v, resumed->state.v));
  EXPECT_GE(cpu->state.ce6[5].D[0], 0.5);
  EXPECT_EQ(cpu->state.ce6[5].D[0], dbg->state.ce6[5].D[0]);
}

TEST(DebugBackend, CliRunGivesTheCpuFiles) {
  using namespace cli_test;
  TempDir dir("backend_debug");
  const std::string scene = quote((kData / "cli" / "restart_box.yaml").string());
  const Outcome a = cli_test::run_fdem("run " + scene + " -q -o " + quote((dir.path / "cpu").string()));
  const Outcome b =
      cli_test::run_fdem("run " + scene + " -q --backend debug -o " + quote((dir.path / "debug").string()));
  ASSERT_EQ(a.code, 0) << a.text;
  ASSERT_EQ(b.code, 0) << b.text;
  EXPECT_TRUE(has(b.text, "backend debug"));
  // The pair buffers start at the first list's size and grow as fragments meet; each growth is
  // reported.
  EXPECT_TRUE(has(b.text, "device: contact pair buffers grew to hold")) << b.text;
  EXPECT_FALSE(has(a.text, "pair buffers grew")) << a.text;
  auto read = [](const fs::path& p) {
    std::ifstream f(p);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  const std::string ma = read(dir.path / "cpu" / "monitors.csv"), mb = read(dir.path / "debug" / "monitors.csv");
  EXPECT_GT(ma.size(), 1000u);
  // The state agrees bit for bit; sums over many elements follow each backend's reduction order
  // and agree to round-off. The energy error is a difference of such sums, relative to the
  // external work: to 1e-12 absolute. Every other value to 1e-12 of itself.
  std::stringstream ra(ma), rb(mb);
  std::string la, lb, header;
  std::getline(ra, header), std::getline(rb, lb);
  ASSERT_EQ(header, lb);
  std::vector<std::string> names;
  for (std::stringstream h(header); std::getline(h, la, ',');) names.push_back(la);
  int rows = 0;
  while (std::getline(ra, la)) {
    ASSERT_TRUE(std::getline(rb, lb)) << "the debug run has fewer rows";
    std::stringstream ca(la), cb(lb);
    std::string va, vb;
    for (const std::string& name : names) {
      ASSERT_TRUE(std::getline(ca, va, ',') && std::getline(cb, vb, ',')) << la;
      if (va == vb) continue;
      const double a = std::stod(va), b = std::stod(vb);
      const double tol = name == "energy_error" ? 1e-12 : 1e-12 * std::max(std::fabs(a), std::fabs(b));
      EXPECT_LE(std::fabs(a - b), tol) << name << " in row " << rows << ": " << va << " against " << vb;
    }
    ++rows;
  }
  EXPECT_FALSE(std::getline(rb, lb)) << "the debug run has more rows";
  EXPECT_GT(rows, 20);
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
  const Outcome o = cli_test::run_fdem("run " + quote(kNoGmshScene.string()) + " -q --backend cuda -o " +
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

TEST(DebugBackend, TheSteppingPassTakesNodeMassesFromTetVolumesOnlyWhereTheyAreTheModelsBits) {
  // Every node's mass is rho V0 / 4 of its one tet (model/build.cpp), so the pass that steps
  // computes it from V0 instead of reading it: 8 bytes a tet corner less in the traffic model.
  // One mass a last bit off (a model from elsewhere) makes the pass read the masses again, and
  // the run stays the CPU's bit for bit either way (with gravity, whose force is m g).
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", "auto");
  double bytes[2] = {0, 0};  // the traffic model's after the first step: masses computed, read
  auto run = [&bytes](bool perturb, const std::string& backend) {
    Scene s = backend_fracture_scene(backend);
    s.gravity = {0, 0, -9.81};
    Model m = build_model(structured_box_mesh({0.006, 0.006, 0.012}, 3, 3, 6), s);
    if (perturb) m.mass[7] = std::nextafter(m.mass[7], 1.0);
    auto solver = std::make_unique<Solver>(s, std::move(m));
    solver->step();
    if (solver->device_loop()) bytes[perturb] = solver->device_loop()->bytes_per_step();
    for (int i = 1; i < 600; ++i) solver->step();
    return solver;
  };
  for (bool perturb : {false, true}) {
    auto cpu = run(perturb, "cpu"), dbg = run(perturb, "debug");
    ASSERT_TRUE(dbg->device_loop()->integrates());
    cpu->sync_host(), dbg->sync_host();
    EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x)) << perturb;
    EXPECT_TRUE(same_bits(cpu->state.v, dbg->state.v)) << perturb;
    const Monitors a = cpu->measure(), b = dbg->measure();
    EXPECT_GT(a.kinetic, 0);
    EXPECT_NEAR(a.kinetic, b.kinetic, 1e-12 * a.kinetic) << perturb;
  }
  EXPECT_EQ(bytes[1] - bytes[0], 324 * 4 * sizeof(real));  // 324 tets, 4 corners each
}

TEST(DebugBackend, TwoBlocksPerSmReachesTheFusedPassAndKeepsTheCpuBits) {
  // FDEM_CUDA_BLOCKS_PER_SM=2 compiles the fused pass's CUDA kernels for two resident blocks; on
  // the host the same pass runs through the other branch of its launch: the same bits as the CPU.
  EnvSetting blocks("FDEM_CUDA_BLOCKS_PER_SM", "2");
  for (const char* schedule : {"auto", "fused", "colour"}) {
    EnvSetting s("FDEM_DEVICE_SCHEDULE", schedule);
    auto cpu = backend_solver(backend_elastic_scene("cpu"));
    auto dbg = backend_solver(backend_elastic_scene("debug"));
    EXPECT_EQ(dbg->device_loop()->blocks_per_sm(), std::string(schedule) == "colour" ? 1 : 2) << schedule;
    for (int i = 0; i < 500; ++i) cpu->step(), dbg->step();
    cpu->sync_host(), dbg->sync_host();
    EXPECT_TRUE(same_bits(cpu->state.x, dbg->state.x)) << schedule;
    EXPECT_TRUE(same_bits(cpu->state.f, dbg->state.f)) << schedule;
    const Monitors a = cpu->measure(), b = dbg->measure();
    EXPECT_EQ(a.axial_stress, b.axial_stress) << schedule;
    EXPECT_GT(a.viscous, 0) << schedule;  // the pass's own sums
    EXPECT_NEAR(a.viscous, b.viscous, 1e-10 * a.viscous) << schedule;
    EXPECT_NEAR(a.kinetic, b.kinetic, 1e-10 * a.kinetic) << schedule;
  }
}

TEST(DebugBackend, AnUnknownBlocksPerSmIsAClearInputError) {
  EnvSetting blocks("FDEM_CUDA_BLOCKS_PER_SM", "4");
  try {
    backend_solver(backend_elastic_scene("debug"));
    ADD_FAILURE() << "FDEM_CUDA_BLOCKS_PER_SM=4 was accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("FDEM_CUDA_BLOCKS_PER_SM=4"), std::string::npos) << what;
    EXPECT_NE(what.find("Fix: FDEM_CUDA_BLOCKS_PER_SM=1"), std::string::npos) << what;
  }
  using namespace cli_test;
  TempDir dir("blocks_per_sm");
  const Outcome o = run_cmd("FDEM_CUDA_BLOCKS_PER_SM=4 " + kEnv + quote(kExe) + " run " + quote(kNoGmshScene.string()) +
                            " -q --backend debug -o " + quote((dir.path / "out").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "FDEM_CUDA_BLOCKS_PER_SM=4")) << o.text;
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
