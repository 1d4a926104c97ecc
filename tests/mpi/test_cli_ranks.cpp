// fdem under mpiexec with two ranks, through the real executable: the same results as one
// rank, rank files from fdem partition, and a failing rank ending the whole job at once.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <regex>
#include <thread>

#include "cli_support.hpp"

using namespace cli_test;

namespace {

const std::string kScene = (kData / "cli" / "restart_box.yaml").string();

std::string mpiexec(int ranks) {
  const std::string exe = find_mpiexec();
  return exe.empty() ? "" : kMpiEnv + kEnv + quote(exe) + " -n " + std::to_string(ranks) + " ";
}

/// Largest relative difference of two monitor files, column by column (energy_error aside,
/// which is a small difference of large sums), and whether their shapes agree; only the rows up
/// to step `last` where given.
double monitor_difference(const Csv& a, const Csv& b, double last = 1e300) {
  if (a.header != b.header || a.rows.size() != b.rows.size()) return 1e300;
  double worst = 0;
  const int skip = column(a, "energy_error"), step = column(a, "step");
  for (std::size_t r = 0; r < a.rows.size(); ++r)
    for (std::size_t c = 0; c < a.header.size(); ++c) {
      if (a.rows[r][step] > last) break;
      if (int(c) == skip) continue;
      const double x = a.rows[r][c], y = b.rows[r][c];
      if (x != y) worst = std::max(worst, std::fabs(x - y) / std::max(std::fabs(x), 1e-300));
    }
  return worst;
}

struct FrameInfo {
  std::string group;  // the frame's group in the HDF5 file: "/frame_000006"
  long step = -1;
};

/// The frame of an XDMF index with this label ("pre-peak", "peak", "post-peak"); step -1 if none.
FrameInfo frame_labelled(const std::string& xdmf, const std::string& label) {
  const std::regex grid("<Grid Name=\"frame_([0-9]{6})_" + label +
                        "\"[^>]*>\\s*<Time[^>]*>\\s*<Information Name=\"step\" Value=\"([0-9]+)\"");
  std::smatch m;
  if (!std::regex_search(xdmf, m, grid)) return {};
  return {"/frame_" + m[1].str(), std::stol(m[2].str())};
}

/// A frame's tets as rows of their corners' mean position (m) and von Mises stress (Pa): the
/// same rows, in another order, for one rank and for several writing one file. The connectivity is
/// /mesh/tets unless the frame carries its own (`xdmf` says which).
std::vector<std::array<double, 4>> tet_rows(const fs::path& h5, const std::string& group, const std::string& xdmf) {
  const std::string own = group + "/tets";
  const std::string topology = has(xdmf, "fields.h5:" + own + "<") ? own : "/mesh/tets";
  const std::vector<int> ids = h5_values<int>(h5, topology);
  const std::vector<double> x = h5_doubles(h5, group + "/x"), vm = h5_doubles(h5, group + "/von_mises");
  std::vector<std::array<double, 4>> rows(vm.size());
  if (ids.size() != 4 * vm.size()) return {};
  for (std::size_t t = 0; t < rows.size(); ++t) {
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 4; ++c) rows[t][k] += x[3 * std::size_t(ids[4 * t + c]) + k] / 4;
    rows[t][3] = vm[t];
  }
  return rows;
}

/// Each row of `b` against the row of `a` whose centre is nearest: the largest of the centres'
/// distance over 1 mm and the stress difference over the largest stress.
double tet_mismatch(const std::vector<std::array<double, 4>>& a, const std::vector<std::array<double, 4>>& b) {
  double far = 0, stress = 0, vm_max = 0;
  for (const auto& r : a) vm_max = std::max(vm_max, r[3]);
  for (const auto& q : b) {
    auto dist = [&](const std::array<double, 4>& r) { return std::hypot(r[0] - q[0], r[1] - q[1], r[2] - q[2]); };
    const std::array<double, 4>* near = &a.front();
    for (const auto& r : a)
      if (dist(r) < dist(*near)) near = &r;
    far = std::max(far, dist(*near));
    stress = std::max(stress, std::fabs((*near)[3] - q[3]));
  }
  return std::max(far / 1e-3, stress / vm_max);
}

}  // namespace

TEST(CliRanks, TwoRanksWriteTheOneRankResults) {
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks");
  const fs::path one = tmp.path / "one", two = tmp.path / "two";
  const Outcome a = run_fdem("run " + quote(kScene) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Outcome b = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " -q -o " + quote(two.string()));
  ASSERT_EQ(b.code, 0) << b.text;
  EXPECT_TRUE(has(b.text, "on 2 MPI ranks")) << b.text;
  // Through the peak and 73 broken CE6s with contact: the same curve to 10 digits (the CSV's).
  EXPECT_LT(monitor_difference(read_csv(one / "monitors.csv"), read_csv(two / "monitors.csv")), 1e-9);
  EXPECT_EQ(slurp(one / "broken_ce6.csv"), slurp(two / "broken_ce6.csv"));
  EXPECT_GT(read_csv(two / "broken_ce6.csv").rows.size(), 50u);
  // One fields.h5 for both ranks, and its index; each tet written once, with its rank.
  for (const char* f : {"fields.h5", "fields.xdmf", "summary.csv"}) EXPECT_TRUE(fs::exists(two / f)) << f;
  for (const char* f : {"fields_rank0.h5", "fields_rank1.h5"}) EXPECT_FALSE(fs::exists(two / f)) << f;
  const std::string x1 = slurp(one / "fields.xdmf"), x2 = slurp(two / "fields.xdmf");
  EXPECT_TRUE(has(x2, "\"rank\"") && has(x2, "_peak\"")) << x2.substr(0, 2000);
  EXPECT_EQ(h5_doubles(two / "fields.h5", frame_labelled(x2, "final").group + "/rank").size(),
            h5_doubles(one / "fields.h5", frame_labelled(x1, "final").group + "/von_mises").size());
  // The final frame's tets, by their corners and stress, are the one-rank frame's.
  for (const char* label : {"peak", "final"}) {
    const FrameInfo f1 = frame_labelled(x1, label), f2 = frame_labelled(x2, label);
    ASSERT_EQ(f1.step, f2.step) << label;
    ASSERT_GE(f1.step, 0) << label;
    const std::vector<std::array<double, 4>> t1 = tet_rows(one / "fields.h5", f1.group, x1),
                                             t2 = tet_rows(two / "fields.h5", f2.group, x2);
    ASSERT_EQ(t1.size(), t2.size()) << label;
    ASSERT_FALSE(t1.empty());
    EXPECT_LT(tet_mismatch(t1, t2), 1e-9) << label;
  }
}

