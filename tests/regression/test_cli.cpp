// The real `fdem` executable (FDEM_EXE) end to end: help and version, `check`, `run` and
// its output files, bad input (exit 2, message naming the file and the key or element, no
// output folder left behind), an unstable run (exit 3) and launching under mpiexec.
// Scenes live in tests/data/cli/ (and tests/data/bad_scenes/); outputs go to a temp folder.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "solver/series.hpp"

namespace fs = std::filesystem;
using namespace cli_test;

TEST(CliExe, HelpListsTheSubcommands) {
  const Outcome o = run_fdem("--help");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "run")) << o.text;
  EXPECT_TRUE(has(o.text, "check")) << o.text;
  EXPECT_TRUE(has(o.text, "triaxial")) << o.text;
  EXPECT_TRUE(has(o.text, "series")) << o.text;
  EXPECT_TRUE(has(o.text, "Subcommands")) << o.text;
  // Each subcommand has its own help naming its scene argument.
  const Outcome r = run_fdem("run --help");
  EXPECT_EQ(r.code, 0) << r.text;
  EXPECT_TRUE(has(r.text, "scene")) << r.text;
  EXPECT_TRUE(has(r.text, "--output")) << r.text;
}

TEST(CliExe, VersionPrintsTheProjectVersion) {
  const Outcome o = run_fdem("--version");
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, std::string("fdem ") + FDEM_VERSION)) << o.text;
}

TEST(CliExe, UnknownSubcommandsAndOptionsFail) {
  const std::string scene = quote((kData / "cli" / "check_box.yaml").string());
  // (Each launch costs about 0.6 s of MPI start-up, so the list is short.)
  for (const std::string& args :
       {std::string("frobnicate"), "check " + scene + " --frobnicate", "run " + scene + " -t minus"}) {
    const Outcome o = run_fdem(args);
    EXPECT_NE(o.code, 0) << "fdem " << args << "\n" << o.text;
    EXPECT_EQ(o.code, 2) << "fdem " << args << "\n" << o.text;  // a command-line error is bad input
    EXPECT_FALSE(has(o.text, "tets ")) << "fdem " << args << " built a model:\n" << o.text;
  }
}

TEST(CliExe, CheckReportsCountsAndStableStep) {
  TempDir tmp("check");
  const std::string check = "cd " + quote(tmp.path.string()) + " && " + kEnv + quote(kExe) + " check " +
                            quote((kData / "cli" / "check_box.yaml").string());
  const Outcome o = run_cmd(check);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "tets ")) << o.text;
  EXPECT_TRUE(has(o.text, "CE6 ")) << o.text;
  EXPECT_TRUE(has(o.text, "stable step ")) << o.text;
  // Default fracture regions: CE6 everywhere, so 4 nodes per tet.
  long tets = -1, ce6 = -1, nodes = -1;
  const std::size_t at = o.text.find("tets ");
  ASSERT_NE(at, std::string::npos);
  ASSERT_EQ(std::sscanf(o.text.c_str() + at, "tets %ld, CE6 %ld, nodes %ld", &tets, &ce6, &nodes), 3) << o.text;
  EXPECT_GT(tets, 0);
  EXPECT_GT(ce6, 0);
  EXPECT_EQ(nodes, 4 * tets);
  EXPECT_LT(ce6, 2 * tets);  // each tet has 4 faces, some on the surface
  // The stable step is a positive number of seconds, and the time step is half of it.
  double stable = 0, dt = 0;
  const std::size_t s = o.text.find("stable step ");
  ASSERT_EQ(std::sscanf(o.text.c_str() + s, "stable step %lf s", &stable), 1) << o.text;
  const std::size_t d = o.text.find("time step ", s + 12);
  ASSERT_NE(d, std::string::npos) << o.text;
  ASSERT_EQ(std::sscanf(o.text.c_str() + d, "time step %lf s", &dt), 1) << o.text;
  EXPECT_GT(stable, 1e-10);
  EXPECT_LT(stable, 1e-5);
  EXPECT_NEAR(dt, 0.9 * stable, 1e-5 * stable);  // default time_step_safety 0.9
  // `check` writes nothing (run in an empty folder, the default output folder would be there).
  EXPECT_TRUE(fs::is_empty(tmp.path));
}

