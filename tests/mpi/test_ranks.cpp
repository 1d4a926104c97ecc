// Multi-rank runs against one rank. Launched by ctest through mpiexec at 1 and at 2 ranks
// (label mpi). Every rank also runs the whole model on its own (MPI_COMM_SELF) as the one-rank
// reference and compares the nodes and CE6s it owns with it, by global id; sums go through
// MPI. With one rank the decomposed path is the plain one and the comparisons are exact.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <mpi.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <memory>
#include <set>

#include "backend_support.hpp"
#include "contact/broad_phase.hpp"
#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "io/checkpoint.hpp"
#include "io/fields.hpp"
#include "model/structured.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"

using namespace fdem;

namespace {

int world_rank() {
  return rank_in(MPI_COMM_WORLD);
}
int world_size() {
  return size_of(MPI_COMM_WORLD);
}
double max_over_ranks(double v) {
  return fdem::max_over_ranks(MPI_COMM_WORLD, v);
}
double sum_over_ranks(double v) {
  return fdem::sum_over_ranks(MPI_COMM_WORLD, v);
}

/// This rank's solver of the model: METIS (or the given partition) over the world's ranks.
std::unique_ptr<Solver> decomposed(const Scene& scene, const Model& global, std::vector<int> part = {}) {
  if (part.empty()) part = partition_tets(global, world_size());
  RankModel rm = extract_rank(global, part, world_rank(), default_reach(global, scene));
  return std::make_unique<Solver>(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
}

/// Largest difference of owned node vectors (by global id) over the ranks, relative to the
/// largest reference value (infinite where a value is NaN).
double node_error(const Solver& d, const std::vector<Vec3>& a, const std::vector<Vec3>& ref,
                  const std::vector<Vec3>& ref_origin, const std::vector<Vec3>& origin) {
  const Decomposition& dd = d.decomposition();
  double diff = 0, scale = 0;
  for (std::size_t n = 0; n < a.size(); ++n) {
    if (!d.owned_nodes()[n]) continue;
    const long g = dd.distributed() ? dd.node_global[n] : long(n);
    const Vec3 u = a[n] - origin[n], ur = ref[g] - ref_origin[g];
    const double e = norm(u - ur);
    diff = std::isnan(e) ? INFINITY : std::max(diff, e);  // a NaN (a stale host copy) fails
    scale = std::max(scale, norm(ur));
  }
  return max_over_ranks(diff) / max_over_ranks(scale);
}

/// A UCS box of structured tets (nx x nx x 2nx cells).
Scene box_scene() {
  Scene s = test::test_scene();
  s.solver.mass_scaling = 10;
  s.platens.velocity = 0.5;
  return s;
}

/// The box confined at 1 MPa and loaded at 1 m/s through fracture, with contact.
Scene fracturing_scene() {
  Scene scene = box_scene();
  scene.platens.velocity = 1.0;
  scene.platens.ramp_time = 2e-5;
  scene.confinement.enabled = true;
  scene.confinement.pressure = 1e6;
  scene.confinement.path = ConfinementPath::constant;
  scene.confinement.ramp_time = 2e-5;
  scene.solver.time_step_safety = 0.9;
  return scene;
}

/// Two 0.01 m blocks of 48 tets, one on the other (or `gap` m above it), offset sideways.
Mesh two_blocks(real gap = 0) {
  Mesh a = structured_box_mesh({0.01, 0.01, 0.01}, 2, 2, 2);
  const Mesh b = structured_box_mesh({0.01, 0.01, 0.01}, 2, 2, 2);
  const int off = int(a.vertices.size());
  for (Vec3 p : b.vertices) a.vertices.push_back(p + Vec3{0.001, 0.0005, 0.01 + gap});
  for (auto q : b.tets) a.tets.push_back({q[0] + off, q[1] + off, q[2] + off, q[3] + off});
  a.source = "two blocks";
  return a;
}
Scene two_blocks_scene() {
  Scene scene = box_scene();
  scene.platens.enabled = false;
  scene.contact.activation = Activation::full;
  scene.fracture.everywhere = false;  // two continuous blocks: contact only between them
  return scene;
}
bool upper(const Model& m, int t) {
  real zc = 0;
  for (int n : m.tet_nodes[t]) zc += 0.25 * m.X[n].z;
  return zc > 0.01;
}
/// The lower block on rank 0, the upper on the last rank.
std::vector<int> block_per_rank(const Model& m) {
  std::vector<int> part(m.tet_nodes.size());
  for (std::size_t t = 0; t < part.size(); ++t) part[t] = upper(m, int(t)) ? world_size() - 1 : 0;
  return part;
}

/// The rank of sector k of `ranks` equal sectors around the vertical line through `axis`, by
/// the angle of each tet's centroid (the tets `only` selects; the others on rank 0).
std::vector<int> sectors(const Model& m, Vec3 axis, const std::function<bool(int)>& only = {}) {
  std::vector<int> part(m.tet_nodes.size(), 0);
  for (std::size_t t = 0; t < part.size(); ++t) {
    if (only && !only(int(t))) continue;
    Vec3 c{0, 0, 0};
    for (int n : m.tet_nodes[t]) c = c + 0.25 * m.X[n];
    const double turn = (std::atan2(c.y - axis.y, c.x - axis.x) + M_PI) / (2 * M_PI);  // 0..1
    part[t] = std::min(world_size() - 1, int(turn * world_size()));
  }
  return part;
}

/// The most ranks among a tet's own and its face neighbours' (through its CE6s), over the tets.
int most_ranks_around_a_tet(const Model& m, const std::vector<int>& part) {
  std::vector<std::set<int>> around(m.tet_nodes.size());
  for (std::size_t t = 0; t < part.size(); ++t) around[t].insert(part[t]);
  for (const auto& ct : m.ce6_tets) around[ct[0]].insert(part[ct[1]]), around[ct[1]].insert(part[ct[0]]);
  std::size_t most = 0;
  for (const auto& a : around) most = std::max(most, a.size());
  return int(most);
}

/// A run on one rank and on several side by side, 3000 steps with a monitor row every 50:
/// the last rows, the peaks, and `row` called at each row.
struct SideBySide {
  Monitors mr, md;
  double peak_r = 0, peak_d = 0;
};
SideBySide run_side_by_side(Solver& ref, Solver& d,
                            const std::function<void(const Monitors&, const Monitors&)>& row = {}) {
  SideBySide r;
  for (int i = 1; i <= 3000; ++i) {
    ref.step();
    d.step();
    if (i % 50) continue;
    r.mr = ref.measure();
    r.md = d.measure();
    r.peak_r = std::max(r.peak_r, r.mr.axial_stress);
    r.peak_d = std::max(r.peak_d, r.md.axial_stress);
    if (row) row(r.mr, r.md);
  }
  return r;
}
}  // namespace

class RanksElastic : public ::testing::TestWithParam<const char*> {};

TEST_P(RanksElastic, CurveAndNodesMatchOneRank) {
  // Before any CE6 is damaged: the same curve and node positions to round-off. Without
  // contact a rank receives only the ghost nodes its elements read; with it, all it holds.
  Scene scene = box_scene();
  scene.contact.activation = test::named<Activation>(GetParam());
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  Solver ref(scene, global);
  auto d = decomposed(scene, global);
  double worst_curve = 0;
  Monitors mr, md;
  for (int i = 1; i <= 2000; ++i) {
    ref.step();
    d->step();
    if (i % 100) continue;
    mr = ref.measure();
    md = d->measure();
    const double pairs[][2] = {{mr.axial_stress, md.axial_stress},
                               {mr.lateral_strain, md.lateral_strain},
                               {mr.strain, md.strain},
                               {mr.kinetic, md.kinetic},
                               {mr.external_work, md.external_work},
                               {mr.cohesive_stored, md.cohesive_stored},
                               {mr.lateral_stress, md.lateral_stress},
                               {mr.force_bottom, md.force_bottom}};
    for (const auto& p : pairs) worst_curve = std::max(worst_curve, std::fabs(p[0] - p[1]) / std::fabs(p[0]));
  }
  EXPECT_EQ(md.damaged, 0) << "still elastic";
  EXPECT_GT(md.axial_stress, 1e6) << "loaded";
  EXPECT_EQ(md.step, mr.step);
  EXPECT_LT(worst_curve, 1e-10);
  const double ex = node_error(*d, d->state.x, ref.state.x, ref.model().X, d->model().X);
  const double ev = node_error(*d, d->state.v, ref.state.v, std::vector<Vec3>(ref.state.v.size()),
                               std::vector<Vec3>(d->state.v.size()));
  EXPECT_LT(ex, 1e-10) << "displacements";
  EXPECT_LT(ev, 1e-10) << "velocities";
  if (world_rank() == 0)
    std::printf("elastic, contact %s, %d rank(s): curve %.2e, displacement %.2e, velocity %.2e (relative)\n",
                GetParam(), world_size(), worst_curve, ex, ev);
}

INSTANTIATE_TEST_SUITE_P(Contact, RanksElastic, ::testing::Values("adaptive", "none"));

TEST(Ranks, FracturingBoxMatchesOneRank) {
  // Through the peak with contact: the same peak stress and broken-CE6 count, with CE6s
  // breaking on the partition boundary.
  const Scene scene = fracturing_scene();
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  Solver ref(scene, global);
  auto d = decomposed(scene, global);
  // Ghost nodes received every step (all ranks): contact reads a ghost tet's nodes while it is
  // active, so the halo carries those of the active ghost tets only. With full activation
  // that is every ghost node; with adaptive activation fewer, growing as CE6s break.
  auto received = [](const Solver& s) { return sum_over_ranks(double(s.halo_bytes_per_step()) / (2 * sizeof(Vec3))); };
  double ghosts = 0;
  for (auto o : d->owned_nodes()) ghosts += !o;
  ghosts = sum_over_ranks(ghosts);
  Scene full = scene;
  full.contact.activation = Activation::full;
  const double received_full = received(*decomposed(full, global)), received_start = received(*d);
  const SideBySide run = run_side_by_side(ref, *d);
  const Monitors &mr = run.mr, &md = run.md;
  const double peak_r = run.peak_r, peak_d = run.peak_d;
  ASSERT_GT(mr.broken, 20) << "the box fractured";
  EXPECT_LT(std::fabs(peak_d - peak_r), 0.005 * peak_r);
  EXPECT_LE(std::fabs(double(md.broken - mr.broken)), 0.02 * mr.broken);
  // Broken CE6s whose two tets belong to different ranks (counted once, by the CE6's owner).
  const Model& m = d->model();
  d->sync_host();
  double on_boundary = 0;
  for (std::size_t c = 0; c < d->state.ce6.size(); ++c)
    if (d->owned_ce6()[c] && d->state.ce6[c].mode != 0 &&
        d->owned_tets()[m.ce6_tets[c][0]] != d->owned_tets()[m.ce6_tets[c][1]])
      on_boundary += 1;
  on_boundary = sum_over_ranks(on_boundary);
  const double received_end = received(*d);  // collective: on every rank, outside the branches
  if (world_size() > 1) {
    EXPECT_GT(on_boundary, 0);
    EXPECT_EQ(received_full, ghosts);
    EXPECT_LT(received_start, 0.8 * ghosts);
    EXPECT_GT(received_end, received_start);
    EXPECT_LE(received_end, ghosts);
  }
  if (world_rank() == 0)
    std::printf(
        "ghost nodes received per step: %g of %g with full activation, adaptive %g at the start and %g "
        "after fracture\n",
        received_full, ghosts, received_start, received_end);
  if (world_rank() == 0)
    std::printf("fracturing, %d rank(s): peak %.6g against %.6g MPa, broken %ld against %ld, %g on the boundary\n",
                world_size(), peak_d / 1e6, peak_r / 1e6, md.broken, mr.broken, on_boundary);
}

TEST(Ranks, SectorsMeetingAtATetMergeItsActivationFlagsAsOneRank) {
  // The fracturing box cut into equal sectors around its vertical axis, one a rank: at three
  // ranks and more, tets on the axis have face neighbours on three ranks, and each of those
  // ranks may raise the tet's activation flag. The ranks' flags are OR-ed: the active tets, the
  // peak and the broken CE6s are the one-rank run's.
  if (world_size() < 3) GTEST_SKIP() << "needs three ranks or more (mpi_ranks_3, mpi_ranks_4)";
  const Scene scene = fracturing_scene();
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  const std::vector<int> part = sectors(global, {0.005, 0.005, 0});
  const int around = most_ranks_around_a_tet(global, part);
  ASSERT_GE(around, 3) << "no tet has neighbours on three ranks";
  Solver ref(scene, global);
  auto d = decomposed(scene, global, part);
  double worst_active = 0;
  const SideBySide run = run_side_by_side(ref, *d, [&](const Monitors& mr, const Monitors& md) {
    if (md.broken == mr.broken)  // the same CE6s broken: the same tets active
      worst_active = std::max(worst_active, std::fabs(double(md.active_tets - mr.active_tets)));
  });
  const Monitors &mr = run.mr, &md = run.md;
  const double peak_r = run.peak_r, peak_d = run.peak_d;
  ASSERT_GT(mr.broken, 20) << "the box fractured";
  EXPECT_GT(mr.active_tets, 0);
  EXPECT_EQ(worst_active, 0) << "active tets differ from one rank's at the same broken count";
  // Through fracture the ranks' sums, added in another order, differ by round-off, and a CE6
  // near its strength may break a step apart: the fracturing tolerances (at 4 ranks:
  // 112 broken against 109).
  EXPECT_LT(std::fabs(peak_d - peak_r), 0.01 * peak_r);
  EXPECT_LE(std::fabs(double(md.broken - mr.broken)), 0.05 * mr.broken);
  if (world_rank() == 0)
    std::printf(
        "sectors, %d rank(s): a tet's neighbours on up to %d ranks; peak %.6g against %.6g MPa, broken %ld "
        "against %ld, active %ld against %ld\n",
        world_size(), around, peak_d / 1e6, peak_r / 1e6, md.broken, mr.broken, md.active_tets, mr.active_tets);
}

class RanksDevice : public ::testing::TestWithParam<const char*> {};

TEST_P(RanksDevice, DeviceLoopGivesTheCpuBackendsRun) {
  // The device loop (halo packed and unpacked on the device, staged through the host; flags
  // merged from device arrays; candidate lists built on the device with the owned-node filter)
  // against the CPU backend on the same partition, through fracture with contact (which
  // FracturingBoxMatchesOneRank holds to one rank's run). debug: bit for bit. cuda (where a GPU
  // is visible; the ranks share it): the tolerances, peak within 0.5 % and broken CE6s
  // within 2 %.
  // "+mpi": the halo hands its device buffers to MPI itself (FDEM_GPU_AWARE_MPI=1), as with a
  // GPU-aware MPI; the debug backend's device memory is host memory, so any MPI takes them.
  // "+colour": the colour passes instead of the fused element pass (FDEM_DEVICE_SCHEDULE).
  const std::string param = GetParam();
  auto ends = [&](const std::string& tail) {
    return param.size() > tail.size() && param.compare(param.size() - tail.size(), tail.size(), tail) == 0;
  };
  const bool direct = ends("+mpi"), colour = ends("+colour");
  const std::string backend = param.substr(0, param.find('+'));
  test::EnvSetting schedule("FDEM_DEVICE_SCHEDULE", colour ? "colour" : "auto");
  if (backend == "cuda" && cuda_device_count() == 0)
    GTEST_SKIP() << "no CUDA device visible (" << cuda_device_count_error() << ")";
  if (backend == "cuda" && direct && !mpi_cuda_aware()) GTEST_SKIP() << "this MPI is not CUDA-aware";
  test::EnvSetting env_guard("FDEM_GPU_AWARE_MPI", direct ? "1" : nullptr);
  const Scene scene = fracturing_scene();
  Scene dscene = scene;
  dscene.solver.backend = test::named<Backend>(backend);
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  auto c = decomposed(scene, global);
  auto g = decomposed(dscene, global);
  EXPECT_EQ(g->device_loop()->fused(), !colour) << "a CE6 on every face: each node is one tet's";
  // One after the other: every rank runs the same sequence of exchanges.
  const double peak_c = test::run_fracture(*c, 3000).peak, peak_g = test::run_fracture(*g, 3000).peak;
  // The fused pass integrates on one rank only (several ranks update the ghosts in between).
  EXPECT_EQ(g->device_loop()->integrates(), !colour && world_size() == 1);
  const Monitors mc = c->measure(), mg = g->measure();
  ASSERT_GT(mc.broken, 20) << "the box fractured";
  EXPECT_LT(std::fabs(peak_g - peak_c), 0.005 * peak_c);
  EXPECT_LE(std::fabs(double(mg.broken - mc.broken)), 0.02 * mc.broken);
  if (backend == "debug") {
    EXPECT_EQ(peak_g, peak_c);
    EXPECT_EQ(mg.broken, mc.broken);
    EXPECT_EQ(mg.contacts, mc.contacts);
    EXPECT_EQ(mg.contact_pairs, mc.contact_pairs);
    EXPECT_EQ(mg.active_tets, mc.active_tets);
    // The energies: several ranks hand the evaluation's whole-model sums to the Solver in the
    // step's reduction, and they are summed in another order than the CPU backend's threads
    // sum them (round-off; one step's sums missed or counted twice is 1/3000 of each).
    for (const auto& [name, got, want] : {std::tuple{"force_top", mg.force_top, mc.force_top},
                                          {"external_work", mg.external_work, mc.external_work},
                                          {"viscous", mg.viscous, mc.viscous},
                                          {"cohesive_dissipated", mg.cohesive_dissipated, mc.cohesive_dissipated},
                                          {"platen_friction", mg.platen_friction, mc.platen_friction},
                                          {"contact", mg.contact, mc.contact},
                                          {"contact_friction", mg.contact_friction, mc.contact_friction}}) {
      EXPECT_NE(want, 0) << name;
      EXPECT_NEAR(got, want, 1e-10 * std::fabs(want)) << name;
    }
    g->sync_host();
    double differing = 0;
    for (std::size_t n = 0; n < c->state.x.size(); ++n)
      differing += c->owned_nodes()[n] && std::memcmp(&c->state.x[n], &g->state.x[n], sizeof(Vec3)) != 0;
    EXPECT_EQ(sum_over_ranks(differing), 0) << "owned node positions differing";
  }
  if (world_size() > 1) {
    EXPECT_GT(g->halo_seconds(), 0);
    EXPECT_EQ(g->device_loop()->halo_passes_device_buffers(), direct || (backend == "cuda" && mpi_cuda_aware()));
  }
  if (world_rank() == 0)
    std::printf("%s backend, %d rank(s): peak %.6g MPa, broken %ld, pairs %ld (cpu: %.6g, %ld, %ld)\n", param.c_str(),
                world_size(), peak_g / 1e6, mg.broken, mg.contact_pairs, peak_c / 1e6, mc.broken, mc.contact_pairs);
}

INSTANTIATE_TEST_SUITE_P(Backend, RanksDevice,
                         ::testing::Values("debug", "debug+mpi", "debug+colour", "cuda", "cuda+mpi", "cuda+colour"),
                         [](const ::testing::TestParamInfo<const char*>& i) {
                           std::string n = i.param;
                           for (char& c : n)
                             if (c == '+') c = '_';
                           return n;
                         });

TEST(Ranks, GpuAwareMpiSettingIsReadAndCheckedAtTheStart) {
  // FDEM_GPU_AWARE_MPI picks how a device loop's halo reaches MPI; a wrong value is an input
  // error naming the variable, raised when the solver is made (not at the first exchange).
  const Scene scene = fracturing_scene();
  Scene dscene = scene;
  dscene.solver.backend = Backend::debug;
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  unsetenv("FDEM_GPU_AWARE_MPI");
  EXPECT_FALSE(device_buffers_to_mpi(false)) << "auto stages the debug backend's buffers";
  EXPECT_EQ(device_buffers_to_mpi(true), mpi_cuda_aware());
  setenv("FDEM_GPU_AWARE_MPI", "0", 1);
  EXPECT_FALSE(device_buffers_to_mpi(true));
  setenv("FDEM_GPU_AWARE_MPI", "1", 1);
  EXPECT_TRUE(device_buffers_to_mpi(false));
  setenv("FDEM_GPU_AWARE_MPI", "yes", 1);
  try {
    device_buffers_to_mpi(true);
    ADD_FAILURE() << "no error for FDEM_GPU_AWARE_MPI=yes";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("FDEM_GPU_AWARE_MPI=yes"), std::string::npos) << e.what();
  }
  if (world_size() > 1) {
    EXPECT_THROW(decomposed(dscene, global), InputError);
  }
  unsetenv("FDEM_GPU_AWARE_MPI");
}

