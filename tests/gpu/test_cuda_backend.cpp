// The CUDA backend against the CPU backend (issue 5): the same scenes as test_backends.cpp.
// Built where nvcc is found; every test skips where no GPU is visible. The device sums each
// node's forces in the CPU's order (colour by colour, or fused: each tet's TET4 then its CE6s in
// colour order); nvcc contracts nothing into fused multiply-adds
// (--fmad=false) and the loop's log, exp and cbrt are core/portable_math.hpp's, built from
// exactly rounded operations, so the states should agree bit for bit. Only the monitors' sums
// differ in order (a tree of blocks on the device), and state that follows a sum (a
// hydrostatic confining pressure) then differs by round-off.
#include <gtest/gtest.h>
#include <mpi.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "backend_support.hpp"
#include "core/error.hpp"
#include "gpu/cuda_flags.hpp"
#include "model/structured.hpp"

using namespace fdem;
using namespace fdem::test;

namespace {

void need_gpu() {
  if (cuda_device_count() == 0) GTEST_SKIP() << "no CUDA device visible (" << cuda_device_count_error() << ")";
}

}  // namespace

// The schedules of the element passes: "auto" (TET4, CE6 and the integration in one pass here),
// "fused" (TET4 and CE6 in one pass) and "colour".
class CudaSchedule : public ::testing::TestWithParam<const char*> {};
INSTANTIATE_TEST_SUITE_P(Schedule, CudaSchedule, ::testing::Values("auto", "fused", "colour"));

