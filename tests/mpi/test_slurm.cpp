// The SLURM scripts in slurm/, run with stand-ins for srun (mpiexec with SLURM_NTASKS ranks)
// and sbatch (records its arguments): a two-rank job writes its results; a job stopped at the
// time limit (TERM) resubmits itself, and the resubmitted job continues from the checkpoints
// to the same files as an uninterrupted run; a triaxial job array and its fit job.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "cli_support.hpp"

using namespace cli_test;

namespace {

const fs::path kSlurm = fs::path(FDEM_SOURCE_DIR) / "slurm";

/// A bin folder with srun and sbatch stand-ins, and the environment a job would see.
struct FakeSlurm {
  TempDir tmp{"slurm"};
  fs::path bin = tmp.path / "bin";
  FakeSlurm() {
    fs::create_directories(bin);
    const std::string mpi = find_mpiexec();
    std::ofstream(bin / "srun") << "#!/bin/bash\nwhile [[ $1 == --* ]]; do shift; done\nexec " << quote(mpi)
                                << " -n \"$SLURM_NTASKS\" \"$@\"\n";
    std::ofstream(bin / "sbatch") << "#!/bin/bash\necho \"$@\" >> " << quote((tmp.path / "sbatch.txt").string())
                                  << "\n";
    fs::permissions(bin / "srun", fs::perms::owner_all);
    fs::permissions(bin / "sbatch", fs::perms::owner_all);
  }
  std::string env(int ranks) const {
    return kMpiEnv + kEnv + "PATH=" + quote(bin.string()) + ":$PATH FDEM=" + quote(kExe) +
           " SLURM_NTASKS=" + std::to_string(ranks) + " SLURM_CPUS_PER_TASK=1 SLURM_JOB_NUM_NODES=1 ";
  }
};

}  // namespace