// fdem check --write-mesh: the generated mesh as a .msh file, which a scene then reads as
// mesh.file to the same model (counts, geometry and time step, as check reports them).
TEST(CliExe, CheckWritesTheMeshThatAFileSceneBuildsTheSameModelFrom) {
  TempDir tmp("write_mesh");
  const fs::path msh = tmp.path / "box.msh";
  const Outcome a =
      run_fdem("check " + quote((kData / "cli" / "check_box.yaml").string()) + " --write-mesh " + quote(msh.string()));
  ASSERT_EQ(a.code, 0) << a.text;
  ASSERT_TRUE(fs::exists(msh)) << a.text;
  EXPECT_TRUE(has(a.text, "mesh written: " + msh.string())) << a.text;
  {
    std::ofstream scene(tmp.path / "from_file.yaml");
    scene << "name: from_file\nmesh: {file: box.msh}\nsolver:\n  end: {steps: 100}\n"
          << "output: {progress_interval: 0, plot: false}\n";
  }
  const Outcome b = run_fdem("check " + quote((tmp.path / "from_file.yaml").string()));
  ASSERT_EQ(b.code, 0) << b.text;
  const std::size_t ia = a.text.find("  tets "), ib = b.text.find("  tets ");
  ASSERT_NE(ia, std::string::npos) << a.text;
  ASSERT_NE(ib, std::string::npos) << b.text;
  EXPECT_EQ(a.text.substr(ia), b.text.substr(ib));  // every count, length and step, to the digits printed
  long vertices = 0, tets = 0, file_tets = 0;
  ASSERT_EQ(std::sscanf(a.text.c_str() + a.text.find("mesh written: "),
                        ("mesh written: " + msh.string() + " (%ld vertices, %ld tets").c_str(), &vertices, &tets),
            2)
      << a.text;
  ASSERT_EQ(std::sscanf(a.text.c_str() + ia, "  tets %ld", &file_tets), 1);
  EXPECT_EQ(tets, file_tets);
  EXPECT_GT(vertices, 8);
  // A folder that does not exist: exit 4 (output), the file named, nothing written, and no
  // model built first (the check comes before the meshing).
  const fs::path bad = tmp.path / "missing" / "box.msh";
  const Outcome c =
      run_fdem("check " + quote((kData / "cli" / "check_box.yaml").string()) + " --write-mesh " + quote(bad.string()));
  EXPECT_EQ(c.code, 4) << c.text;
  EXPECT_TRUE(has(c.text, bad.string())) << c.text;
  EXPECT_FALSE(fs::exists(tmp.path / "missing"));
  EXPECT_FALSE(has(c.text, "tets ")) << c.text;
  // Over the files the check reads (the scene, its mesh.file, by another spelling of the path):
  // exit 2, and both keep their bytes.
  const fs::path scene = tmp.path / "from_file.yaml";
  const std::string scene_text = slurp(scene), mesh_text = slurp(msh);
  for (const auto& [target, names] : {std::pair<fs::path, std::string>{scene, "is the scene file"},
                                      std::pair<fs::path, std::string>{tmp.path / "." / "box.msh", "mesh.file"}}) {
    const Outcome d = run_fdem("check " + quote(scene.string()) + " --write-mesh " + quote(target.string()));
    EXPECT_EQ(d.code, 2) << d.text;
    EXPECT_TRUE(has(d.text, names) && has(d.text, "another file name")) << d.text;
  }
  EXPECT_EQ(slurp(scene), scene_text);
  EXPECT_EQ(slurp(msh), mesh_text);
  // Over a special file (here a pipe; a device such as /dev/full alike, whose node the rename
  // replaced when run as root): refused, the pipe left in place.
  const fs::path pipe = tmp.path / "pipe";
  ASSERT_EQ(::mkfifo(pipe.c_str(), 0600), 0);
  const Outcome e = run_fdem("check " + quote(scene.string()) + " --write-mesh " + quote(pipe.string()));
  EXPECT_EQ(e.code, 4) << e.text;
  EXPECT_TRUE(has(e.text, "not a regular file")) << e.text;
  EXPECT_TRUE(fs::is_fifo(pipe));
}

TEST(CliExe, InvertedTetsInAMeshFileAreFine) {
  const Outcome o = run_fdem("check " + quote((kData / "cli" / "inverted_tets.yaml").string()));
  EXPECT_EQ(o.code, 0) << o.text;
  // cube6_v22.msh: 6 tets of the unit cube (scaled to 1 cm) around one diagonal.
  EXPECT_TRUE(has(o.text, "tets 6, CE6 6, nodes 24, surface faces 12")) << o.text;
}

namespace {

struct BadCase {
  std::string scene;                   // path under tests/data
  std::vector<std::string> must_name;  // substrings of the message
  bool also_check;                     // try `fdem check` too
};

}  // namespace