TEST_P(CudaSchedule, ElasticBoxMatchesCpuTo1e10) {
  // The CE6 penalty amplifies a last-bit difference in a position some 10^7-fold in the forces
  // (measured on the host: a fused multiply-add build against one without, or the C library's
  // log against portable_log, give forces 1e-4 apart after these 3000 steps), so 1e-10 in the
  // forces holds only if the device computes the host's bits: asserted as well.
  need_gpu();
  if (IsSkipped()) return;
#ifdef FDEM_CUDA_FMAD
  GTEST_SKIP() << "built with FDEM_CUDA_FMAD=ON: nvcc fuses multiply-adds, so the bits differ";
#endif
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_elastic_scene("cpu"));
  auto gpu = backend_solver(backend_elastic_scene("cuda"));
  ASSERT_EQ(gpu->backend(), Backend::cuda);
  for (int i = 0; i < 3000; ++i) cpu->step(), gpu->step();
  EXPECT_EQ(gpu->device_loop()->fused(), std::string(GetParam()) != "colour");
  EXPECT_EQ(gpu->device_loop()->integrates(), std::string(GetParam()) == "auto");
  cpu->sync_host(), gpu->sync_host();
  const real dx = max_rel_diff(cpu->state.x, gpu->state.x, 1e-6);
  const real df = max_rel_diff(cpu->state.f, gpu->state.f, 1e-6 * max_force(cpu->state.f));
  RecordProperty("max_rel_diff_x", std::to_string(dx));
  RecordProperty("max_rel_diff_f", std::to_string(df));
  EXPECT_LT(dx, 1e-10);
  EXPECT_LT(df, 1e-10);
  ASSERT_EQ(cpu->state.x.size(), gpu->state.x.size());
  EXPECT_EQ(std::memcmp(cpu->state.x.data(), gpu->state.x.data(), cpu->state.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(cpu->state.v.data(), gpu->state.v.data(), cpu->state.v.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(cpu->state.f.data(), gpu->state.f.data(), cpu->state.f.size() * sizeof(Vec3)), 0);
  const Monitors a = cpu->measure(), b = gpu->measure();
  EXPECT_GT(a.axial_stress, 1e6);
  EXPECT_NEAR(a.axial_stress, b.axial_stress, 1e-10 * a.axial_stress);
  EXPECT_NEAR(a.external_work, b.external_work, 1e-9 * a.external_work);
}

TEST_P(CudaSchedule, FracturingBoxPeakWithin1PercentBrokenWithin5Percent) {
  need_gpu();
  if (IsSkipped()) return;
  EnvSetting schedule("FDEM_DEVICE_SCHEDULE", GetParam());
  auto cpu = backend_solver(backend_fracture_scene("cpu"));
  auto gpu = backend_solver(backend_fracture_scene("cuda"));
  const FractureResult a = run_fracture(*cpu, 4000), b = run_fracture(*gpu, 4000);
  RecordProperty("peak_cpu_Pa", std::to_string(a.peak));
  RecordProperty("peak_cuda_Pa", std::to_string(b.peak));
  RecordProperty("broken_cpu", std::to_string(a.broken));
  RecordProperty("broken_cuda", std::to_string(b.broken));
  EXPECT_GT(a.broken, 20);
  EXPECT_NEAR(b.peak, a.peak, 0.01 * a.peak);
  EXPECT_LE(std::abs(b.broken - a.broken), std::max(1.0, 0.05 * a.broken));
  EXPECT_GT(gpu->measure().contacts, 0);
  // The activation on the GPU (raise_flag: an atomicOr on the word holding the tet's flag):
  // exactly the tets around its broken CE6s and at the loaded ends.
  cpu->sync_host(), gpu->sync_host();
  EXPECT_EQ(flags_from_breaks(*gpu), gpu->contacts.tet_flags);
  // Through fracture and contact the states should be the same bits too (the debug backend's
  // are): recorded here, asserted once a GPU has shown it.
  cpu->sync_host();
  gpu->sync_host();
  RecordProperty("x_bit_identical",
                 cpu->state.x.size() == gpu->state.x.size() &&
                     std::memcmp(cpu->state.x.data(), gpu->state.x.data(), cpu->state.x.size() * sizeof(Vec3)) == 0);
  RecordProperty("max_rel_diff_x", std::to_string(max_rel_diff(cpu->state.x, gpu->state.x, 1e-6)));
}

TEST(CudaBackend, GravityHydrostaticPressureAndPrescribedNodesMatchCpu) {
  need_gpu();
  if (IsSkipped()) return;
  auto cpu = backend_gravity_solver("cpu"), gpu = backend_gravity_solver("cuda");
  for (int i = 0; i < 1500; ++i) cpu->step(), gpu->step();
  cpu->sync_host(), gpu->sync_host();
  EXPECT_LT(max_rel_diff(cpu->state.x, gpu->state.x, 1e-6), 1e-10);
  EXPECT_EQ(gpu->state.v[0].x, 0.015);
  const Monitors a = cpu->measure(), b = gpu->measure();
  EXPECT_NEAR(a.confining_pressure, b.confining_pressure, 1e-9 * a.confining_pressure);
}

TEST(CudaBackend, BoundaryConditionsMatchCpu) {
  // Every condition type on a box with CE6s on every face (so the fused pass prescribes):
  // rollers, a fixed face, a pressed end on a table, a pressure, a shearing traction and an
  // absorbing face. The positions agree as the other scenes' do; the conditions' forces and
  // works are sums of the device's own order, so to round-off.
  need_gpu();
  if (IsSkipped()) return;
  auto solver = [](const std::string& backend) {
    const Scene s = parse_scene(
        "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
        "platens: none\ncontact: {activation: none}\n"
        "boundary_conditions:\n"
        "  - {surface: xmin, type: roller}\n"
        "  - {surface: ymin, type: roller}\n"
        "  - {surface: zmin, type: fixed}\n"
        "  - {surface: zmax, type: velocity, velocity: [~, ~, -0.05], time_function: {table: [[0, 0], [2e-5, 1]]}}\n"
        "  - {surface: ymax, type: pressure, pressure: 1e6, time_function: {shape: smooth, duration: 2e-5}}\n"
        "  - {surface: xmax, type: traction, traction: [0, 0, 2e5]}\n"
        "  - {surface: xmax, type: absorbing}\n"
        "solver: {threads: 1, backend: " +
            backend + ", end: {steps: 1500}}\n",
        "bc.yaml");
    return std::make_unique<Solver>(s, build_model(structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8), s));
  };
  auto cpu = solver("cpu"), gpu = solver("cuda");
  for (int i = 0; i < 1500; ++i) cpu->step(), gpu->step();
  cpu->sync_host(), gpu->sync_host();
  EXPECT_LT(max_rel_diff(cpu->state.x, gpu->state.x, 1e-6), 1e-10);
  const Monitors a = cpu->measure(), b = gpu->measure();
  ASSERT_EQ(a.condition_columns, 28);
  for (int k = 0; k < a.condition_columns; ++k)
    EXPECT_NEAR(a.conditions[k], b.conditions[k], 1e-9 * std::fabs(a.conditions[k]) + 1e-12) << k;
  EXPECT_NEAR(a.external_work, b.external_work, 1e-9 * std::fabs(a.external_work));
}

