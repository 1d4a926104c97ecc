// The fdem command line end to end: help, check, run outputs, bad input (exit 2, message
// naming the file and the key, nothing written), an unstable run (exit 3), MPI launch.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace fs = std::filesystem;

namespace {

const std::string exe = FDEM_EXE;
const std::string data = std::string(FDEM_TEST_DATA);

struct Result {
  int code;
  std::string out;
};

Result sh(const std::string& cmd) {
  Result r{-1, ""};
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return r;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, p)) r.out += buf;
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

fs::path temp_dir(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("fdem_cli_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  return d;
}

bool contains(const std::string& s, const std::string& what) {
  return s.find(what) != std::string::npos;
}

}  // namespace

TEST(Cli, HelpVersionAndUnknownOptions) {
  Result r = sh(exe + " --help");
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(contains(r.out, "run") && contains(r.out, "check")) << r.out;
  r = sh(exe + " --version");
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(contains(r.out, "fdem ")) << r.out;
  EXPECT_NE(sh(exe + " frobnicate").code, 0);
  EXPECT_NE(sh(exe + " run --no-such-option x.yaml").code, 0);
}

TEST(Cli, CheckReportsCountsAndTheStableStep) {
  const Result r = sh(exe + " check " + data + "/cli/tiny_box.yaml");
  EXPECT_EQ(r.code, 0) << r.out;
  EXPECT_TRUE(contains(r.out, "tets ") && contains(r.out, "CE6 ") && contains(r.out, "stable step")) << r.out;
  EXPECT_TRUE(contains(r.out, "minimum altitude")) << r.out;
}

TEST(Cli, RunWritesCurvesAndParaViewFiles) {
  const fs::path out = temp_dir("run");
  const Result r = sh(exe + " run -q " + data + "/cli/tiny_box.yaml -o " + out.string());
  ASSERT_EQ(r.code, 0) << r.out;
  std::ifstream csv(out / "monitors.csv");
  std::string header, line;
  ASSERT_TRUE(std::getline(csv, header));
  EXPECT_EQ(header.rfind("step,time_s,axial_strain,axial_stress_Pa", 0), 0u) << header;
  int rows = 0;
  double last_stress = -1, first_stress = 0;
  while (std::getline(csv, line)) {
    std::stringstream ss(line);
    std::string cell;
    int col = 0;
    while (std::getline(ss, cell, ',')) {
      const double v = std::stod(cell);
      ASSERT_TRUE(std::isfinite(v)) << line;
      if (col == 3) last_stress = v;
      ++col;
    }
    if (rows == 0) first_stress = last_stress;
    ++rows;
  }
  EXPECT_EQ(rows, 400 / 20 + 1);  // initial row + one per monitor interval
  EXPECT_GT(last_stress, first_stress);
  EXPECT_GT(fs::file_size(out / "fields.h5"), 0u);
  std::ifstream xdmf(out / "fields.xdmf");
  const std::string x((std::istreambuf_iterator<char>(xdmf)), {});
  EXPECT_TRUE(contains(x, "Name=\"rock\"") && contains(x, "</Xdmf>")) << x.substr(0, 200);
  fs::remove_all(out);
}

TEST(Cli, BadInputExitsTwoNamingFileAndKeyAndWritesNothing) {
  struct Case {
    std::string scene, expect;
  } cases[] = {
      {data + "/bad_scenes/negative_modulus.yaml", "material.youngs_modulus"},
      {data + "/bad_scenes/missing_mesh.yaml", "mesh"},
      {data + "/no_such_scene.yaml", "no_such_scene.yaml"},
      {data + "/cli/degenerate_mesh.yaml", "zero or near-zero volume"},
      {data + "/cli/garbage_mesh.yaml", "bad_garbage.msh"},
      {data + "/cli/folded_mesh.yaml", "overlapping"},  // a tet folded over its neighbour
  };
  for (const Case& c : cases) {
    const fs::path out = temp_dir("bad");
    const Result r = sh(exe + " run -q " + c.scene + " -o " + out.string());
    EXPECT_EQ(r.code, 2) << c.scene << "\n" << r.out;
    EXPECT_TRUE(contains(r.out, c.expect)) << r.out;
    EXPECT_FALSE(fs::exists(out)) << "output written for a bad scene " << c.scene;
  }
  // Messages about scene keys name the scene file too.
  EXPECT_TRUE(contains(sh(exe + " check " + data + "/bad_scenes/negative_modulus.yaml").out, "negative_modulus.yaml"));
  // Tets listed with the opposite orientation are fine: they are re-oriented.
  EXPECT_EQ(sh(exe + " check " + data + "/cli/inverted_mesh.yaml").code, 0);
}

TEST(Cli, UnstableRunExitsThreeWithTheFixAndCleanCsv) {
  const fs::path out = temp_dir("unstable");
  const Result r = sh(exe + " run -q " + data + "/cli/unstable.yaml -o " + out.string());
  EXPECT_EQ(r.code, 3) << r.out;
  EXPECT_TRUE(contains(r.out, "time_step_safety")) << r.out;
  std::ifstream csv(out / "monitors.csv");
  const std::string all((std::istreambuf_iterator<char>(csv)), {});
  EXPECT_FALSE(all.empty());
  EXPECT_FALSE(contains(all, "nan") || contains(all, "inf")) << all.substr(0, 400);
  fs::remove_all(out);
}

TEST(Cli, RunsAsOneMpiRankAndRefusesTwo) {
  if (sh("command -v mpiexec").code != 0) GTEST_SKIP() << "mpiexec not found";
  const std::string mpi = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 mpiexec --oversubscribe ";
  Result r = sh(mpi + "-n 1 " + exe + " check " + data + "/cli/tiny_box.yaml");
  EXPECT_EQ(r.code, 0) << r.out;
  r = sh(mpi + "-n 2 " + exe + " check " + data + "/cli/tiny_box.yaml");
  EXPECT_NE(r.code, 0);
  EXPECT_TRUE(contains(r.out, "one MPI rank")) << r.out;
}