/// Two continuous blocks, one on the other (offset sideways), the upper one moving down at
/// 0.5 m/s, cut over the ranks by `cut`: contact forces across ranks give the one-rank run's.
void contact_across_ranks(const std::function<std::vector<int>(const Model&)>& cut, const char* what) {
  SCOPED_TRACE(what);
  const Scene scene = two_blocks_scene();
  const Model global = build_model(two_blocks(), scene);
  const std::vector<int> part = cut(global);
  Solver ref(scene, global);
  auto d = decomposed(scene, global, part);
  for (Solver* s : {&ref, d.get()})
    for (std::size_t t = 0; t < s->model().tet_nodes.size(); ++t)
      if (upper(s->model(), int(t)))
        for (int n : s->model().tet_nodes[t]) s->state.v[n] = {0, 0, -0.5};
  const std::vector<Vec3> zero_r(ref.state.f.size()), zero_d(d->state.f.size());
  double worst_f = 0, worst_x = 0, across = 0;
  long touching = 0, touching_d = 0;
  Monitors mr, md;
  for (int i = 1; i <= 400; ++i) {
    ref.step();
    d->step();
    if (i % 10) continue;
    mr = ref.measure();
    md = d->measure();
    if (mr.contacts == 0) continue;
    worst_f = std::max(worst_f, node_error(*d, d->state.f, ref.state.f, zero_r, zero_d));
    worst_x = std::max(worst_x, node_error(*d, d->state.x, ref.state.x, ref.model().X, d->model().X));
    touching = std::max(touching, mr.contacts);
    touching_d = std::max(touching_d, md.contacts);
  }
  // Candidate pairs with one tet here and one on another rank.
  for (const ContactPair& p : d->contacts.pairs) across += d->owned_tets()[p.a] != d->owned_tets()[p.b];
  across = sum_over_ranks(across);
  if (world_size() > 1) {
    EXPECT_GT(across, 0);
  }
  EXPECT_GT(touching, 0) << "the blocks touch";
  EXPECT_EQ(touching_d, touching);
  EXPECT_LT(worst_f, 1e-10) << "forces";
  EXPECT_LT(worst_x, 1e-10) << "displacements";
  EXPECT_LT(std::fabs(md.contact - mr.contact), 1e-10 * std::fabs(mr.contact));
  if (world_rank() == 0)
    std::printf(
        "contact (%s), %d rank(s): %g candidate pairs across ranks, %ld touching; forces %.2e, displacements "
        "%.2e (relative)\n",
        what, world_size(), across, touching, worst_f, worst_x);
}