TEST(CliExe, BadInputExitsTwoNamingTheProblemAndWritesNothing) {
  TempDir tmp("bad");
  const std::vector<BadCase> cases = {
      {"bad_scenes/negative_modulus.yaml", {"negative_modulus.yaml", "material.youngs_modulus"}, true},
      {"bad_scenes/missing_mesh.yaml", {"missing_mesh.yaml", "mesh"}, false},
      {"cli/does_not_exist.yaml", {"does_not_exist.yaml", "does not exist"}, false},
      {"cli/zero_volume_tet.yaml", {"bad_zero_volume.msh", "element tag 7", "volume"}, true},
      {"cli/garbage_msh.yaml", {"bad_garbage.msh", "$MeshFormat"}, false},
      {"bad_scenes/missing_mesh_file.yaml", {"missing_mesh_file.yaml", "mesh.file"}, false},
      {"cli/folded_mesh.yaml", {"bad_overlap.msh", "overlapping"}, true},  // a tet folded over its neighbour
      {"cli/zero_time_step.yaml", {"zero_time_step.yaml", "the time step is 0 s"}, true},
      {"cli/time_step_beyond_bound.yaml",
       {"time_step_beyond_bound.yaml", "solver.time_step: 1 s is", "x the stable-step bound", "lower solver.time_step"},
       true},  // it ran one step and stopped as unstable, advising time_step_safety
      {"cli/endless_run.yaml", {"endless_run.yaml", "solver.end.time takes 1e+294 steps"}, true},  // ran forever
  };
  int i = 0;
  for (const BadCase& c : cases) {
    const std::string scene = quote((kData / c.scene).string());
    const fs::path out = tmp.path / ("out" + std::to_string(i++));
    // `run` with an explicit output folder; `check` takes no options.
    std::vector<std::string> calls{"run " + scene + " -q -o " + quote(out.string())};
    if (c.also_check) calls.push_back("check " + scene);
    for (const std::string& args : calls) {
      const Outcome r = run_fdem(args);
      SCOPED_TRACE("fdem " + args + "\n" + r.text);
      EXPECT_EQ(r.code, 2);
      EXPECT_TRUE(has(r.text, "error")) << r.text;
      for (const std::string& w : c.must_name) EXPECT_TRUE(has(r.text, w)) << "message should name '" << w << "'";
      EXPECT_FALSE(has(r.text, "tets ")) << "a model was reported for bad input";
    }
    EXPECT_FALSE(fs::exists(out)) << c.scene << " left " << out;
  }
  // The scene's own output folder is not created either (run from inside the temp folder).
  const Outcome o = run_cmd("cd " + quote(tmp.path.string()) + " && " + kEnv + quote(kExe) + " run " +
                            quote((kData / "bad_scenes/negative_modulus.yaml").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_FALSE(fs::exists(tmp.path / "out")) << o.text;
}

TEST(CliExe, RunWritesMonitorsAndFields) {
  TempDir tmp("run");
  const fs::path out = tmp.path / "nested" / "run_box";
  const Outcome o =
      run_fdem("run " + quote((kData / "cli" / "run_box.yaml").string()) + " -t 1 -o " + quote(out.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "finished")) << o.text;
  EXPECT_TRUE(has(o.text, "step count 400 reached")) << o.text;
  ASSERT_TRUE(fs::exists(out / "monitors.csv")) << o.text;
  ASSERT_TRUE(fs::exists(out / "fields.xdmf")) << o.text;
  ASSERT_TRUE(fs::exists(out / "fields.h5")) << o.text;
  EXPECT_FALSE(fs::exists(out / "stress_strain.png"));  // output.plot: false
  EXPECT_TRUE(fs::exists(out / "summary.csv"));
  EXPECT_FALSE(fs::exists(out / "summary.csv.tmp"));
  EXPECT_GT(fs::file_size(out / "fields.h5"), 1000u);

  const Csv csv = read_csv(out / "monitors.csv");
  EXPECT_TRUE(csv.bad.empty()) << "non-numeric or non-finite cells, first: " << csv.bad.front();
  const int step = column(csv, "step"), stress = column(csv, "axial_stress_Pa"), strain = column(csv, "axial_strain"),
            err = column(csv, "energy_error");
  ASSERT_GE(step, 0);
  ASSERT_GE(stress, 0);
  ASSERT_GE(strain, 0);
  ASSERT_GE(err, 0);
  // monitor_interval 25, 400 steps: rows at 0, 25, ..., 400.
  ASSERT_EQ(csv.rows.size(), 17u);
  for (std::size_t r = 0; r < csv.rows.size(); ++r) {
    ASSERT_EQ(csv.rows[r].size(), csv.header.size()) << "row " << r;
    EXPECT_EQ(csv.rows[r][step], 25.0 * r);
  }
  EXPECT_EQ(csv.rows[0][stress], 0);
  EXPECT_EQ(csv.rows[0][strain], 0);
  // The platens ramp up smoothly over about three wave transits: the stress rises at every row.
  for (std::size_t r = 1; r < csv.rows.size(); ++r) {
    EXPECT_GT(csv.rows[r][strain], csv.rows[r - 1][strain]) << "row " << r;
    EXPECT_GT(csv.rows[r][stress], csv.rows[r - 1][stress]) << "row " << r;
  }
  // Once at full speed the specimen is loaded quasi-statically: the tangent modulus of the
  // last rows is Young's modulus (12.2 GPa) to within the platen-friction stiffening.
  const auto& a = csv.rows[csv.rows.size() - 5];
  const auto& b = csv.rows.back();
  const double modulus = (b[stress] - a[stress]) / (b[strain] - a[strain]);
  EXPECT_GT(modulus, 0.85 * 12.2e9);
  EXPECT_LT(modulus, 1.2 * 12.2e9);
  EXPECT_LT(b[err], 0.01);  // energy balance

  const std::string xdmf = slurp(out / "fields.xdmf");
  EXPECT_TRUE(has(xdmf, "Xdmf")) << xdmf.substr(0, 200);
  EXPECT_TRUE(has(xdmf, "fields.h5")) << xdmf.substr(0, 400);
  // Adaptive contact (the default): the activation flag is a cell field, and the tets at the
  // platens are active from the start. In this continuous mesh (no CE6) candidate pairs are
  // tets near each other that share no node; none of them overlaps, so none touches.
  EXPECT_TRUE(has(xdmf, "Name=\"active\"")) << xdmf.substr(0, 400);
  const int active = column(csv, "active_tets"), touching = column(csv, "contacts");
  ASSERT_GE(active, 0);
  ASSERT_GE(touching, 0);
  EXPECT_GT(csv.rows[0][active], 0);
  EXPECT_EQ(csv.rows.back()[touching], 0);
}

TEST(CliExe, UnstableRunStopsWithExitThreeAndAValidCsv) {
  TempDir tmp("unstable");
  const fs::path out = tmp.path / "unstable";
  const Outcome o =
      run_fdem("run " + quote((kData / "cli" / "unstable_box.yaml").string()) + " -o " + quote(out.string()));
  EXPECT_EQ(o.code, 3) << o.text;
  EXPECT_TRUE(has(o.text, "time_step_safety")) << o.text;
  EXPECT_TRUE(has(o.text, "unstable")) << o.text;
  ASSERT_TRUE(fs::exists(out / "monitors.csv")) << o.text;
  const Csv csv = read_csv(out / "monitors.csv");
  EXPECT_EQ(column(csv, "axial_stress_Pa"), 3);
  EXPECT_GE(csv.rows.size(), 2u);
  EXPECT_TRUE(csv.bad.empty()) << "non-finite cell before the stop: " << csv.bad.front();
  for (const auto& r : csv.rows) EXPECT_EQ(r.size(), csv.header.size());
  const std::string raw = slurp(out / "monitors.csv");
  EXPECT_FALSE(has(raw, "nan"));
  EXPECT_FALSE(has(raw, "inf"));
  // It stopped long before the 200000 steps asked for.
  EXPECT_LT(csv.rows.back()[0], 1000);
  // A last ParaView frame marked as such, showing where it went wrong, with nothing non-finite.
  const std::string xdmf = slurp(out / "fields.xdmf");
  EXPECT_TRUE(has(xdmf, "diagnostic")) << xdmf.substr(0, 2000);
  EXPECT_TRUE(has(xdmf, "\"inverted\"")) << "the diagnostic frame marks the inverted tets";
  EXPECT_TRUE(has(xdmf, "\"non_finite\""));
  EXPECT_FALSE(has(xdmf, "nan"));
  // The same step given as solver.time_step: the fix names that key, not time_step_safety
  // (which it overrides).
  const fs::path given = cli_test::scene_variant(kData / "cli" / "unstable_box.yaml", tmp.path, "given",
                                                 {{"time_step_safety: 4.0", "time_step: 1.0e-7"}});
  const Outcome g = run_fdem("run " + quote(given.string()) + " -q -o " + quote((tmp.path / "given").string()));
  EXPECT_EQ(g.code, 3) << g.text;
  EXPECT_TRUE(has(g.text, "Fix: lower solver.time_step (now 1e-07 s, 3.99 x the stable-step bound)")) << g.text;
  EXPECT_FALSE(has(g.text, "time_step_safety (now")) << g.text;
}

TEST(CliExe, AFreshRunThatCannotReplaceTheOutputsChangesNothingAndOneThatStartsDropsTheStaleOnes) {
  TempDir tmp("replace");
  const fs::path out = tmp.path / "out";
  const std::string first = "run " + quote((kData / "cli" / "run_box.yaml").string()) + " -q -o " + quote(out.string());
  ASSERT_EQ(run_fdem(first).code, 0);
  ASSERT_TRUE(fs::exists(out / "summary.csv") && fs::exists(out / "broken_ce6.csv"));
  // The field index's place taken by a folder (what a file that cannot be replaced does without
  // root): exit 4 naming it, and the earlier run's files keep every byte (monitors.csv was cut
  // to its header, and fields.h5 emptied, before the field writer failed).
  fs::remove(out / "fields.xdmf");
  fs::create_directory(out / "fields.xdmf");
  std::vector<std::pair<fs::path, std::string>> before;
  for (const char* f : {"monitors.csv", "summary.csv", "broken_ce6.csv", "fields.h5"})
    before.push_back({out / f, slurp(out / f)});
  const Outcome blocked = run_fdem(first);
  EXPECT_EQ(blocked.code, 4) << blocked.text;
  EXPECT_TRUE(has(blocked.text, (out / "fields.xdmf").string() + " is a folder")) << blocked.text;
  EXPECT_TRUE(has(blocked.text, "nothing was changed")) << blocked.text;
  for (const auto& [path, bytes] : before) EXPECT_EQ(slurp(path), bytes) << path;
  // Cleared, a run that stops unstable (exit 3) leaves no summary or broken-CE6 list of the
  // earlier run beside its own monitors.
  fs::remove(out / "fields.xdmf");
  const Outcome unstable =
      run_fdem("run " + quote((kData / "cli" / "unstable_box.yaml").string()) + " -q -o " + quote(out.string()));
  EXPECT_EQ(unstable.code, 3) << unstable.text;
  EXPECT_FALSE(fs::exists(out / "summary.csv"));
  EXPECT_FALSE(fs::exists(out / "broken_ce6.csv"));
  EXPECT_NE(slurp(out / "monitors.csv"), before[0].second);
}

TEST(CliExe, RunsUnderMpiexecWithOneRank) {
  const std::string mpiexec = find_mpiexec();
  if (mpiexec.empty()) GTEST_SKIP() << "mpiexec not found";
  TempDir tmp("mpi");
  const fs::path out = tmp.path / "mpi1";
  const std::string scene = quote((kData / "cli" / "run_box.yaml").string());
  const Outcome one = run_cmd(kMpiEnv + kEnv + quote(mpiexec) + " -n 1 " + quote(kExe) + " run " + scene + " -o " +
                              quote(out.string()));
  ASSERT_EQ(one.code, 0) << one.text;
  EXPECT_TRUE(fs::exists(out / "monitors.csv"));
  EXPECT_TRUE(fs::exists(out / "fields.h5"));
  EXPECT_EQ(read_csv(out / "monitors.csv").rows.size(), 17u);

  // Several ranks: tests/mpi/test_cli_ranks.cpp.
}

TEST(CliExe, SeriesRunsEveryValueOnceAndTabulatesThem) {
  TempDir tmp("series");
  const fs::path out = tmp.path / "study";
  // A name with a comma and a quote (a lab's "Berea, dry"): one field of summary.csv and series.csv.
  const std::string name = "Berea, dry \"B\"";
  const std::string scene = quote(cli_test::scene_variant(kData / "cli" / "run_box.yaml", tmp.path, "named",
                                                          {{"name: cli_run_box", "name: \"Berea, dry \\\"B\\\"\""}})
                                      .string());
  const std::string args = "series " + scene + " --vary mass_scaling=10,40 -q -o " + quote(out.string());
  const Outcome o = run_fdem(args);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "[2/2] mass_scaling_40: running")) << o.text;
  const Csv csv = read_csv(out / "series.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.header[0], "mass_scaling");
  EXPECT_EQ(csv.rows[0][0], 10);
  EXPECT_EQ(csv.rows[1][0], 40);
  const int steps = column(csv, "steps"), time = column(csv, "time_s");
  ASSERT_GE(steps, 0);
  ASSERT_GE(time, 0);
  EXPECT_EQ(csv.rows[0][steps], 400);
  EXPECT_EQ(csv.rows[1][steps], 400);
  // The stable step grows with sqrt(m): 400 steps cover twice the time at m = 40.
  EXPECT_NEAR(csv.rows[1][time] / csv.rows[0][time], 2.0, 0.02);
  for (const char* f : {"mass_scaling_10/summary.csv", "mass_scaling_40/monitors.csv", "mass_scaling_40/run.txt"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  EXPECT_EQ(fdem::read_summary((out / "mass_scaling_10" / "summary.csv").string()).at("name"),
            name + " mass_scaling_10");
  EXPECT_EQ(fdem::read_summary((out / "mass_scaling_40" / "summary.csv").string()).at("end_reason"),
            "step count 400 reached");
  EXPECT_EQ(csv.rows[1].size(), csv.header.size());
  // Again: both found finished, the table unchanged.
  const std::string before = slurp(out / "series.csv");
  const Outcome again = run_fdem(args);
  ASSERT_EQ(again.code, 0) << again.text;
  EXPECT_TRUE(has(again.text, "[1/2] mass_scaling_10: finished before, not run again")) << again.text;
  EXPECT_TRUE(has(again.text, "[2/2] mass_scaling_40: finished before, not run again")) << again.text;
  EXPECT_EQ(slurp(out / "series.csv"), before);
}

TEST(CliExe, SeriesBadValuesExitTwoBeforeAnyRun) {
  TempDir tmp("series_bad");
  const std::string scene = quote((kData / "cli" / "run_box.yaml").string());
  std::string many = "1";  // 1001 mass scalings: with 10 safety factors, 10010 runs
  for (int m = 2; m <= 1001; ++m) many += "," + std::to_string(m);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"triaxial " + scene + " --sigma3 0,5", "below 1 kPa"},
      {"series " + scene + " --vary frob=1,2", "unknown key 'frob'"},
      {"series " + scene + " --vary diameter=0.05", "needs a generated cylinder or disc"},
      {"series " + scene + " --vary mass_scaling=5,x", "mass_scaling=x: not a number"},
      {"series " + scene + " --vary mass_scaling=0.5", "mass scaling must be >= 1"},
      {"series " + scene + " --vary platen_speed=0", "platen_velocity=0: the platen speed must be > 0 m/s"},
      {"series " + scene + " --vary activation=some", "allowed: adaptive, full, none"},
      {"series " + scene + " --vary mass_scaling=1e7", "mass_scaling=1e7: mass scaling must be >= 1 and at most"},
      {"series " + scene + " --vary platen_velocity=1e9", "at most 10 m/s"},
      {"triaxial " + scene + " --sigma3 1e11", "sigma3=1e11: the confining pressure must be in [0, "},
      {"series " + scene + " --vary mass_scaling=5 --vary mass_scaling=10", "--vary mass_scaling is given twice"},
      // The same value spelled twice ran twice, and counted twice in triaxial's Mohr-Coulomb fit.
      {"series " + scene + " --vary mass_scaling=10,1e1", "value 1e1 is given twice (as 10)"},
      {"triaxial " + scene + " --sigma3 1e6,1000000", "value 1000000 is given twice (as 1e6)"},
      {"series " + scene + " --vary mass_scaling=10,", "an empty value after the last comma"},
      {"series " + scene + " --vary mass_scaling=0x10", "mass_scaling=0x10: not a number"},
      {"series " + scene + " --vary mass_scaling=" + many +
           " --vary time_step_safety=0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9,1",
       "--vary: 1e+04 combinations, each a whole run; at most 10000"},
      {"run " + scene + " -t 65536", "--threads: Value 65536 not in range 0 to 1024"},
      {"run " + scene + " --contact-reach nan", "--contact-reach: Value nan is not a finite length > 0 (m)"},
      {"series " + scene + " -t 1025 --vary mass_scaling=5", "Value 1025 not in range 0 to 1024"},
      {"study " + scene + " --vary precision=fp64,fp32", "double precision only"},
      {"study " + scene + " --vary sigma3=0,1e6", "sigma3 has no most exact value"},
      {"study " + scene + " --vary mass_scaling=1,5 --budget speed=2", "should be metric=limit"},
      // 2 read as 200 %, the second limit silently winning, and 2%% taken.
      {"study " + scene + " --vary mass_scaling=1,5 --budget peak=2", "'peak=2' is 200 % (limits are fractions)"},
      {"study " + scene + " --vary mass_scaling=1,5 --budget peak=2%,peak=3%", "peak is given twice"},
      {"study " + scene + " --vary mass_scaling=1,5 --budget peak=2%%", "needs a limit >= 0"},
  };
  int i = 0;
  for (const auto& [args, msg] : cases) {
    const fs::path out = tmp.path / ("o" + std::to_string(i++));
    const Outcome o = run_fdem(args + " -q -o " + quote(out.string()));
    EXPECT_EQ(o.code, 2) << args << "\n" << o.text;
    EXPECT_TRUE(has(o.text, msg)) << args << "\n" << o.text;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
  // -o naming a file: exit 2 naming it (it was exit 4, "cannot write .../run.txt.tmp").
  std::ofstream(tmp.path / "a_file") << "keep";
  const Outcome f =
      run_fdem("series " + scene + " --vary mass_scaling=5 -q -o " + quote((tmp.path / "a_file").string()));
  EXPECT_EQ(f.code, 2) << f.text;
  EXPECT_TRUE(has(f.text, "cannot create the folder for the runs")) << f.text;
  EXPECT_EQ(slurp(tmp.path / "a_file"), "keep");
}

TEST(CliExe, CheckNamesASliverThatSetsTheTimeStep) {
  const Outcome o = run_fdem("check " + quote((kData / "cli" / "sliver.yaml").string()));
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "warning: tet 2 of ")) << o.text;
  EXPECT_TRUE(has(o.text, "sliver_v22.msh is a sliver (altitude 1.73e-10 m, 1.5e-08 of the mean edge)")) << o.text;
  // A gmsh box: no warning.
  const Outcome box = run_fdem("check " + quote((kData / "cli" / "run_box.yaml").string()));
  EXPECT_EQ(box.code, 0) << box.text;
  EXPECT_FALSE(has(box.text, "sliver")) << box.text;
}