/// `scene` run on two ranks from the rank files fdem partition writes under dir: its monitors.
Csv run_from_rank_files(const std::string& scene, const fs::path& dir) {
  const fs::path parts = dir / "parts", files = dir / "files";
  const Outcome p = run_fdem("partition " + quote(scene) + " -n 2 -o " + quote(parts.string()));
  EXPECT_EQ(p.code, 0) << p.text;
  const Outcome f = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene) + " --partitioned " +
                            quote(parts.string()) + " -q -o " + quote(files.string()));
  EXPECT_EQ(f.code, 0) << f.text;
  return read_csv(files / "monitors.csv");
}

TEST(CliRanks, BoundaryConditionsOnTwoRanksGiveTheOneRankReactions) {
  // Rollers, a fixed face, a pressed end, a pressure and dashpots on a box cut in two: each
  // node's force is counted by its owner once, so the forces and works match the one-rank run
  // to round-off.
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks_conditions");
  const std::string scene = (kData / "cli" / "conditions_box.yaml").string();
  const fs::path one = tmp.path / "one", two = tmp.path / "two";
  const Outcome a = run_fdem("run " + quote(scene) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Outcome b = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene) + " -q -o " + quote(two.string()));
  ASSERT_EQ(b.code, 0) << b.text;
  const Csv c1 = read_csv(one / "monitors.csv"), c2 = read_csv(two / "monitors.csv");
  EXPECT_LT(monitor_difference(c1, c2), 1e-9);
  const int rz = column(c1, "bc4_zmax_force_z_N");
  ASSERT_GE(rz, 0) << "the pressed end's column";
  EXPECT_LT(c1.rows.back()[rz], -10) << "the end is loaded";
  const int py = column(c1, "bc5_ymax_force_y_N"), wx = column(c1, "bc6_xmax_work_J");
  ASSERT_GE(py, 0);
  ASSERT_GE(wx, 0);
  EXPECT_NEAR(c1.rows.back()[py], -1e6 * 2e-4, 2e-3 * 1e6 * 2e-4) << "1 MPa on the 10 x 20 mm face";
  EXPECT_LT(c1.rows.back()[wx], 0) << "the dashpots take energy out";
  // Rank 0's cut and the rank files carry the faces' and nodes' conditions too: the same run.
  const fs::path root = tmp.path / "root";
  const Outcome o =
      run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene) + " --distribute root -q -o " + quote(root.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_LT(monitor_difference(c1, read_csv(root / "monitors.csv")), 1e-9);
  EXPECT_LT(monitor_difference(c1, run_from_rank_files(scene, tmp.path)), 1e-9);
}

/// `scene` on two ranks (DMPlex's cut, then rank 0's, into tmp/two and tmp/two_root) and from rank
/// files: each run's monitors within 1e-6 of the one-rank run's (c1); `also` checks each two-rank
/// run's folder further.
void two_rank_runs_match(const std::string& scene, const fs::path& tmp, const Csv& c1,
                         const std::function<void(const fs::path&)>& also) {
  for (const char* how : {"", " --distribute root"}) {
    SCOPED_TRACE(how);
    const fs::path two = tmp / (std::string("two") + (*how ? "_root" : ""));
    const Outcome b =
        run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene) + how + " -q -o " + quote(two.string()));
    ASSERT_EQ(b.code, 0) << b.text;
    EXPECT_LT(monitor_difference(c1, read_csv(two / "monitors.csv")), 1e-6);
    also(two);
  }
  EXPECT_LT(monitor_difference(c1, run_from_rank_files(scene, tmp)), 1e-6);
}