TEST(Ranks, ContactPairAcrossRanksGivesOneRankForces) {
  // Block A on rank 0, block B on the last rank. Contact is the only force between them, so
  // every force across the interface comes from pairs split over two ranks.
  contact_across_ranks(block_per_rank, "a block a rank");
}

TEST(Ranks, AFragmentOverThreeRanksTouchesAsOnOneRank) {
  // The upper block cut in sectors around its axis, one a rank, the lower block on rank 0: at
  // three ranks and more one fragment spans three ranks, and its pairs with the lower block
  // are split over them.
  contact_across_ranks(
      [](const Model& m) {
        const std::vector<int> part = sectors(m, {0.006, 0.0055, 0}, [&](int t) { return upper(m, t); });
        std::set<int> upper_ranks;
        for (std::size_t t = 0; t < part.size(); ++t)
          if (upper(m, int(t))) upper_ranks.insert(part[t]);
        EXPECT_EQ(int(upper_ranks.size()), world_size()) << "the upper block spans every rank";
        return part;
      },
      "a fragment over the ranks");
}

/// The two-block fall of the test below, stepped on one rank (ref) and decomposed (d): the
/// largest differences, the contacts, the lower block's push, and a run restarted at step 700
/// from a checkpoint of d.
struct TwoBlockFall {
  double worst_f = 0, worst_x = 0, worst_e = 0;
  long touching = 0, touching_d = 0;
  Monitors mr, md;
  real pushed = 0;
  std::unique_ptr<Solver> restarted;
};