TEST(CudaBackend, TwoRunsThroughFractureAreTheSameBitForBit) {
  // The device's sums add in an order fixed by the element counts alone (block sums, then the
  // blocks in order: no atomicAdd), so a run repeats itself exactly, monitors included.
  need_gpu();
  if (IsSkipped()) return;
  auto a = backend_solver(backend_fracture_scene("cuda"));
  auto b = backend_solver(backend_fracture_scene("cuda"));
  const FractureResult ra = run_fracture(*a, 4000), rb = run_fracture(*b, 4000);
  a->sync_host();
  b->sync_host();
  EXPECT_GT(ra.broken, 20);
  EXPECT_EQ(ra.peak, rb.peak);
  EXPECT_EQ(ra.broken, rb.broken);
  ASSERT_EQ(a->state.x.size(), b->state.x.size());
  EXPECT_EQ(std::memcmp(a->state.x.data(), b->state.x.data(), a->state.x.size() * sizeof(Vec3)), 0);
  const Monitors ma = a->measure(), mb = b->measure();
  EXPECT_EQ(ma.external_work, mb.external_work);
  EXPECT_EQ(ma.kinetic, mb.kinetic);
  EXPECT_EQ(ma.contacts, mb.contacts);
}

TEST(CudaBackend, TwoBlocksPerSmGivesTheSameBitsThroughFracture) {
  // FDEM_CUDA_BLOCKS_PER_SM=2: the fused pass's kernels with half the registers (ptxas spills the
  // rest); the same arithmetic and the same grid, so the same bits as the default build's kernels.
  need_gpu();
  if (IsSkipped()) return;
  auto one = backend_solver(backend_fracture_scene("cuda"));
  std::unique_ptr<Solver> two;
  {
    EnvSetting blocks("FDEM_CUDA_BLOCKS_PER_SM", "2");
    two = backend_solver(backend_fracture_scene("cuda"));
  }
  ASSERT_EQ(one->device_loop()->blocks_per_sm(), 1);
  ASSERT_EQ(two->device_loop()->blocks_per_sm(), 2);
  ASSERT_TRUE(two->device_loop()->integrates());
  const FractureResult a = run_fracture(*one, 4000), b = run_fracture(*two, 4000);
  one->sync_host();
  two->sync_host();
  EXPECT_GT(a.broken, 20);
  EXPECT_EQ(a.peak, b.peak);
  EXPECT_EQ(a.broken, b.broken);
  ASSERT_EQ(one->state.x.size(), two->state.x.size());
  EXPECT_EQ(std::memcmp(one->state.x.data(), two->state.x.data(), one->state.x.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(one->state.f.data(), two->state.f.data(), one->state.f.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(one->measure().external_work, two->measure().external_work);
}

TEST(CudaBackend, TheDebugBackendCountsTheCopiesTheCudaBackendMakes) {
  // device::traffic() is the CUDA backend's count of its copies between host and device; the
  // debug backend counts the copies the CUDA backend would make, and the CI's traffic test
  // (test_backends: OnlyAFewScalarsCrossToTheHostBetweenMonitorRows) relies on that. The same
  // steps and monitor rows on both: the same copies, bytes, largest copy and launches (and of
  // those, the launches queued behind a copy the host waits for).
  need_gpu();
  if (IsSkipped()) return;
  auto run = [](const char* backend) {
    auto s = backend_solver(backend_elastic_scene(backend));
    s->step();  // the first step uploads the state
    device::reset_traffic();
    for (int i = 1; i <= 300; ++i) {
      s->step();
      if (i % 100 == 0) s->measure();
    }
    return device::traffic();
  };
  const device::Traffic d = run("debug"), c = run("cuda");
  EXPECT_GT(c.to_host, 0);
  EXPECT_EQ(d.to_host, c.to_host);
  EXPECT_EQ(d.host_bytes, c.host_bytes);
  EXPECT_EQ(d.to_device, c.to_device);
  EXPECT_EQ(d.device_bytes, c.device_bytes);
  EXPECT_EQ(d.largest_to_host, c.largest_to_host);
  EXPECT_GT(c.launches, 300);
  EXPECT_EQ(d.launches, c.launches);
  EXPECT_GT(c.launches_ahead, 0);
  EXPECT_EQ(d.launches_ahead, c.launches_ahead);
}

TEST(CudaBackend, AProgramThatNeverStartedMpiGetsTheDeviceOrTheReasonNotAnAbort) {
  // This program never calls MPI_Init (gtest_main), like a library user's: choosing the device
  // must not call MPI then (a collective before MPI_Init aborts the process, which would end
  // every test after the first CUDA solver). Runs with or without a GPU.
  int mpi = 1;
  MPI_Initialized(&mpi);
  ASSERT_EQ(mpi, 0) << "this test is about a program without MPI_Init";
  if (cuda_device_count() > 0) {
    auto gpu = backend_solver(backend_elastic_scene("cuda"));
    auto cpu = backend_solver(backend_elastic_scene("cpu"));
    EXPECT_EQ(gpu->backend(), Backend::cuda);
    for (int i = 0; i < 10; ++i) gpu->step(), cpu->step();
    cpu->sync_host(), gpu->sync_host();
    EXPECT_EQ(std::memcmp(cpu->state.x.data(), gpu->state.x.data(), cpu->state.x.size() * sizeof(Vec3)), 0);
  } else {
    try {
      backend_solver(backend_elastic_scene("cuda"));
      ADD_FAILURE() << "the cuda backend started without a visible GPU";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no CUDA device is visible"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("--backend cpu"), std::string::npos) << e.what();
    }
  }
}

TEST(CudaBackend, RaisedFlagsAreCountedOnceAndLeaveTheirNeighboursInTheWord) {
  // raise_flag on the GPU: an atomicOr on the 4-byte word that holds the byte, so that the
  // threads raising one tet's flag count it once (the activation, the flags merged over ranks).
  // 41 flags: the last word only partly the array's; every flag raised by about 2,400 threads.
  need_gpu();
  if (IsSkipped()) return;
  std::vector<std::uint8_t> flags(41, 0);
  flags[3] = flags[4] = 1;  // raised before: one the rule leaves, one it would raise
  std::vector<std::uint8_t> expected = flags;
  long fresh = 0;
  for (int j = 0; j < int(flags.size()); ++j)
    if (raised_by_rule(j) && !expected[j]) expected[j] = 1, ++fresh;
  EXPECT_EQ(raise_flags_on_cuda(flags, 100000), fresh);
  EXPECT_EQ(flags, expected);
  std::vector<long> longs(8, 0);  // (7 i mod 8 visits every flag)
  raise_long_flags_on_cuda(longs, 1000);
  EXPECT_EQ(longs, (std::vector<long>{0, 1, 1, 0, 1, 1, 0, 1}));
}