TEST(CliRanks, MaterialsOnTwoRanksGiveTheOneRankRun) {
  // Two layers of different stiffness and density joined by a weak interface that breaks: each
  // tet's material and each CE6's law travel with the cut (DMPlex, rank 0's, the rank files).
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks_materials");
  const std::string scene = (kData / "cli" / "materials_box.yaml").string();
  const Outcome c = run_fdem("check " + quote(scene));
  ASSERT_EQ(c.code, 0) << c.text;
  EXPECT_TRUE(cli_test::has(c.text, "material 'stiff' (volume groups upper): ")) << c.text;
  EXPECT_TRUE(cli_test::has(c.text, "interface 'soft' | 'stiff': ")) << c.text;
  const fs::path one = tmp.path / "one";
  const Outcome a = run_fdem("run " + quote(scene) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Csv c1 = read_csv(one / "monitors.csv");
  const int broken = column(c1, "broken_ce6");
  ASSERT_GE(broken, 0);
  EXPECT_GT(c1.rows.back()[broken], 0) << "the interface broke";
  EXPECT_TRUE(cli_test::has(slurp(one / "fields.xdmf"), "<Attribute Name=\"material\""))
      << "each tet's material as a field";
  EXPECT_TRUE(cli_test::has(slurp(one / "fields.xdmf"), "<Attribute Name=\"youngs_modulus_factor\""));
  EXPECT_TRUE(cli_test::has(slurp(one / "fields.xdmf"), "<Attribute Name=\"group\"")) << "each tet's volume group";
  two_rank_runs_match(scene, tmp.path, c1, [&](const fs::path& two) {
    EXPECT_EQ(c1.rows.back()[broken], read_csv(two / "monitors.csv").rows.back()[broken]);
    EXPECT_TRUE(cli_test::has(slurp(two / "fields.xdmf"), "<Attribute Name=\"group\""));
  });
}

TEST(CliRanks, AFrictionalJointOnTwoRanksGivesTheOneRankRun) {
  // A block sliding on a frictional joint, held by tet-tet contact: each tet's joint (its
  // contact friction), the joint's CE6 law and the contact candidates of its broken-from-the-
  // start faces travel with the cut (DMPlex, rank 0's, the rank files).
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks_joints");
  const std::string scene = (kData / "cli" / "joints_box.yaml").string();
  const Outcome c = run_fdem("check " + quote(scene));
  ASSERT_EQ(c.code, 0) << c.text;
  EXPECT_TRUE(cli_test::has(c.text, "joint 'bedding' (surfaces bedding): ")) << c.text;
  const fs::path one = tmp.path / "one";
  const Outcome a = run_fdem("run " + quote(scene) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Csv c1 = read_csv(one / "monitors.csv");
  const int joint = column(c1, "joint_broken_ce6"), broken = column(c1, "broken_ce6");
  ASSERT_GE(joint, 0);
  ASSERT_GE(broken, 0);
  EXPECT_GT(c1.rows.front()[joint], 0) << "broken from the start";
  EXPECT_EQ(c1.rows.back()[broken], 0) << "the rock's count leaves the joint out";
  EXPECT_TRUE(cli_test::has(slurp(one / "broken_ce6.csv"), ",4,bedding\n")) << "never bonded, on the joint";
  EXPECT_TRUE(cli_test::has(slurp(one / "fields.xdmf"), "<Attribute Name=\"joint\""));
  two_rank_runs_match(scene, tmp.path, c1, [&](const fs::path& two) {
    EXPECT_EQ(slurp(one / "broken_ce6.csv"), slurp(two / "broken_ce6.csv"));
  });
}

TEST(CliRanks, AnExcavationOnTwoRanksGivesTheOneRankRun) {
  // The upper layer of a box in in-situ stress excavated and relaxed, with every tet a contact
  // candidate: each tet's stage travels with the cut (DMPlex, rank 0's, the rank files), every
  // rank removes its part at the same step, and the removed tets leave the candidates.
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks_excavation");
  const std::string scene = (kData / "cli" / "excavation_box.yaml").string();
  const Outcome c = run_fdem("check " + quote(scene));
  ASSERT_EQ(c.code, 0) << c.text;
  std::smatch lower;  // the lower layer's tets, which stay
  ASSERT_TRUE(std::regex_search(c.text, lower, std::regex("group volume 'lower' \\(3D, tag 1\\): ([0-9]+) tets")))
      << c.text;
  EXPECT_TRUE(cli_test::has(c.text, "excavation stage 0: volume 'upper'")) << c.text;
  const fs::path one = tmp.path / "one";
  const Outcome a = run_fdem("run " + quote(scene) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Csv c1 = read_csv(one / "monitors.csv");
  const int active = column(c1, "active_tets"), strain = column(c1, "strain_J");
  ASSERT_GE(active, 0);
  EXPECT_GT(c1.rows.front()[active], std::stod(lower[1])) << "every tet a candidate";
  EXPECT_EQ(c1.rows.back()[active], std::stod(lower[1])) << "the lower layer's tets only";
  EXPECT_LT(c1.rows.back()[strain], 0.0) << "J: the lower layer gave up in-situ energy";
  EXPECT_TRUE(cli_test::has(slurp(one / "fields.xdmf"), "<Attribute Name=\"initial_stress_zz\""));
  two_rank_runs_match(scene, tmp.path, c1, [&](const fs::path& two) {
    EXPECT_EQ(c1.rows.back()[active], read_csv(two / "monitors.csv").rows.back()[active]);
  });
}

// The first job's ranks (the launcher's children) are stopped while the second job tries the
// folder, so a fast first job cannot end before the second starts. Stopped ranks keep the lock.
const std::string kStopRanks = "kids=$(cat /proc/$pid/task/*/children 2>/dev/null); kill -STOP $kids; ";
const std::string kContinueRanks = "kill -CONT $kids; ";

TEST(CliRanks, ASecondJobIntoAFolderInUseIsRefused) {
  // Rank 0 holds the folder's lock for the whole job: a second two-rank job into it ends with
  // exit 2 on every rank before writing, and the first finishes with the two-rank results.
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("ranks_lock");
  const fs::path x = tmp.path / "x", alone = tmp.path / "alone";
  const std::string job = mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " -q -o ";
  ASSERT_EQ(run_cmd(job + quote(alone.string())).code, 0);
  const std::string script = job + quote(x.string()) + " & pid=$!; for i in $(seq 1500); do [ \"$(cat " +
                             quote((x / "monitors.csv").string()) +
                             " 2>/dev/null | wc -l)\" -ge 3 ] && break; sleep 0.02; done; " + kStopRanks + job +
                             quote(x.string()) + "; echo second=$?; " + kContinueRanks + "wait $pid; echo first=$?";
  const Outcome o = run_cmd("bash -c " + quote(script));
  EXPECT_TRUE(has(o.text, "second=2")) << o.text;
  EXPECT_TRUE(has(o.text, "first=0")) << o.text;
  EXPECT_TRUE(has(o.text, "is the output folder of a run still going on")) << o.text;
  EXPECT_EQ(slurp(x / "monitors.csv"), slurp(alone / "monitors.csv"));
}

TEST(CliRanks, RankFilesFromPartitionGiveTheSameRun) {
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("partition");
  const fs::path parts = tmp.path / "parts", fly = tmp.path / "fly", files = tmp.path / "files";
  const Outcome p = run_fdem("partition " + quote(kScene) + " -n 2 -o " + quote(parts.string()));
  ASSERT_EQ(p.code, 0) << p.text;
  EXPECT_TRUE(fs::exists(parts / "rank_0.fdp") && fs::exists(parts / "rank_1.fdp")) << p.text;
  // -o naming a file: exit 4 naming it and the fix, the file kept (it was a raw filesystem error, exit 1).
  std::ofstream(tmp.path / "a_file") << "keep";
  const Outcome f = run_fdem("partition " + quote(kScene) + " -n 2 -o " + quote((tmp.path / "a_file").string()));
  EXPECT_EQ(f.code, 4) << f.text;
  EXPECT_TRUE(has(f.text, "cannot create the folder '" + (tmp.path / "a_file").string() + "' for the rank files"))
      << f.text;
  EXPECT_EQ(slurp(tmp.path / "a_file"), "keep");
  const std::string steps = " -q -o ";
  const Outcome a = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + steps + quote(fly.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  // On the fly through DMPlex where fdem has PETSc (the default there), and from rank 0.
  EXPECT_EQ(has(a.text, "distribution: PETSc DMPlex"), bool(FDEM_TEST_HAVE_PETSC)) << a.text;
  const Outcome b = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " --partitioned " +
                            quote(parts.string()) + steps + quote(files.string()));
  ASSERT_EQ(b.code, 0) << b.text;
  EXPECT_EQ(slurp(fly / "monitors.csv"), slurp(files / "monitors.csv"));
  EXPECT_EQ(slurp(fly / "broken_ce6.csv"), slurp(files / "broken_ce6.csv"));
  const fs::path root = tmp.path / "root";
  const Outcome r =
      run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " --distribute root" + steps + quote(root.string()));
  ASSERT_EQ(r.code, 0) << r.text;
  EXPECT_TRUE(has(r.text, "distribution: rank 0 cut every rank's part")) << r.text;
  EXPECT_EQ(slurp(root / "monitors.csv"), slurp(files / "monitors.csv"));
  EXPECT_EQ(slurp(root / "broken_ce6.csv"), slurp(files / "broken_ce6.csv"));
  if (!FDEM_TEST_HAVE_PETSC) {  // asking for DMPlex without PETSc: a clear refusal
    const Outcome x = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " --distribute plex" + steps +
                              quote((tmp.path / "x").string()));
    EXPECT_EQ(x.code, 2) << x.text;
    EXPECT_TRUE(has(x.text, "without PETSc") && has(x.text, "--distribute root")) << x.text;
  }

  // Rank files of the scene without contact, run with contact: refused on every rank (the run
  // held no contact ghosts and lost contacts across ranks without a word); and --contact-reach
  // beside --partitioned, which it cannot change.
  const fs::path no_contact = cli_test::scene_variant(
      kScene, tmp.path, "no_contact", {{"contact: {activation: adaptive}", "contact: {activation: none}"}});
  const fs::path parts_nc = tmp.path / "parts_nc";
  ASSERT_EQ(run_fdem("partition " + quote(no_contact.string()) + " -n 2 -o " + quote(parts_nc.string())).code, 0);
  const Outcome nc = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " --partitioned " +
                             quote(parts_nc.string()) + steps + quote((tmp.path / "nc").string()));
  EXPECT_EQ(nc.code, 2) << nc.text;
  EXPECT_TRUE(has(nc.text, "written for a scene without contact (contact reach 0 m)")) << nc.text;
  const Outcome reach =
      run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(kScene) + " --partitioned " + quote(parts.string()) +
              " --contact-reach 0.001" + steps + quote((tmp.path / "reach").string()));
  EXPECT_EQ(reach.code, 2) << reach.text;
  EXPECT_TRUE(has(reach.text, "--contact-reach 0.001 with --partitioned")) << reach.text;

  // Rank files for two ranks on one: refused, naming the file and the fix.
  const Outcome c = run_fdem("run " + quote(kScene) + " --partitioned " + quote(parts.string()) + " -q -o " +
                             quote((tmp.path / "wrong").string()));
  EXPECT_EQ(c.code, 2) << c.text;
  EXPECT_TRUE(has(c.text, "rank_0.fdp") && has(c.text, "mpiexec -n 2")) << c.text;
  // A folder without rank files: named as one, with fdem partition's fix (not a checkpoint's).
  const Outcome m = run_fdem("run " + quote(kScene) + " --partitioned " + quote((tmp.path / "none").string()) +
                             " -q -o " + quote((tmp.path / "m").string()));
  EXPECT_EQ(m.code, 2) << m.text;
  EXPECT_TRUE(has(m.text, "rank_0.fdp: cannot open the rank file") && has(m.text, "fdem partition -o")) << m.text;
  EXPECT_FALSE(has(m.text, "checkpoint")) << m.text;
}