TwoBlockFall step_two_block_fall(Solver& ref, Solver& d, const Scene& scene, const RankModel& start,
                                 const Model& global) {
  TwoBlockFall r;
  const std::vector<Vec3> zero_r(ref.state.f.size());
  for (int i = 1; i <= 2500; ++i) {
    ref.step();
    d.step();
    if (r.restarted) r.restarted->step();
    if (i == 700) {
      // A checkpoint after growths holds the grown rank model: a solver of the rank model the
      // run started with continues from it bit for bit.
      CheckpointOut o;
      d.save(o);
      r.restarted = std::make_unique<Solver>(scene, start.model, start.dd, MPI_COMM_WORLD);
      CheckpointIn in(o.payload(), "checkpoint in memory");
      r.restarted->load(in);
      in.finish();
    }
    r.mr = ref.measure();
    r.md = d.measure();
    ref.sync_host();  // (a device backend's monitor row leaves the host copy as it was)
    d.sync_host();
    real vz = 0;  // the lower block's mean velocity: it moves once the upper one hits it
    int count = 0;
    for (std::size_t t = 0; t < global.tet_nodes.size(); ++t)
      if (!upper(global, int(t)))
        for (int n : global.tet_nodes[t]) vz += ref.state.v[n].z, ++count;
    r.pushed = std::min(r.pushed, vz / count);
    // Bit for bit through the impact and fracture: the contact pairs are in global order
    // (ContactSet::rebuild), so every node sums its contact forces as on one rank.
    const std::vector<Vec3> zero_d(d.state.f.size());
    r.worst_x = std::max(r.worst_x, node_error(d, d.state.x, ref.state.x, ref.model().X, d.model().X));
    if (r.mr.contacts == 0) continue;
    r.worst_f = std::max(r.worst_f, node_error(d, d.state.f, ref.state.f, zero_r, zero_d));
    r.worst_e = std::max(r.worst_e, std::fabs(r.md.contact - r.mr.contact) / std::fabs(r.mr.contact));
    r.touching = std::max(r.touching, r.mr.contacts);
    r.touching_d = std::max(r.touching_d, r.md.contacts);
  }
  return r;
}

/// Tets whose box comes within half the reach of the box of one of d's own tets (at the
/// one-rank run's positions, brute force), and how many of them d does not hold.
struct NearTets {
  long near = 0, missing = 0;
};

NearTets near_tets_not_held(const Solver& ref, const Solver& d, const Model& global, real reach) {
  const Decomposition& dd = d.decomposition();
  std::set<long> held(dd.tet_global.begin(), dd.tet_global.end());
  auto box = [&](long t) {
    Aabb b{ref.state.x[global.tet_nodes[t][0]], ref.state.x[global.tet_nodes[t][0]]};
    for (int n : global.tet_nodes[t])
      for (int k = 0; k < 3; ++k)
        b.lo[k] = std::min(b.lo[k], ref.state.x[n][k]), b.hi[k] = std::max(b.hi[k], ref.state.x[n][k]);
    return b;
  };
  NearTets r;
  for (std::size_t i = 0; i < dd.tet_global.size(); ++i) {
    if (!dd.tet_owned[i]) continue;
    const Aabb a = box(dd.tet_global[i]);
    for (long u = 0; u < long(global.tet_nodes.size()); ++u) {
      const Aabb b = box(u);
      bool close = true;
      for (int k = 0; k < 3; ++k) close = close && a.lo[k] - 0.5 * reach <= b.hi[k] && b.lo[k] - 0.5 * reach <= a.hi[k];
      r.near += close;
      r.missing += close && !held.count(u);
    }
  }
  return r;
}