TEST(CliExe, OpenMpThreadsFromTheEnvironmentHaveTheSameLimitAsTheOption) {
  // libgomp crashed (exit 139, no output) at OMP_NUM_THREADS=100000.
  const Outcome o =
      run_cmd("OMP_NUM_THREADS=100000 " + quote(kExe) + " check " + quote((kData / "cli" / "run_box.yaml").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "OMP_NUM_THREADS=100000: more than 1024 OpenMP threads")) << o.text;
}

TEST(CliExe, SeriesKnowsAFinishedRunByItsSceneTextAndMeshBytesNotThePathAsTyped) {
  TempDir tmp("series_fingerprint");
  fs::copy_file(kData / "meshes" / "cube6_v22.msh", tmp.path / "cube.msh");
  std::ofstream(tmp.path / "s.yaml") << "name: fp\nmesh: {file: cube.msh, scale: 0.01}\n"
                                        "solver: {end: {steps: 20}}\noutput: {progress_interval: 0, plot: false}\n";
  const std::string out = " -q -o " + quote((tmp.path / "series").string());
  const std::string vary = " --vary mass_scaling=1";
  Outcome o = run_fdem("series " + quote((tmp.path / "s.yaml").string()) + vary + out);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "[1/1] mass_scaling_1: running in")) << o.text;
  // The same scene by another spelling of its path: finished (it reran, dropping checkpoints).
  o = run_fdem("series " + quote((tmp.path / "." / "s.yaml").string()) + vary + out);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "finished before, not run again")) << o.text;
  // The mesh file edited (a corner moved), the scene's text the same: run again (it reported the
  // old mesh's results as finished).
  std::string mesh = slurp(tmp.path / "cube.msh");
  const std::size_t at = mesh.find("\n80 1.0 1.0 1.0\n");
  ASSERT_NE(at, std::string::npos);
  mesh.replace(at, 16, "\n80 1.0 1.0 1.2\n");
  std::ofstream(tmp.path / "cube.msh") << mesh;
  o = run_fdem("series " + quote((tmp.path / "s.yaml").string()) + vary + out);
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "[1/1] mass_scaling_1: running in")) << o.text;
}