TEST(CliRanks, ABadInputOnOneRankEndsTheJobWithItsMessage) {
  // Four ranks (oversubscribed): the others wait in their first exchange, and the failing rank's
  // MPI_Abort must end them all within seconds.
  if (mpiexec(4).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("fail");
  // Ranks 0-2 read a good scene and go on to the first exchange; rank 3 cannot read its scene.
  const std::string bad = (kData / "bad_scenes" / "negative_modulus.yaml").string();
  ASSERT_TRUE(fs::exists(bad));
  const std::string exe = find_mpiexec();
  auto t0 = std::chrono::steady_clock::now();
  const Outcome o = run_cmd(kMpiEnv + kEnv + "timeout 120 " + quote(exe) + " -n 3 " + quote(kExe) + " run " +
                            quote(kScene) + " -q -o " + quote((tmp.path / "a").string()) + " : -n 1 " + quote(kExe) +
                            " run " + quote(bad) + " -q -o " + quote((tmp.path / "b").string()));
  double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(o.code, 0) << o.text;
  EXPECT_NE(o.code, 124) << "the job hung until timeout killed it: " << o.text;
  EXPECT_LT(s, 60) << o.text;
  EXPECT_TRUE(has(o.text, "rank 3: error:")) << o.text;
  EXPECT_TRUE(has(o.text, "negative_modulus.yaml")) << o.text;
  EXPECT_FALSE(has(o.text, "finished:")) << o.text;
  std::printf("a bad scene on rank 3 of 4 ended the job in %.1f s\n", s);

  // A damaged rank file on one rank: the same.
  const fs::path parts = tmp.path / "parts";
  ASSERT_EQ(run_fdem("partition " + quote(kScene) + " -n 4 -o " + quote(parts.string())).code, 0);
  fs::resize_file(parts / "rank_2.fdp", fs::file_size(parts / "rank_2.fdp") / 2);
  t0 = std::chrono::steady_clock::now();
  const Outcome d = run_cmd(mpiexec(4) + "timeout 120 " + quote(kExe) + " run " + quote(kScene) + " --partitioned " +
                            quote(parts.string()) + " -q -o " + quote((tmp.path / "c").string()));
  s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_NE(d.code, 0) << d.text;
  EXPECT_NE(d.code, 124) << d.text;
  EXPECT_LT(s, 60) << d.text;
  EXPECT_TRUE(has(d.text, "rank 2: error:") && has(d.text, "rank_2.fdp")) << d.text;
  EXPECT_TRUE(has(d.text, "not a usable fdem rank file") && has(d.text, "again with fdem partition")) << d.text;
  EXPECT_FALSE(has(d.text, "other checkpoint")) << d.text;
  std::printf("a damaged rank file on rank 2 of 4 ended the job in %.1f s\n", s);
}

TEST(CliRanks, ARankKilledMidRunEndsTheJob) {
  if (mpiexec(4).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("kill");
  // A long run (1e6 steps) on four ranks; one of them is killed once all are stepping.
  const fs::path scene = tmp.path / "long.yaml";
  {
    std::ofstream o(scene);
    o << slurp(kScene) << "\n";
  }
  std::string text = slurp(scene);
  text.replace(text.find("end: {steps: 3000}"), 18, "end: {steps: 1000000}");
  {
    std::ofstream o(scene);
    o << text;
  }
  const fs::path log = tmp.path / "log.txt";
  const std::string cmd = mpiexec(4) + "timeout 300 " + quote(kExe) + " run " + quote(scene.string()) + " -o " +
                          quote((tmp.path / "out").string()) + " > " + quote(log.string()) + " 2>&1; echo $? > " +
                          quote((tmp.path / "rc").string());
  ASSERT_EQ(std::system(("(" + cmd + ") &").c_str()), 0);
  // Wait until the run has written monitor rows (every rank past the start), then kill one.
  const fs::path mon = tmp.path / "out" / "monitors.csv";
  for (int i = 0; i < 600 && !(fs::exists(mon) && fs::file_size(mon) > 2000); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(mon)) << slurp(log);
  const std::string marker = quote("^" + kExe + " run " + scene.string());
  const auto t0 = std::chrono::steady_clock::now();
  // The newest fdem process of this run is one of its ranks.
  ASSERT_EQ(std::system(("pkill -KILL -n -f " + marker).c_str()) >> 8, 0);
  const fs::path rc = tmp.path / "rc";
  for (int i = 0; i < 1200 && !fs::exists(rc); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(fs::exists(rc)) << "the job did not end within 120 s of a rank's death";
  const int code = std::stoi(slurp(rc));
  EXPECT_NE(code, 0);
  EXPECT_NE(code, 124) << "timeout ended it, not MPI";
  EXPECT_LT(s, 60) << "the job should end within seconds of a rank's death";
  EXPECT_FALSE(fs::exists(tmp.path / "out" / "summary.csv"));
  std::printf("a killed rank ended the job in %.1f s (exit %d)\n", s, code);
}

TEST(CliRanks, TwoRanksRestartBitForBitFromTheirCheckpoints) {
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("restart");
  const fs::path whole = tmp.path / "whole", cut = tmp.path / "cut", term = tmp.path / "term";
  auto scene_with = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string text = slurp(kScene);
    text.replace(text.find(from), from.size(), to);
    const fs::path p = tmp.path / name;
    std::ofstream(p) << text;
    return p.string();
  };
  const std::string run = mpiexec(2) + quote(kExe) + " run ";
  const Outcome a = run_cmd(run + quote(kScene) + " -q -o " + quote(whole.string()));
  ASSERT_EQ(a.code, 0) << a.text;

  // (a) A checkpoint every 500 steps, the run ending at step 1000, then continued to 3000.
  const std::string short_scene = scene_with("short.yaml", "end: {steps: 3000}", "end: {steps: 1000}");
  std::string text = slurp(short_scene);
  text.replace(text.find("checkpoint_wall_interval: 0"), 27, "checkpoint_wall_interval: 0, checkpoint_interval: 500");
  std::ofstream(short_scene) << text;
  const Outcome b = run_cmd(run + quote(short_scene) + " -q -o " + quote(cut.string()));
  ASSERT_EQ(b.code, 0) << b.text;
  EXPECT_TRUE(fs::exists(cut / "checkpoints" / "step_000000000500.rank0of2.ckpt"));
  EXPECT_TRUE(fs::exists(cut / "checkpoints" / "step_000000000500.rank1of2.ckpt"));
  const Outcome c =
      run_cmd(run + quote(kScene) + " -q -o " + quote(cut.string()) + " --restart " + quote(cut.string()));
  ASSERT_EQ(c.code, 0) << c.text;
  EXPECT_TRUE(has(c.text, "continuing from")) << c.text;
  for (const char* f : {"monitors.csv", "broken_ce6.csv", "fields.xdmf"})
    EXPECT_EQ(slurp(whole / f), slurp(cut / f)) << f;
  // The shared fields.h5: the continued run's frames hold the uninterrupted run's values.
  int frames = 0;
  for (;; ++frames) {
    char group[32];
    std::snprintf(group, sizeof group, "/frame_%06d", frames);
    const std::vector<double> x = h5_doubles(whole / "fields.h5", std::string(group) + "/x");
    if (x.empty()) break;
    EXPECT_EQ(x, h5_doubles(cut / "fields.h5", std::string(group) + "/x")) << group;
    EXPECT_EQ(h5_doubles(whole / "fields.h5", std::string(group) + "/von_mises"),
              h5_doubles(cut / "fields.h5", std::string(group) + "/von_mises"))
        << group;
  }
  EXPECT_GT(frames, 5);
  EXPECT_TRUE(h5_doubles(cut / "fields.h5", "/frame_" + std::string(6 - std::to_string(frames).size(), '0') +
                                                std::to_string(frames) + "/x")
                  .empty())
      << "no frame beyond those of the uninterrupted run";

  // (b) SIGTERM to both ranks mid-run: each writes its checkpoint of the same step, the job
  // ends with exit 5 and the command that continues it; continuing gives the same files.
  const std::string log = (tmp.path / "term.log").string(), rc = (tmp.path / "term.rc").string();
  ASSERT_EQ(std::system(("(" + run + quote(kScene) + " -o " + quote(term.string()) + " > " + quote(log) +
                         " 2>&1; echo $? > " + quote(rc) + ") &")
                            .c_str()),
            0);
  const fs::path mon = term / "monitors.csv";
  for (int i = 0; i < 600 && !(fs::exists(mon) && fs::file_size(mon) > 4000); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::system(("pkill -TERM -f " + quote("^" + kExe + " run " + kScene)).c_str());
  for (int i = 0; i < 1200 && !fs::exists(rc); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(rc));
  const std::string term_log = slurp(log);
  if (std::stoi(slurp(rc)) == 0) GTEST_SKIP() << "the run finished before the signal: " << term_log;
  EXPECT_EQ(std::stoi(slurp(rc)), 5) << term_log;
  EXPECT_TRUE(has(term_log, "continue with: mpiexec -n 2 fdem run")) << term_log;
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(term / "checkpoints")) files += e.path().extension() == ".ckpt";
  EXPECT_EQ(files, 2u) << "one file per rank of the same step";
  const Outcome d =
      run_cmd(run + quote(kScene) + " -q -o " + quote(term.string()) + " --restart " + quote(term.string()));
  ASSERT_EQ(d.code, 0) << d.text;
  for (const char* f : {"monitors.csv", "broken_ce6.csv", "fields.xdmf"})
    EXPECT_EQ(slurp(whole / f), slurp(term / f)) << f;
}

TEST(CliRanks, PeakFramesKeptBeforeContactGhostsGrowAreWrittenWhole) {
  // The pre-peak and peak frames are kept in memory and written once the stress has fallen 5 %
  // past the peak. On several ranks the contact ghosts may be gathered again in between and add
  // tets (and their nodes and CE6s) to a rank model: the kept frames are then written in the
  // grown layout, the new ghosts with their present state (a rank writes its own tets only).
  // A finer box than the other tests' (2.5 mm elements) and a contact reach of 0.02 mm: after the
  // peak (near step 2600) the fragments slide far enough that a gathering adds a tet before the
  // 5 % drop (near step 2850). The kept frames must hold the state of their own step, as the
  // same frames of a run on one rank do.
  if (mpiexec(2).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("peak_ghosts");
  const fs::path scene = scene_variant(
      kScene, tmp.path, "fine",
      {{"element_size: 0.005", "element_size: 0.0025"}, {"plot: false", "plot: false, peak_frames: true"}});
  const fs::path one = tmp.path / "one", two = tmp.path / "two";
  const Outcome a = run_fdem("run " + quote(scene.string()) + " -q -o " + quote(one.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Outcome b = run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene.string()) + " --contact-reach 2e-5 -o " +
                            quote(two.string()));
  ASSERT_EQ(b.code, 0) << b.text;

  const std::string x1 = slurp(one / "fields.xdmf"), x2 = slurp(two / "fields.xdmf");
  const FrameInfo pre = frame_labelled(x2, "pre-peak"), post = frame_labelled(x2, "post-peak");
  ASSERT_GE(pre.step, 0) << x2;
  ASSERT_GT(post.step, pre.step) << x2;
  // The case this test is for: a gathering that added tets after the first kept frame, before
  // the kept frames were written (the log line comes before the frames at the same row).
  const std::regex grew("gathered again [0-9]+ time\\(s\\) by step ([0-9]+) [^\\n]*, ([0-9]+) tets added");
  long added = 0;
  for (std::sregex_iterator it(b.text.begin(), b.text.end(), grew), end; it != end; ++it)
    if (const long step = std::stol((*it)[1].str()); step > pre.step && step <= post.step)
      added += std::stol((*it)[2].str());
  ASSERT_GT(added, 0) << "no gathering added tets between step " << pre.step << " and " << post.step
                      << ": the scene no longer reaches the case this test is for\n"
                      << b.text;

  const fs::path h5 = two / "fields.h5";
  for (const char* label : {"pre-peak", "peak"}) {
    const FrameInfo f1 = frame_labelled(x1, label), f2 = frame_labelled(x2, label);
    EXPECT_EQ(f2.step, f1.step) << label;
    // The nodes of the ranks' own tets, as in the frame written after the gathering.
    EXPECT_EQ(h5_doubles(h5, f2.group + "/x").size(), h5_doubles(h5, post.group + "/x").size()) << label;
    // The state of the frame's own step: each tet's centre and von Mises stress as on one rank.
    const std::vector<std::array<double, 4>> t1 = tet_rows(one / "fields.h5", f1.group, x1),
                                             t2 = tet_rows(h5, f2.group, x2);
    ASSERT_EQ(t1.size(), t2.size()) << label;
    ASSERT_FALSE(t1.empty());
    EXPECT_LT(tet_mismatch(t1, t2), 1e-9) << label;
  }
}

namespace {

/// summary.csv's value in `name`'s column.
double summary_value(const fs::path& folder, const std::string& name) {
  const Csv s = read_csv(folder / "summary.csv");
  const int c = column(s, name);
  return c >= 0 && !s.rows.empty() ? s.rows[0][std::size_t(c)] : NAN;
}

/// The run's continuation from the checkpoint in `folder` on `ranks` ranks (1: without mpiexec).
Outcome continue_on(int ranks, const std::string& scene, const fs::path& folder, const std::string& more = "") {
  const std::string args =
      " run " + quote(scene) + more + " -o " + quote(folder.string()) + " --restart " + quote(folder.string());
  return ranks == 1 ? run_fdem(args) : run_cmd(mpiexec(ranks) + quote(kExe) + args);
}

}  // namespace

TEST(CliRanks, ACheckpointOfTwoRanksContinuesOnThreeAndOnOne) {
  // The state of every rank's file in global numbering, taken into the layout of another rank
  // count. The checkpoint at step 1000 is taken before the peak (near step 1100), while the
  // states kept for the pre-peak frame wait in memory; the runs continue through fracture.
  if (mpiexec(3).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("rerank");
  const fs::path scene = scene_variant(
      kScene, tmp.path, "short",
      {{"end: {steps: 3000}", "end: {steps: 1050}"}, {"checkpoint_wall_interval: 0", "checkpoint_interval: 500"}});
  struct Case {
    int saved, continued;
  };
  for (const Case k : {Case{2, 3}, Case{2, 1}, Case{1, 2}}) {
    const std::string name = std::to_string(k.saved) + "to" + std::to_string(k.continued);
    SCOPED_TRACE(name);
    const fs::path whole = tmp.path / ("whole" + std::to_string(k.saved)), cut = tmp.path / name;
    auto run_on = [&](int ranks, const std::string& sc, const fs::path& out) {
      const std::string args = " run " + quote(sc) + " -q -o " + quote(out.string());
      return ranks == 1 ? run_fdem(args) : run_cmd(mpiexec(ranks) + quote(kExe) + args);
    };
    if (!fs::exists(whole)) {
      ASSERT_EQ(run_on(k.saved, kScene, whole).code, 0);
    }
    ASSERT_EQ(run_on(k.saved, scene.string(), cut).code, 0);
    const Outcome c = continue_on(k.continued, kScene, cut);
    ASSERT_EQ(c.code, 0) << c.text;
    EXPECT_TRUE(has(c.text, "step_000000001000") && has(c.text, "taken into " + std::to_string(k.continued))) << c.text;
    // To the peak, the uninterrupted run's monitors to round-off; through fracture, its peak and
    // broken CE6 within the multi-rank tolerances.
    const Csv a = read_csv(whole / "monitors.csv"), b = read_csv(cut / "monitors.csv");
    const int stress = column(a, "axial_stress_Pa"), step = column(a, "step");
    ASSERT_GE(stress, 0);
    std::size_t peak = 0;
    for (std::size_t r = 0; r < a.rows.size(); ++r)
      if (a.rows[r][stress] > a.rows[peak][stress]) peak = r;
    EXPECT_GT(a.rows[peak][step], 1000) << "the peak after the checkpoint";
    EXPECT_LT(monitor_difference(a, b, a.rows[peak][step]), 1e-9);
    EXPECT_NEAR(summary_value(cut, "peak_stress_Pa"), summary_value(whole, "peak_stress_Pa"),
                0.01 * summary_value(whole, "peak_stress_Pa"));
    EXPECT_NEAR(summary_value(cut, "broken_ce6"), summary_value(whole, "broken_ce6"),
                0.05 * summary_value(whole, "broken_ce6"));
    // The pre-peak and peak frames, written from states kept before the checkpoint and carried
    // into the new layout: each tet as in the uninterrupted run.
    const std::string xa = slurp(whole / "fields.xdmf"), xb = slurp(cut / "fields.xdmf");
    for (const char* label : {"pre-peak", "peak"}) {
      const FrameInfo fa = frame_labelled(xa, label), fb = frame_labelled(xb, label);
      ASSERT_GE(fa.step, 0) << label << xa;
      EXPECT_EQ(fb.step, fa.step) << label;
      if (std::string(label) == "pre-peak") {
        EXPECT_LT(fa.step, 1000) << "kept before the checkpoint";
      }
      const auto ta = tet_rows(whole / "fields.h5", fa.group, xa), tb = tet_rows(cut / "fields.h5", fb.group, xb);
      ASSERT_EQ(ta.size(), tb.size()) << label;
      ASSERT_FALSE(ta.empty()) << label;
      EXPECT_LT(tet_mismatch(ta, tb), 1e-9) << label;
    }
  }
}

TEST(CliRanks, ACheckpointAfterTheContactGhostsGrewContinuesOnThreeRanks) {
  // A rank model grown by a gathering of contact ghosts (saved whole in its checkpoint) is
  // replaced by the partition for three ranks; the ghosts are gathered at the positions reached.
  // The finer box of PeakFramesKeptBeforeContactGhostsGrow..., whose gathering near step 2850
  // adds a tet, checkpointed at step 2900.
  if (mpiexec(3).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("rerank_grown");
  const fs::path fine = scene_variant(kScene, tmp.path, "fine", {{"element_size: 0.005", "element_size: 0.0025"}});
  const fs::path cut_scene = scene_variant(
      fine, tmp.path, "cut",
      {{"end: {steps: 3000}", "end: {steps: 2950}"}, {"checkpoint_wall_interval: 0", "checkpoint_interval: 2900"}});
  const std::string reach = " --contact-reach 2e-5";
  const fs::path whole = tmp.path / "whole", cut = tmp.path / "cut";
  const Outcome a =
      run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(fine.string()) + reach + " -q -o " + quote(whole.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  const Outcome b =
      run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(cut_scene.string()) + reach + " -o " + quote(cut.string()));
  ASSERT_EQ(b.code, 0) << b.text;
  const std::regex grew("by step ([0-9]+) [^\\n]*, ([1-9][0-9]*) tets added");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(b.text, m, grew) && std::stol(m[1].str()) < 2900)
      << "no gathering added tets before the checkpoint: the scene no longer reaches the case this test is for\n"
      << b.text;
  const fs::path one = tmp.path / "one";
  fs::copy(cut, one, fs::copy_options::recursive);
  const Outcome c = continue_on(3, fine.string(), cut, reach);
  ASSERT_EQ(c.code, 0) << c.text;
  EXPECT_TRUE(has(c.text, "saved on 2 ranks and taken into 3")) << c.text;
  // No CE6 has broken by the end: the uninterrupted run's monitors to round-off.
  EXPECT_EQ(summary_value(whole, "broken_ce6"), 0);
  const Csv w = read_csv(whole / "monitors.csv");
  EXPECT_LT(monitor_difference(w, read_csv(cut / "monitors.csv")), 1e-9);
  // On one rank, checkpointed at step 2950 and continued again from there: the rank model of
  // the partition, not the grown one saved, is what this checkpoint holds.
  const fs::path again =
      scene_variant(fine, tmp.path, "again", {{"checkpoint_wall_interval: 0", "checkpoint_interval: 2950"}});
  const Outcome d = continue_on(1, again.string(), one, " -q --contact-reach 2e-5 -t 1");
  ASSERT_EQ(d.code, 0) << d.text;
  ASSERT_TRUE(fs::exists(one / "checkpoints" / "step_000000002950.ckpt"));
  fs::remove(one / "summary.csv");
  const Outcome e = continue_on(1, fine.string(), one, " -q");
  ASSERT_EQ(e.code, 0) << e.text;
  EXPECT_LT(monitor_difference(w, read_csv(one / "monitors.csv")), 1e-9);
}

TEST(CliRanks, ARestartOntoMoreRanksThanTheModelFillsIsRefused) {
  // A 6-tet cube checkpointed on 2 ranks: 7 ranks would leave one without a tet.
  if (mpiexec(7).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("rerank_many");
  const fs::path scene = tmp.path / "cube.yaml";
  std::ofstream(scene) << "name: cube6\nmesh: {file: " << (kData / "meshes" / "cube6_v41.msh").string()
                       << ", scale: 0.01}\nplatens: {velocity: 0.1}\nsolver: {threads: 1, end: {steps: 200}}\n"
                       << "output: {monitor_interval: 50, progress_interval: 0, plot: false, "
                       << "checkpoint_wall_interval: 0, checkpoint_interval: 100}\n";
  const fs::path out = tmp.path / "out";
  ASSERT_EQ(run_cmd(mpiexec(2) + quote(kExe) + " run " + quote(scene.string()) + " -q -o " + quote(out.string())).code,
            0);
  const std::string monitors = slurp(out / "monitors.csv");
  const Outcome many = continue_on(7, scene.string(), out, " -q");
  EXPECT_EQ(many.code, 2) << many.text;
  EXPECT_TRUE(has(many.text, "7 ranks for a model of 6 tets") && has(many.text, "at most 6 ranks")) << many.text;
  EXPECT_EQ(slurp(out / "monitors.csv"), monitors) << "nothing changed";
  EXPECT_TRUE(fs::exists(out / "checkpoints" / "step_000000000100.rank1of2.ckpt"));
  // Six ranks, one tet each, continue it: the two-rank run's monitors.
  const Outcome six = continue_on(6, scene.string(), out, " -q");
  ASSERT_EQ(six.code, 0) << six.text;
  std::ofstream(tmp.path / "two.csv") << monitors;
  EXPECT_LT(monitor_difference(read_csv(tmp.path / "two.csv"), read_csv(out / "monitors.csv")), 1e-9);
}

TEST(CliRanks, ConditionsAndAnExcavationContinueOnAnotherRankCount) {
  // Loaded faces under a pressure and an absorbing condition, whose powers and works each rank
  // keeps in part; and an excavation stage done before the checkpoint, whose forces and removed
  // rock the new ranks take over. From 2 ranks to 3, and to 1 from one named file of the set.
  if (mpiexec(3).empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("rerank_loads");
  struct Case {
    std::string name, end, cut, checkpoint, step;
  };
  const fs::path cli = kData / "cli";
  for (const Case& k : {Case{"conditions_box", "end: {time: 1e-4}", "end: {steps: 2500}", "2000", "2000"},
                        Case{"excavation_box", "end: {time: 4e-5}", "end: {steps: 4100}", "4000", "4000"}}) {
    SCOPED_TRACE(k.name);
    std::vector<std::pair<std::string, std::string>> edits = {
        {k.end, k.cut},
        {"checkpoint_wall_interval: 0", "checkpoint_wall_interval: 0, checkpoint_interval: " + k.checkpoint}};
    if (k.name == "excavation_box")  // (its mesh file is named relative to the scene)
      edits.push_back({"file: layered_box.geo", "file: " + (cli / "layered_box.geo").string()});
    const std::string base = (cli / (k.name + ".yaml")).string();
    const fs::path cut_scene = scene_variant(base, tmp.path, k.name + "_cut", edits);
    const fs::path whole = tmp.path / (k.name + "_whole"), cut = tmp.path / (k.name + "_cut");
    const std::string run = mpiexec(2) + quote(kExe) + " run ";
    ASSERT_EQ(run_cmd(run + quote(base) + " -q -o " + quote(whole.string())).code, 0);
    ASSERT_EQ(run_cmd(run + quote(cut_scene.string()) + " -q -o " + quote(cut.string())).code, 0);
    const fs::path one = tmp.path / (k.name + "_one");
    fs::copy(cut, one, fs::copy_options::recursive);
    const Outcome c = continue_on(3, base, cut);
    ASSERT_EQ(c.code, 0) << c.text;
    EXPECT_TRUE(has(c.text, "step_00000000" + k.step + ".rank0of2.ckpt") && has(c.text, "taken into 3")) << c.text;
    const Csv w = read_csv(whole / "monitors.csv");
    EXPECT_LT(monitor_difference(w, read_csv(cut / "monitors.csv")), 1e-9);
    // One rank, given one file of the set.
    const std::string file = (one / "checkpoints" / ("step_00000000" + k.step + ".rank1of2.ckpt")).string();
    const Outcome o = run_fdem("run " + quote(base) + " -q -o " + quote(one.string()) + " --restart " + quote(file));
    ASSERT_EQ(o.code, 0) << o.text;
    EXPECT_LT(monitor_difference(w, read_csv(one / "monitors.csv")), 1e-9);
  }
}