TEST(Ranks, FragmentsTravellingBeyondTheReachGatherTheirContactGhosts) {
  // The upper block starts 0.5 mm above the lower one and falls at 5 m/s onto it; the contact
  // reach is 0.3 mm, so at the start neither rank holds a tet of the other block. Each time a
  // node has come a quarter of the reach from where the contact ghosts were gathered, every
  // rank gathers them again with the current positions (the tets, with their nodes and the CE6s
  // between them): the blocks then meet and break CE6s as on one rank, bit for bit, and a
  // restart from a checkpoint written after gatherings continues bit for bit. The same on the
  // debug backend (the check runs in its integration) and, where a GPU is visible, on the CUDA
  // backend.
  const real reach = 3e-4, gap = 5e-4;
  for (const std::string backend : {"cpu", "debug", "cuda"}) {
    if (backend == "cuda" && cuda_device_count() == 0) {
      if (world_rank() == 0) std::printf("cuda: not run, no CUDA device visible\n");
      continue;
    }
    Scene scene = two_blocks_scene();
    scene.solver.backend = test::named<Backend>(backend);
    scene.fracture.everywhere = true;  // CE6s inside each block: the ghosts bring them, with their damage
    const Model global = build_model(two_blocks(gap), scene);
    Solver ref(scene, global);
    RankModel rm = extract_rank(global, block_per_rank(global), world_rank(), reach);
    const double ce6_start = sum_over_ranks(double(rm.model.ce6_nodes.size()));
    const long held_at_start = long(rm.model.tet_nodes.size());
    const RankModel start = rm;
    Solver d(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
    for (Solver* s : {&ref, &d}) {
      s->sync_host();
      for (std::size_t t = 0; t < s->model().tet_nodes.size(); ++t)
        if (upper(s->model(), int(t)))
          for (int n : s->model().tet_nodes[t]) s->state.v[n] = {0, 0, -5};
      s->host_changed();
    }
    const TwoBlockFall fall = step_two_block_fall(ref, d, scene, start, global);
    const Monitors &mr = fall.mr, &md = fall.md;
    const std::unique_ptr<Solver>& restarted = fall.restarted;
    const double worst_f = fall.worst_f, worst_x = fall.worst_x, worst_e = fall.worst_e;
    const long touching = fall.touching, touching_d = fall.touching_d;
    const real pushed = fall.pushed;
    d.sync_host();
    restarted->sync_host();
    EXPECT_EQ(restarted->model().tet_nodes.size(), d.model().tet_nodes.size()) << backend;
    auto same = [](const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
      return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3)) == 0;
    };
    EXPECT_TRUE(same(restarted->state.x, d.state.x) && same(restarted->state.v, d.state.v))
        << backend << ": the restarted run differs";
    EXPECT_EQ(restarted->ghost_growths().count, d.ghost_growths().count) << backend;
    EXPECT_LT(pushed, -0.5) << backend << ": the blocks meet (m/s, the lower block's mean velocity)";
    EXPECT_GT(touching, 0) << backend << ": pairs touch before a CE6 breaks";
    EXPECT_EQ(touching_d, touching) << backend;
    EXPECT_EQ(worst_f, 0) << backend << ": forces";
    EXPECT_EQ(worst_x, 0) << backend << ": displacements";
    EXPECT_LT(worst_e, 1e-10) << backend << ": contact energy (the ranks' sums added in another order)";
    EXPECT_GT(mr.broken, 20) << backend << ": the impact breaks CE6s";
    EXPECT_EQ(md.broken, mr.broken) << backend;
    const GhostGrowths& g = d.ghost_growths();
    const double ce6_added = sum_over_ranks(double(d.model().ce6_nodes.size())) - ce6_start;
    EXPECT_EQ(restarted->ghost_growths().unchanged, g.unchanged) << backend;
    if (world_size() > 1) {
      EXPECT_GT(g.count, 3) << backend;
      // Both kinds: gatherings while the blocks are apart add nothing and keep the layout.
      EXPECT_GT(g.unchanged, 0) << backend;
      EXPECT_LT(g.unchanged, g.count) << backend;
      EXPECT_GT(ce6_added, 0) << backend;
      EXPECT_GT(g.tets, 0) << backend;
      // (A rank that owns no tet, the middle ones of three or more, has nothing to gather for.)
      if (held_at_start > 0) {
        EXPECT_GT(long(d.model().tet_nodes.size()), held_at_start) << backend;
      }
      // Every tet whose box comes within half the reach of an own tet's box now is held: the
      // ghosts were gathered within the reach where the nodes were, less than a quarter of the
      // reach ago.
      const NearTets near = near_tets_not_held(ref, d, global, reach);
      EXPECT_EQ(near.missing, 0) << backend << " (" << near.near << " near pairs)";
    } else {
      EXPECT_EQ(g.count, 0) << backend;
    }
    if (world_rank() == 0)
      std::printf(
          "%s, %d rank(s): contact ghosts gathered %ld times, %ld tets and %g CE6s added; lower block pushed to "
          "%.2f m/s; %ld pairs touching at most; forces %.2e, displacements %.2e (relative, largest over the "
          "run); broken CE6s %ld against %ld\n",
          backend.c_str(), world_size(), g.count, g.tets, ce6_added, pushed, touching, worst_f, worst_x, md.broken,
          mr.broken);
  }
}

TEST(Ranks, ContactReachGuardStopsARunBeforeAPartnerIsMissed) {
  // Both blocks fly at 50 m/s (10 um per step) with a contact reach of 10 um: they move half
  // the reach in a step, faster than the contact ghosts can be gathered again, so after the
  // first step every rank stops the run (with one rank nothing is missing). The same on the
  // debug backend, whose check runs in its integration on the device.
  for (const std::string backend : {"cpu", "debug"}) {
    Scene scene = two_blocks_scene();
    scene.solver.backend = test::named<Backend>(backend);
    const Model global = build_model(two_blocks(), scene);
    RankModel rm = extract_rank(global, block_per_rank(global), world_rank(), 1e-5);
    Solver d(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
    for (Vec3& v : d.state.v) v = {50, 0, 0};
    std::string message;
    try {
      for (int i = 0; i < 400; ++i) d.step();
    } catch (const RunError& e) {
      message = e.what();
    }
    if (world_size() > 1) {
      EXPECT_NE(message.find("contact reach"), std::string::npos) << backend << ": " << message;
      EXPECT_NE(message.find("--contact-reach"), std::string::npos) << backend << ": " << message;
      // A value to try: at least twice the reach, and four times the distance moved.
      const std::size_t at = message.find("e.g. --contact-reach ");
      ASSERT_NE(at, std::string::npos) << message;
      EXPECT_GE(std::stod(message.substr(at + 21)), 2e-5) << message;
    } else {
      EXPECT_EQ(message, "") << backend;
    }
  }
}

TEST(Ranks, PrepartitionedFilesGiveTheSameRun) {
  // fdem partition's rank files against the partition made at start: identical bits.
  Scene scene = box_scene();
  scene.platens.velocity = 2.0;
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  const std::vector<int> part = partition_tets(global, world_size());
  std::string dir = "/tmp/fdem_test_ranks_" + std::to_string(getpid());
  int len = int(dir.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, MPI_COMM_WORLD);
  dir.resize(len);
  MPI_Bcast(dir.data(), len, MPI_CHAR, 0, MPI_COMM_WORLD);
  const std::string file = dir + "/rank_" + std::to_string(world_rank()) + ".fdp";
  if (world_rank() == 0) {
    std::filesystem::create_directories(dir);
    for (int r = 0; r < world_size(); ++r)
      write_rank_file(dir + "/rank_" + std::to_string(r) + ".fdp",
                      extract_rank(global, part, r, default_reach(global, scene)), model_key(scene));
  }
  MPI_Barrier(MPI_COMM_WORLD);
  RankModel rm = read_rank_file(file, model_key(scene));
  Scene other = scene;
  other.solver.mass_scaling = 20;
  EXPECT_THROW(read_rank_file(file, model_key(other)), InputError) << "a rank file of another model";
  {  // a colouring that lists a CE6 twice (the device keeps one slot per CE6) is refused by name
    RankModel twice = read_rank_file(file, model_key(scene));
    ASSERT_GE(twice.model.ce6_colours.order.size(), 2u);
    twice.model.ce6_colours.order[1] = twice.model.ce6_colours.order[0];
    const std::string bad = file + ".twice";
    write_rank_file(bad, twice, model_key(scene));
    try {
      read_rank_file(bad, model_key(scene));
      ADD_FAILURE() << "a CE6 twice in the colouring was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(bad + ": inconsistent rank file (an element twice in a colouring)"),
                std::string::npos)
          << e.what();
    }
    std::filesystem::remove(bad);
  }
  MPI_Barrier(MPI_COMM_WORLD);
  if (world_rank() == 0) std::filesystem::remove_all(dir);
  Solver from_file(scene, std::move(rm.model), std::move(rm.dd), MPI_COMM_WORLD);
  auto on_the_fly = decomposed(scene, global, part);
  for (int i = 0; i < 2000; ++i) from_file.step(), on_the_fly->step();
  from_file.sync_host(), on_the_fly->sync_host();
  ASSERT_EQ(from_file.state.x.size(), on_the_fly->state.x.size());
  EXPECT_EQ(std::memcmp(from_file.state.x.data(), on_the_fly->state.x.data(), from_file.state.x.size() * sizeof(Vec3)),
            0);
  ASSERT_EQ(from_file.state.ce6.size(), on_the_fly->state.ce6.size());
  EXPECT_EQ(std::memcmp(from_file.state.ce6.damage.data(), on_the_fly->state.ce6.damage.data(),
                        from_file.state.ce6.size() * sizeof(Ce6Damage)),
            0);
  EXPECT_EQ(std::memcmp(from_file.state.ce6.anchors.data(), on_the_fly->state.ce6.anchors.data(),
                        from_file.state.ce6.size() * sizeof(Ce6Anchors)),
            0);
  EXPECT_GT(from_file.measure().damaged, 0) << "the run went far enough to damage CE6s";
}