TEST(CliExe, ASeriesVariantWhoseFixedTimeStepIsBeyondItsBoundIsUnstableNotTheEnd) {
  // solver.time_step fixed at 1e-6 s: about 0.65 x the stable-step bound at m = 1000, 20 x at
  // m = 1 (the bound grows with sqrt(m)). The second variant is recorded, not run; the series ends
  // with its table.
  TempDir tmp("series_dt");
  const fs::path scene = cli_test::scene_variant(kData / "cli" / "study_box.yaml", tmp.path, "fixed_dt",
                                                 {{"mass_scaling: 10", "mass_scaling: 10\n  time_step: 1.0e-6"}});
  const fs::path out = tmp.path / "series";
  const Outcome o =
      run_fdem("series " + quote(scene.string()) + " --vary mass_scaling=1000,1 -q -o " + quote(out.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "[2/2] mass_scaling_1: running in")) << o.text;
  EXPECT_TRUE(has(o.text, "not run: ")) << o.text;
  const auto first = fdem::read_summary((out / "mass_scaling_1000" / "summary.csv").string());
  const auto second = fdem::read_summary((out / "mass_scaling_1" / "summary.csv").string());
  EXPECT_EQ(first.at("end_reason"), "axial strain reached");
  EXPECT_EQ(second.at("end_reason").rfind("unstable: not run: ", 0), 0u) << second.at("end_reason");
  EXPECT_TRUE(has(second.at("end_reason"), "x the stable-step bound")) << second.at("end_reason");
  EXPECT_TRUE(fs::exists(out / "series.csv"));
}