TEST(Slurm, RunScriptStopsAtTheLimitResubmitsAndContinues) {
  if (find_mpiexec().empty()) GTEST_SKIP() << "mpiexec not found";
  FakeSlurm s;
  const std::string scene = (kData / "cli" / "restart_box.yaml").string();
  const fs::path whole = s.tmp.path / "whole", job = s.tmp.path / "job";
  const std::string script = quote((kSlurm / "run.sbatch").string());
  const Outcome a = run_cmd(s.env(2) + "bash " + script + " " + quote(scene) + " " + quote(whole.string()) + " -q");
  ASSERT_EQ(a.code, 0) << a.text;
  EXPECT_TRUE(fs::exists(whole / "summary.csv") && fs::exists(whole / "fields.h5")) << a.text;

  // The time limit: TERM to the ranks mid-run.
  const std::string log = (s.tmp.path / "job.log").string(), rc = (s.tmp.path / "job.rc").string();
  ASSERT_EQ(std::system(("(" + s.env(2) + "bash " + script + " " + quote(scene) + " " + quote(job.string()) + " > " +
                         quote(log) + " 2>&1; echo $? > " + quote(rc) + ") &")
                            .c_str()),
            0);
  const fs::path mon = job / "monitors.csv";
  for (int i = 0; i < 600 && !(fs::exists(mon) && fs::file_size(mon) > 4000); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::system(("pkill -TERM -f " + quote("^" + kExe + " run " + scene)).c_str());
  for (int i = 0; i < 1200 && !fs::exists(rc); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(fs::exists(rc));
  if (std::stoi(slurp(rc)) == 0) GTEST_SKIP() << "the run finished before the signal";
  EXPECT_EQ(std::stoi(slurp(rc)), 5) << slurp(log);
  const std::string sub = slurp(s.tmp.path / "sbatch.txt");
  EXPECT_TRUE(has(sub, "--ntasks=2") && has(sub, "run.sbatch") && has(sub, job.string())) << sub;
  // A continuation on three ranks instead (a job given other nodes): from a copy of the folder.
  const fs::path three = s.tmp.path / "three";
  fs::copy(job, three, fs::copy_options::recursive);
  const Outcome t = run_cmd(s.env(3) + "bash " + script + " " + quote(scene) + " " + quote(three.string()));
  ASSERT_EQ(t.code, 0) << t.text;
  EXPECT_TRUE(has(t.text, "saved on 2 ranks and taken into 3")) << t.text;
  const Csv w = read_csv(whole / "monitors.csv"), r3 = read_csv(three / "monitors.csv");
  ASSERT_EQ(w.rows.size(), r3.rows.size());
  const int stress = column(w, "axial_stress_Pa");
  for (std::size_t i = 0; i < w.rows.size(); ++i)  // (before and after fracture: the same state)
    EXPECT_NEAR(r3.rows[i][stress], w.rows[i][stress], 1e-6 * std::fabs(w.rows[i][stress]) + 1) << "row " << i;
  // The resubmitted job: the same script again, which finds the checkpoints.
  const Outcome c = run_cmd(s.env(2) + "bash " + script + " " + quote(scene) + " " + quote(job.string()) + " -q");
  ASSERT_EQ(c.code, 0) << c.text;
  EXPECT_TRUE(has(c.text, "continuing from")) << c.text;
  for (const char* f : {"monitors.csv", "broken_ce6.csv", "fields.xdmf"})
    EXPECT_EQ(slurp(whole / f), slurp(job / f)) << f;
}

TEST(Slurm, ResubmissionTakesTheRankCountAskedFor) {
  // fdem stopped at the limit (a stand-in that exits 5 at once): the job submits its
  // continuation with its own ranks and nodes, or with FDEM_NEXT_NTASKS and FDEM_NEXT_NODES
  // (not with --partitioned rank files, made for one count).
  if (find_mpiexec().empty()) GTEST_SKIP() << "mpiexec not found";
  FakeSlurm s;
  const fs::path stub = s.bin / "stopped_fdem";
  std::ofstream(stub) << "#!/bin/bash\nexit 5\n";
  fs::permissions(stub, fs::perms::owner_all);
  const std::string script = quote((kSlurm / "run.sbatch").string()),
                    args = " scene.yaml " + quote(s.tmp.path.string());
  const std::string env = s.env(2) + "FDEM=" + quote(stub.string()) + " FDEM_RESUBMIT=1 ";
  const Outcome same = run_cmd(env + "bash " + script + args);
  EXPECT_EQ(same.code, 5) << same.text;
  const Outcome more = run_cmd(env + "FDEM_NEXT_NTASKS=3 FDEM_NEXT_NODES=2 bash " + script + args);
  EXPECT_EQ(more.code, 5) << more.text;
  // With rank files made for 2 ranks, the continuation keeps 2.
  const Outcome kept = run_cmd(env + "FDEM_NEXT_NTASKS=3 bash " + script + args + " --partitioned parts");
  EXPECT_EQ(kept.code, 5) << kept.text;
  EXPECT_TRUE(has(kept.text, "FDEM_NEXT_NTASKS ignored")) << kept.text;
  std::vector<std::string> jobs;
  std::istringstream lines(slurp(s.tmp.path / "sbatch.txt"));
  for (std::string line; std::getline(lines, line);) jobs.push_back(line);
  ASSERT_EQ(jobs.size(), 3u);
  EXPECT_TRUE(has(jobs[0], "--nodes=1 --ntasks=2 --ntasks-per-node=2")) << jobs[0];
  EXPECT_TRUE(has(jobs[1], "--nodes=2 --ntasks=3 --ntasks-per-node=2")) << jobs[1];
  EXPECT_TRUE(has(jobs[2], "--nodes=1 --ntasks=2 ") && has(jobs[2], "--partitioned parts")) << jobs[2];
}

TEST(Slurm, TriaxialArrayTasksAndTheFitJob) {
  FakeSlurm s;
  const std::string scene = (kData / "cli" / "run_box.yaml").string();
  const fs::path out = s.tmp.path / "triax";
  const std::string script = quote((kSlurm / "triaxial_array.sbatch").string());
  for (int i : {0, 1}) {
    const Outcome a = run_cmd(s.env(1) + "SIGMA3=0,2e6 SLURM_ARRAY_TASK_ID=" + std::to_string(i) + " bash " + script +
                              " " + quote(scene) + " " + quote(out.string()));
    ASSERT_EQ(a.code, 0) << a.text;
  }
  EXPECT_TRUE(fs::exists(out / "sigma3_0" / "summary.csv"));
  EXPECT_TRUE(fs::exists(out / "sigma3_2e6" / "summary.csv"));
  const Outcome f =
      run_cmd(s.env(1) + "SIGMA3=0,2e6 bash " + script + " " + quote(scene) + " " + quote(out.string()) + " fit");
  ASSERT_EQ(f.code, 0) << f.text;
  EXPECT_FALSE(has(f.text, "running in")) << "the fit job reran a finished pressure: " << f.text;
  EXPECT_EQ(read_csv(out / "series.csv").rows.size(), 2u);
  // An index past the list is refused.
  const Outcome bad = run_cmd(s.env(1) + "SIGMA3=0,2e6 SLURM_ARRAY_TASK_ID=2 bash " + script + " " + quote(scene) +
                              " " + quote(out.string()));
  EXPECT_EQ(bad.code, 2) << bad.text;
}