TEST(Ranks, ContactGhostsAreTheTetsWithinTheReachOfAnotherRanksTets) {
  // The plan's held sets against a brute-force search over all pairs: a rank holds a tet of
  // another rank exactly when it shares a mesh vertex with one of its own (the ghost layer) or
  // their reference boxes come within the reach. On one box, and on two boxes across a gap.
  Scene scene = box_scene();
  Mesh two = structured_box_mesh({0.01, 0.01, 0.01}, 3, 3, 3);
  {
    const Mesh b = structured_box_mesh({0.01, 0.01, 0.01}, 3, 3, 3);
    const int off = int(two.vertices.size());
    for (Vec3 p : b.vertices) two.vertices.push_back(p + Vec3{0.002, 0, 0.0105});
    for (auto q : b.tets) two.tets.push_back({q[0] + off, q[1] + off, q[2] + off, q[3] + off});
  }
  for (const Mesh& mesh : {structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), two}) {
    const Model g = build_model(mesh, scene);
    const int nt = int(g.tet_nodes.size());
    std::vector<Aabb> box(nt);
    for (int t = 0; t < nt; ++t) {
      box[t] = {g.X[g.tet_nodes[t][0]], g.X[g.tet_nodes[t][0]]};
      for (int n : g.tet_nodes[t])
        for (int d = 0; d < 3; ++d)
          box[t].lo[d] = std::min(box[t].lo[d], g.X[n][d]), box[t].hi[d] = std::max(box[t].hi[d], g.X[n][d]);
    }
    for (int parts : {2, 3, 4})
      for (real reach : {0.5 * default_reach(g, scene), default_reach(g, scene), real(0.004)}) {
        const std::vector<int> part = partition_tets(g, parts);
        const PartitionPlan plan = plan_partition(g, part, reach);
        std::vector<std::set<int>> expected(nt);
        long ghosts = 0;
        for (int t = 0; t < nt; ++t) {
          expected[t].insert(part[t]);
          for (int u = 0; u < nt; ++u) {
            bool shares = false, near = true;
            for (int a : g.tet_nodes[t])
              for (int b : g.tet_nodes[u]) shares = shares || g.node_vertex[a] == g.node_vertex[b];
            for (int d = 0; d < 3; ++d)
              near = near && box[t].lo[d] - reach <= box[u].hi[d] && box[u].lo[d] - reach <= box[t].hi[d];
            if (shares || near) expected[t].insert(part[u]);
          }
          EXPECT_EQ(std::set<int>(plan.held[t].begin(), plan.held[t].end()), expected[t])
              << "tet " << t << ", " << parts << " parts, reach " << reach;
          ghosts += long(expected[t].size()) - 1;
        }
        EXPECT_GT(ghosts, 0);
      }
  }
}

TEST(Ranks, DefaultContactReachCoversThePlatenTravelToTheEnd) {
  // Two mean edges, or 2.5 times the platen travel by the end condition (the contact ghosts are
  // gathered again each time a node has moved a quarter of the reach: the travel alone does
  // that at most once): axial strain x height, velocity x time, the smaller.
  Scene scene = box_scene();
  scene.contact.activation = Activation::adaptive;
  const Model g = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
  const real edges = 2 * g.mean_edge;
  scene.solver.end = {};
  EXPECT_EQ(default_reach(g, scene), edges) << "no bound on the travel";
  scene.solver.end.axial_strain = 0.01;  // 0.2 mm of travel: the edges rule
  EXPECT_EQ(default_reach(g, scene), edges);
  scene.solver.end.axial_strain = 0.5;  // 10 mm
  EXPECT_DOUBLE_EQ(default_reach(g, scene), 2.5 * 0.5 * g.height0);
  EXPECT_GT(default_reach(g, scene), edges);
  scene.platens.velocity = 0.1, scene.solver.end.time = 0.05;  // 5 mm by time, before the strain
  EXPECT_DOUBLE_EQ(default_reach(g, scene), 2.5 * 0.005);
  scene.solver.end.axial_strain = 0;
  EXPECT_DOUBLE_EQ(default_reach(g, scene), 2.5 * 0.005);
  scene.platens.enabled = false;  // no platen: no travel to bound
  EXPECT_EQ(default_reach(g, scene), edges);
  scene.contact.activation = Activation::none;
  EXPECT_EQ(default_reach(g, scene), 0);
}

TEST(Ranks, PartitionIsBalancedAndCoversEveryTet) {
  const Scene scene = box_scene();
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 4, 4, 8), scene);
  for (int parts : {1, 2, 3, 4}) {
    const std::vector<int> part = partition_tets(global, parts);
    std::vector<long> count(parts, 0);
    for (int p : part) ++count[p];
    const long nt = long(global.tet_nodes.size());
    for (int r = 0; r < parts; ++r) {
      EXPECT_GT(count[r], 0);
      EXPECT_LT(count[r], 1.1 * nt / parts + 1) << parts << " parts";  // METIS allows 3 % imbalance
    }
    // Every tet owned once; every node owned once; only some ghost nodes are received every
    // step (those of the elements a rank computes; with contact the halo adds the nodes of
    // active ghost tets as they activate); what one rank sends another receives.
    long tets = 0, nodes = 0;
    for (real reach : {real(0), default_reach(global, scene)}) {
      const PartitionPlan plan = plan_partition(global, part, reach);
      std::vector<std::vector<long>> sent(parts, std::vector<long>(parts, 0)), got = sent;
      for (int r = 0; r < parts; ++r) {
        const RankModel rm = extract_rank(global, plan, r);
        if (reach == 0) {
          for (auto o : rm.dd.tet_owned) tets += o;
          for (auto o : rm.dd.node_owned) nodes += o;
        }
        long ghosts = 0, received = 0;
        for (auto o : rm.dd.node_owned) ghosts += !o;
        for (const Neighbour& nb : rm.dd.neighbours) {
          received += long(nb.recv_nodes.size());
          sent[r][nb.rank] = long(nb.send_nodes.size());
          got[nb.rank][r] = long(nb.recv_nodes.size());
        }
        if (parts > 1) {
          EXPECT_LT(received, ghosts) << "rank " << r << " of " << parts;
        }
      }
      EXPECT_EQ(sent, got) << parts << " parts, reach " << reach;
    }
    EXPECT_EQ(tets, nt);
    EXPECT_EQ(nodes, long(global.X.size()));
  }
  EXPECT_THROW(partition_tets(global, int(global.tet_nodes.size()) + 1), InputError);
}