TEST(CliExe, StudyMeasuresErrorsAgainstTheReferenceAndResumes) {
  // An elastic column loaded at three time steps: the finest (the default reference: the
  // smallest time_step_safety) has zero error; the coarsest the largest.
  TempDir tmp("study");
  const fs::path out = tmp.path / "study";
  const std::string args = "study " + quote((kData / "cli" / "study_box.yaml").string()) +
                           " --vary time_step_safety=0.9,0.2,0.45 --budget curve_pre=1% -q -o " + quote(out.string());
  const Outcome o = run_fdem(args);
  ASSERT_EQ(o.code, 0) << o.text;
  const Csv csv = read_csv(out / "study.csv");
  ASSERT_EQ(csv.rows.size(), 3u);  // rows in --vary order: 0.9, 0.2, 0.45
  const int ref = column(csv, "reference"), pre = column(csv, "error_curve_pre"), peak = column(csv, "error_peak"),
            jac = column(csv, "error_jaccard"), rec = column(csv, "recommended");
  ASSERT_GE(ref, 0);
  ASSERT_GE(pre, 0);
  ASSERT_GE(jac, 0);
  EXPECT_EQ(csv.rows[1][ref], 1);
  for (std::size_t c = 0; c < csv.header.size(); ++c) {
    if (csv.header[c].rfind("error_", 0) == 0 && csv.header[c] != "error_jaccard") {
      EXPECT_EQ(csv.rows[1][c], 0) << csv.header[c];
    }
  }
  EXPECT_EQ(csv.rows[1][jac], 1);
  EXPECT_GT(csv.rows[2][pre], 0);
  EXPECT_GT(csv.rows[0][pre], csv.rows[2][pre]);  // the coarser step is further off
  EXPECT_GT(csv.rows[0][peak], csv.rows[2][peak]);
  EXPECT_EQ(csv.rows[0][rec] + csv.rows[1][rec] + csv.rows[2][rec], 1);
  EXPECT_TRUE(fs::exists(out / "study.md"));
  EXPECT_TRUE(has(slurp(out / "study.md"), "(reference)"));
  // Again: nothing reruns, the table is the same.
  const std::string before = slurp(out / "study.csv");
  const Outcome again = run_fdem(args);
  ASSERT_EQ(again.code, 0) << again.text;
  EXPECT_FALSE(has(again.text, ": running in")) << again.text;
  EXPECT_EQ(slurp(out / "study.csv"), before);
  // A reference that is not among the variants is bad input.
  const Outcome bad = run_fdem(args + " --reference time_step_safety=0.3");
  EXPECT_EQ(bad.code, 2) << bad.text;
  EXPECT_TRUE(has(bad.text, "--reference names no variant")) << bad.text;
  // A reference that ends before any load (no platens): exit 3 naming it, not a table of NaN errors.
  const fs::path unloaded = cli_test::scene_variant(kData / "cli" / "study_box.yaml", tmp.path, "unloaded",
                                                    {{"platens: {velocity: 0.5, ramp_time: 4e-5}", "platens: none"},
                                                     {"end: {axial_strain: 0.0005}", "end: {steps: 20}"}});
  const fs::path out2 = tmp.path / "unloaded";
  const Outcome none =
      run_fdem("study " + quote(unloaded.string()) + " --vary time_step_safety=0.9,0.45 -q -o " + quote(out2.string()));
  EXPECT_EQ(none.code, 3) << none.text;
  EXPECT_TRUE(has(none.text, "the reference variant (time_step_safety=0.45) reached no peak: peak stress 0 Pa"))
      << none.text;
  EXPECT_FALSE(fs::exists(out2 / "study.csv"));
}