TEST(Ranks, APartitionThatLeavesARankEmptyNamesTheMostRanksThatEachGetTets) {
  // METIS may leave a part empty well below one rank per tet. The refusal names the largest
  // rank count below that fills every rank, for a restart onto more ranks than a model can take.
  const Scene scene = box_scene();
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.01}, 2, 2, 2), scene);
  const int nt = int(global.tet_nodes.size());
  auto fills = [&](int parts) {
    try {
      const std::vector<int> part = partition_tets(global, parts);
      std::vector<int> count(parts, 0);
      for (int p : part) ++count[p];
      return *std::min_element(count.begin(), count.end()) > 0;
    } catch (const InputError&) {
      return false;
    }
  };
  int refused = 0;
  for (int parts = 2; parts <= nt + 1; ++parts) {
    try {
      partition_tets(global, parts);
    } catch (const InputError& e) {
      ++refused;
      const std::string what = e.what();
      const std::size_t at = what.find("at most ");
      ASSERT_NE(at, std::string::npos) << what;
      const int usable = std::atoi(what.c_str() + at + 8);
      ASSERT_GT(usable, 0) << what;
      ASSERT_LT(usable, parts) << what;
      EXPECT_TRUE(fills(usable)) << what;
      for (int q = usable + 1; q < parts && parts <= nt; ++q) EXPECT_FALSE(fills(q)) << q << ": " << what;
    }
  }
  EXPECT_GT(refused, 1) << "METIS filled every count up to the tet count: the case is not reached";
  std::printf("%d tets: %d of %d rank counts refused\n", nt, refused, nt);
}

TEST(Ranks, PartitionBalancesTheWorkWhenFractureRegionsCoverPartOfTheModel) {
  // CE6s only in the lower quarter of a box: a tet there costs about 4 times one above it
  // (docs/benchmarks.md: 90 ns per TET4, 135 ns per CE6 on one core). The work each rank's
  // model gives it (own tets, and the CE6s it computes: those acting on a node it owns, the
  // partition boundary's on both sides) is balanced by the cost weights; equal tet counts
  // would give the fracturing part's rank far more.
  Scene scene = box_scene();
  scene.contact.activation = Activation::none;
  scene.fracture.everywhere = false;
  scene.fracture.boxes.push_back({{-1, -1, -1}, {1, 1, 0.0125}});
  const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.05}, 4, 4, 20), scene);
  for (int parts : {2, 3, 4}) {
    double imbalance[2] = {0, 0};
    for (PartitionWeights w : {PartitionWeights::cost, PartitionWeights::uniform}) {
      const PartitionPlan plan = plan_partition(global, partition_tets(global, parts, w), 0);
      std::vector<double> work(parts, 0);
      for (int r = 0; r < parts; ++r) {
        const RankModel rm = extract_rank(global, plan, r);
        for (auto o : rm.dd.tet_owned) work[r] += 90.0 * o;
        for (const auto& q : rm.model.ce6_nodes) {
          bool computed = false;
          for (int n : q) computed = computed || rm.dd.node_owned[n];
          work[r] += 135.0 * computed;
        }
      }
      double sum = 0, most = 0;
      for (double x : work) sum += x, most = std::max(most, x);
      imbalance[w == PartitionWeights::uniform] = most / (sum / parts);
    }
    EXPECT_LT(imbalance[0], 1.06) << parts << " parts, cost weights";
    EXPECT_GT(imbalance[1], 1.2) << parts << " parts, equal tet counts";
    if (world_rank() == 0)
      std::printf("%d parts: slowest rank's work / mean %.3f with cost weights, %.3f with equal tet counts\n", parts,
                  imbalance[0], imbalance[1]);
  }
}

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  ::testing::InitGoogleTest(&argc, argv);
  const int code = RUN_ALL_TESTS();
  int worst = code;
  MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return worst;
}

TEST(Ranks, DeviceLoopCopiesToTheHostAFewTimesAStep) {
  // Each copy between host and device waits for the device, and each reduction over the ranks
  // for every rank. On several ranks a step of the device loop copies to the host: the broad
  // phase's decision after the CE6 pass, the halo's send buffer, and the integration's sums
  // with the force evaluation's scalars; with a hydrostatic confining pressure, which follows the
  // summed platen reactions, those reactions too. To the device: the halo's receive buffer, and
  // on the hydrostatic path the summed reactions. One reduction a step (the step's sums, the
  // evaluation's whole-model sums and whether a rank raised an activation flag), and on the
  // hydrostatic path the reactions'. Activation flags are exchanged only on steps where a rank
  // raised one (none here: elastic). Handing device buffers to MPI (FDEM_GPU_AWARE_MPI=1)
  // leaves out the halo's two copies. One rank: one copy a step and no reduction
  // (DebugBackend.OnlyAFewScalarsCrossToTheHostBetweenMonitorRows).
  const bool several = world_size() > 1;
  for (const std::string path : {"none", "constant", "hydrostatic"})
    for (const bool direct : {false, true}) {
      test::EnvSetting env("FDEM_GPU_AWARE_MPI", direct ? "1" : nullptr);
      Scene scene = box_scene();
      scene.solver.backend = Backend::debug;
      if (path != "none") {
        scene.confinement.enabled = true;
        scene.confinement.pressure = 1e6;
        scene.confinement.path = test::named<ConfinementPath>(path);
      }
      const Model global = build_model(structured_box_mesh({0.01, 0.01, 0.02}, 3, 3, 6), scene);
      auto d = decomposed(scene, global);
      ASSERT_TRUE(d->contacts.enabled());
      d->step();  // uploads, and merges the flags it took from the host
      device::reset_traffic();
      const long reductions_before = sums_over_ranks_made();
      const int steps = 50;
      for (int i = 0; i < steps; ++i) d->step();
      const device::Traffic t = device::traffic();
      const long reductions = sums_over_ranks_made() - reductions_before;
      EXPECT_EQ(d->measure().damaged, 0) << "elastic";
      const long to_host = !several ? 1 : 2 + (path == "hydrostatic") + (direct ? 0 : 1);
      const long to_device = !several ? 0 : (path == "hydrostatic") + (direct ? 0 : 1);
      const long reduced = !several ? 0 : 1 + (path == "hydrostatic");
      EXPECT_EQ(t.to_host, to_host * steps) << path << (direct ? ", device buffers to MPI" : "");
      EXPECT_EQ(t.to_device, to_device * steps) << path << (direct ? ", device buffers to MPI" : "");
      EXPECT_EQ(reductions, reduced * steps) << path << (direct ? ", device buffers to MPI" : "");
    }
}

namespace {

/// Rank r's slab of a synthetic field frame: tets of four nodes each, values that name the
/// rank, the row and the frame, crack faces on even ranks; with three ranks or more, rank 1
/// holds nothing. Frame 1 turns rank 0's tets, so that the frame carries its own connectivity.
struct Slab {
  std::vector<Vec3> x, u;
  std::vector<std::array<int, 4>> tets;
  std::vector<real> von_mises;
  std::vector<std::array<int, 3>> faces;
  std::vector<real> damage;
  std::vector<int> mode;

  /// This slab after `other`'s, as one process would hold both: node ids shifted.
  void append(const Slab& o) {
    const int shift = int(x.size());
    x.insert(x.end(), o.x.begin(), o.x.end());
    u.insert(u.end(), o.u.begin(), o.u.end());
    for (auto q : o.tets) tets.push_back({q[0] + shift, q[1] + shift, q[2] + shift, q[3] + shift});
    von_mises.insert(von_mises.end(), o.von_mises.begin(), o.von_mises.end());
    for (auto q : o.faces) faces.push_back({q[0] + shift, q[1] + shift, q[2] + shift});
    damage.insert(damage.end(), o.damage.begin(), o.damage.end());
    mode.insert(mode.end(), o.mode.begin(), o.mode.end());
  }
  FieldFrame frame(int index) const {
    FieldFrame f;
    f.time = 1e-3 * index, f.step = 100 * index, f.label = index == 0 ? "initial" : "";
    f.x = &x, f.u = &u, f.tets = &tets, f.von_mises = &von_mises;
    f.crack_faces = &faces, f.crack_damage = &damage, f.crack_mode = &mode;
    return f;
  }
};

Slab slab_of(int r, int size, int index) {
  Slab s;
  const int tets = size >= 3 && r == 1 ? 0 : r + 2;
  for (int t = 0; t < tets; ++t) {
    for (int k = 0; k < 4; ++k) {
      const double id = 1000 * r + 4 * t + k;
      s.x.push_back({id, -id, index + 0.5 * id});
      s.u.push_back({index * 1e-3 * id, 0, 1});
    }
    const int n = 4 * t;
    s.tets.push_back(index == 1 && r == 0 ? std::array<int, 4>{n + 1, n, n + 2, n + 3}
                                          : std::array<int, 4>{n, n + 1, n + 2, n + 3});
    s.von_mises.push_back(1e6 * r + t + index);
    if (r % 2 == 1) continue;
    s.faces.push_back({n, n + 1, n + 3});
    s.damage.push_back(0.25 * (t % 4));
    s.mode.push_back(t % 5);
  }
  return s;
}

/// Every dataset of a field file by path, as raw bytes.
std::map<std::string, std::string> field_datasets(const std::string& file) {
  std::map<std::string, std::string> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  auto visit = [](hid_t loc, const char* name, const H5O_info_t* info, void* data) -> herr_t {
    if (info->type != H5O_TYPE_DATASET) return 0;
    const hid_t ds = H5Dopen2(loc, name, H5P_DEFAULT), type = H5Dget_type(ds), space = H5Dget_space(ds);
    std::string bytes(std::size_t(H5Sget_simple_extent_npoints(space)) * H5Tget_size(type), '\0');
    if (!bytes.empty()) H5Dread(ds, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, bytes.data());
    (*static_cast<std::map<std::string, std::string>*>(data))[name] = bytes;
    H5Sclose(space), H5Tclose(type), H5Dclose(ds);
    return 0;
  };
  H5Ovisit(f, H5_INDEX_NAME, H5_ITER_INC, visit, &out);
  H5Fclose(f);
  return out;
}

}  // namespace

TEST(Ranks, OneFieldFileOfAllRanksHoldsWhatOneProcessWritesOfTheWhole) {
  // The ranks write their slabs into one fields.h5, through MPI-IO and by gathering on rank 0,
  // with a restart's take-over and a relabel between the frames. Rank 0 writes the ranks'
  // slabs joined, alone. Every dataset and the index must be the same, byte for byte.
  const int rank = world_rank(), size = world_size();
  std::string dir = "/tmp/fdem_test_fields_" + std::to_string(getpid());
  int len = int(dir.size());
  MPI_Bcast(&len, 1, MPI_INT, 0, MPI_COMM_WORLD);
  dir.resize(len);
  MPI_Bcast(dir.data(), len, MPI_CHAR, 0, MPI_COMM_WORLD);
  auto write = [&](const std::string& folder, MPI_Comm ranks, SharedWrite how, const Slab* frames) {
    FieldWriterState after_first;
    {
      FieldWriter w(folder, "fields", ranks, how);
      w.write(frames[0].frame(0));
      after_first = w.state();
      w.write(frames[1].frame(1));  // written, then dropped by the take-over below
    }
    FieldWriter w(folder, "fields", after_first, ranks, how);
    EXPECT_EQ(w.frames(), 1);
    w.write(frames[1].frame(1));
    w.relabel(0, "first");
  };
  const Slab mine[2] = {slab_of(rank, size, 0), slab_of(rank, size, 1)};
  write(dir + "/collective", MPI_COMM_WORLD, SharedWrite::collective, mine);
  write(dir + "/gathered", MPI_COMM_WORLD, SharedWrite::gathered, mine);
  int same = 1;
  if (rank == 0) {
    Slab whole[2];
    for (int i = 0; i < 2; ++i)
      for (int r = 0; r < size; ++r) whole[i].append(slab_of(r, size, i));
    write(dir + "/one", MPI_COMM_NULL, SharedWrite::collective, whole);
    const auto one = field_datasets(dir + "/one/fields.h5");
    EXPECT_TRUE(one.count("frame_000001/tets") && one.count("frame_000000/crack_mode")) << "the cases the test is for";
    for (const char* how : {"collective", "gathered"}) {
      const std::string folder = dir + "/" + how;
      const auto shared = field_datasets(folder + "/fields.h5");
      EXPECT_EQ(shared.size(), one.size()) << how;
      for (const auto& [path, bytes] : one) {
        const bool equal = shared.count(path) && shared.at(path) == bytes;
        EXPECT_TRUE(equal) << how << ": " << path;
        same = same && equal;
      }
      std::ifstream a(dir + "/one/fields.xdmf"), b(folder + "/fields.xdmf");
      const std::string ta((std::istreambuf_iterator<char>(a)), {}), tb((std::istreambuf_iterator<char>(b)), {});
      EXPECT_EQ(ta, tb) << how;
      EXPECT_NE(ta.find("frame_000000_first"), std::string::npos);
    }
    std::filesystem::remove_all(dir);
  }
  MPI_Bcast(&same, 1, MPI_INT, 0, MPI_COMM_WORLD);
  EXPECT_TRUE(same) << "rank 0 found a dataset that differs";
  if (default_shared_write() != SharedWrite::collective && rank == 0)
    std::printf("collective: written as gathered, this HDF5 has no MPI-IO\n");

  // A rank that gives a field the others do not: every rank throws, naming it (no rank waits
  // in a collective call the others never make).
  if (size > 1) {
    FieldWriter w(dir + "/mismatch", "fields", MPI_COMM_WORLD);
    const std::vector<real> extra(mine[0].tets.size(), 1.0);
    FieldFrame f = mine[0].frame(0);
    if (rank == size - 1) f.extra.push_back({"only_here", &extra});
    try {
      w.write(f);
      ADD_FAILURE() << "rank " << rank << ": a frame with different fields was written";
    } catch (const RunError& e) {
      EXPECT_NE(std::string(e.what()).find("the ranks give different fields"), std::string::npos) << e.what();
    }
    MPI_Barrier(MPI_COMM_WORLD);
    if (rank == 0) std::filesystem::remove_all(dir);
  }
}