TEST(CliExe, EveryHostileInputFileExitsTwoQuicklyWithItsNameAndWritesNothing) {
  // Every malformed scene in tests/data/bad_scenes and every malformed mesh in
  // tests/data/meshes (bad_*.msh, through a scene that reads it), run by the real executable
  // under a time limit: exit 2 (not a crash, a signal or a hang), an "error" line naming the
  // file, and no output folder.
  TempDir tmp("hostile");
  std::vector<std::pair<fs::path, std::string>> cases;  // scene, file the message must name
  for (const auto& e : fs::directory_iterator(kData / "bad_scenes"))
    if (e.path().extension() == ".yaml") cases.push_back({e.path(), e.path().filename().string()});
  for (const auto& e : fs::directory_iterator(kData / "meshes")) {
    const std::string name = e.path().filename().string();
    if (name.rfind("bad_", 0) != 0) continue;
    const fs::path scene = tmp.path / (e.path().stem().string() + ".yaml");
    std::ofstream(scene) << "name: hostile\nmesh:\n  file: " << e.path().string()
                         << "\nsolver: {end: {steps: 10}}\noutput: {progress_interval: 0, plot: false}\n";
    cases.push_back({scene, name});
  }
  ASSERT_GE(cases.size(), 50u);
  std::sort(cases.begin(), cases.end());
  int i = 0;
  for (const auto& [scene, name] : cases) {
    const fs::path out = tmp.path / ("out" + std::to_string(i++));
    const Outcome o = run_cmd("timeout 60 env " + kEnv + quote(kExe) + " run " + quote(scene.string()) + " -q -o " +
                              quote(out.string()));
    SCOPED_TRACE(scene.string() + "\n" + o.text);
    EXPECT_EQ(o.code, 2);  // 124 would be the time limit, 134/139 a crash
    EXPECT_TRUE(has(o.text, "error")) << o.text;
    EXPECT_TRUE(has(o.text, name)) << "the message should name " << name;
    EXPECT_FALSE(fs::exists(out));
  }
  RecordProperty("hostile_files", std::to_string(cases.size()));
}
