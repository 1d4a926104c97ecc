// Checkpoint and restart through the real executable: a run continued from a checkpoint (taken
// every N steps, by wall time, or on SIGTERM) writes the same files as an uninterrupted run,
// bit for bit (monitors.csv, broken_ce6.csv, the XDMF index and every dataset of every frame in
// fields.h5); a damaged newest checkpoint falls back to the one before; a checkpoint of another
// scene, or one already past the scene's end, is refused with exit 2; an interrupted `fdem
// series` continues its run from its checkpoint; a checkpoint that cannot be written is a
// warning, not the end of the run. A second run into a folder in use is refused, and a killed
// run's folder is taken over by its restart.
#include <unistd.h>

#include <ctime>
#include <fstream>
#include <regex>

#include "backend_support.hpp"
#include "cli_support.hpp"

namespace fs = std::filesystem;
using namespace cli_test;

namespace {

const fs::path kScene = kData / "cli" / "restart_box.yaml";

fs::path scene_variant(const fs::path& dir, const std::string& name,
                       const std::vector<std::pair<std::string, std::string>>& edits) {
  return cli_test::scene_variant(kScene, dir, name, edits);
}

/// The restart scene ending after `steps` with a checkpoint every `every` steps, plus edits.
fs::path checkpointed(const fs::path& dir, const std::string& name, int steps, int every,
                      std::vector<std::pair<std::string, std::string>> edits = {}) {
  edits.insert(edits.begin(), {{"end: {steps: 3000}", "end: {steps: " + std::to_string(steps) + "}"},
                               {"checkpoint_wall_interval: 0", "checkpoint_interval: " + std::to_string(every)}});
  return scene_variant(dir, name, edits);
}

std::string run_args(const fs::path& scene, const fs::path& out) {
  return "run " + quote(scene.string()) + " -o " + quote(out.string());
}

std::string attribute_text(hid_t group, const char* name) {
  if (H5Aexists(group, name) <= 0) return "";
  const hid_t a = H5Aopen(group, name, H5P_DEFAULT);
  const hid_t type = H5Aget_type(a);
  std::string out(H5Tget_size(type), '\0');
  H5Aread(a, type, out.data());
  H5Tclose(type);
  H5Aclose(a);
  return out;
}

/// Every frame of two fields.h5 files: the same groups, attributes and dataset bytes. Returns
/// "" or the first difference.
std::string compare_fields(const fs::path& a, const fs::path& b) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const hid_t fa = H5Fopen(a.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t fb = H5Fopen(b.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  std::string diff;
  if (fa < 0 || fb < 0) diff = "cannot open " + a.string() + " or " + b.string();
  int frames = 0;
  for (int i = 0; diff.empty(); ++i) {
    char g[32];
    std::snprintf(g, sizeof g, "/frame_%06d", i);
    const bool in_a = H5Lexists(fa, g + 1, H5P_DEFAULT) > 0, in_b = H5Lexists(fb, g + 1, H5P_DEFAULT) > 0;
    if (in_a != in_b) diff = std::string(g) + " exists in one file only";
    if (!in_a || !in_b) break;
    ++frames;
    const hid_t ga = H5Gopen2(fa, g, H5P_DEFAULT), gb = H5Gopen2(fb, g, H5P_DEFAULT);
    for (const char* attr : {"time", "step", "label"})
      if (attribute_text(ga, attr) != attribute_text(gb, attr)) diff = std::string(g) + " attribute " + attr;
    H5Gclose(ga);
    H5Gclose(gb);
    for (const char* d : {"x", "u", "v", "stress", "von_mises", "crack_faces", "crack_damage", "crack_mode", "active"})
      if (diff.empty() && dataset_bytes(fa, std::string(g) + "/" + d) != dataset_bytes(fb, std::string(g) + "/" + d))
        diff = std::string(g) + "/" + d + " differs";
  }
  if (diff.empty() && frames < 5) diff = "only " + std::to_string(frames) + " frames";
  if (fa >= 0) H5Fclose(fa);
  if (fb >= 0) H5Fclose(fb);
  return diff;
}

/// summary.csv without its wall-time column.
std::string summary_without_wall(const fs::path& folder) {
  const Csv c = read_csv(folder / "summary.csv");
  const int wall = column(c, "wall_s");
  std::string out;
  for (const auto& row : c.rows)
    for (std::size_t i = 0; i < row.size(); ++i)
      if (int(i) != wall) out += std::to_string(row[i]) + ",";
  return out;
}

/// "" if two text files are equal, else the first line that differs in each.
std::string first_difference(const fs::path& a, const fs::path& b) {
  std::ifstream fa(a), fb(b);
  std::string la, lb;
  for (int line = 1;; ++line) {
    const bool ga = bool(std::getline(fa, la)), gb = bool(std::getline(fb, lb));
    if (!ga && !gb) return "";
    if (ga != gb || la != lb)
      return a.filename().string() + " line " + std::to_string(line) + ":\n  " + (ga ? la : "(end)") + "\n  " +
             (gb ? lb : "(end)");
  }
}

void expect_same_run(const fs::path& a, const fs::path& b) {
  ASSERT_TRUE(fs::exists(b / "summary.csv")) << b;
  for (const char* file : {"monitors.csv", "broken_ce6.csv", "fields.xdmf"}) {
    EXPECT_TRUE(fs::exists(a / file)) << file;
    EXPECT_EQ(first_difference(a / file, b / file), "");
  }
  EXPECT_EQ(compare_fields(a / "fields.h5", b / "fields.h5"), "");
  EXPECT_EQ(summary_without_wall(a), summary_without_wall(b));
}

std::vector<std::string> checkpoint_names(const fs::path& folder) {
  std::vector<std::string> names;
  if (fs::is_directory(folder / "checkpoints"))
    for (const auto& e : fs::directory_iterator(folder / "checkpoints")) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

/// The uninterrupted reference run, made once for all tests of this file.
const fs::path& reference_run() {
  static TempDir dir("restart_reference");
  static const fs::path out = dir.path / "a";
  static bool done = false;
  if (!done) {
    const Outcome o = run_fdem(run_args(kScene, out));
    EXPECT_EQ(o.code, 0) << o.text;
    done = true;
    // The run fractures and the peak frames exist: the restart must carry all of that state.
    const Csv c = read_csv(out / "monitors.csv");
    EXPECT_GT(c.rows.back()[column(c, "broken_ce6")], 30);
    EXPECT_GT(c.rows.back()[column(c, "contact_pairs")], 100);
    EXPECT_TRUE(has(slurp(out / "fields.xdmf"), "post-peak"));
    EXPECT_TRUE(checkpoint_names(out).empty());
  }
  return out;
}

}  // namespace

TEST(Restart, FromAStepCheckpointBeforeThePeakEqualsTheUninterruptedRun) {
  const fs::path& a = reference_run();
  TempDir tmp("restart_steps");
  // A first run of 1000 steps checkpointing every 500: one checkpoint, at step 500 (none at the end).
  const fs::path first = checkpointed(tmp.path, "first", 1000, 500);
  const fs::path b = tmp.path / "b";
  Outcome o = run_fdem(run_args(first, b));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "checkpoint (every 500 steps)")) << o.text;
  ASSERT_EQ(checkpoint_names(b), std::vector<std::string>{"step_000000000500.ckpt"});
  // Continued to the reference's 3000 steps (solver.end may change on a restart).
  o = run_fdem(run_args(kScene, b) + " --restart " + quote((b / "checkpoints" / "step_000000000500.ckpt").string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "restart: continuing from")) << o.text;
  expect_same_run(a, b);
}

TEST(Restart, UnderTheScheduleThatStepsInTheFusedPassEqualsTheUninterruptedRun) {
  // FDEM_DEVICE_SCHEDULE=auto on the cpu backend: the fused pass integrates and reads the contact
  // gather list's places per node. A restart loads another list into the contact set, whose
  // vectors the loop works on in place: the places of the list the new process built first must
  // all go, or the fused pass adds contact forces at nodes no pair touches.
  const fdem::test::EnvSetting schedule("FDEM_DEVICE_SCHEDULE", "auto");  // (unset again, whatever fails)
  TempDir tmp("restart_auto");
  const fs::path a = tmp.path / "a", b = tmp.path / "b";
  Outcome o = run_fdem(run_args(kScene, a));
  ASSERT_EQ(o.code, 0) << o.text;
  o = run_fdem(run_args(checkpointed(tmp.path, "first", 1000, 500), b));
  ASSERT_EQ(o.code, 0) << o.text;
  o = run_fdem(run_args(kScene, b) + " --restart " + quote((b / "checkpoints" / "step_000000000500.ckpt").string()));
  ASSERT_EQ(o.code, 0) << o.text;
  expect_same_run(a, b);
}

TEST(Restart, AfterSigtermWithADamagedNewestCheckpointEqualsTheUninterruptedRun) {
  const fs::path& a = reference_run();
  TempDir tmp("restart_signal");
  const fs::path scene =
      scene_variant(tmp.path, "wall", {{"checkpoint_wall_interval: 0", "checkpoint_wall_interval: 0.1"}});
  const fs::path c = tmp.path / "c";
  // Started in the background, stopped with SIGTERM once 25 monitor rows (step 1200) and two
  // wall-time checkpoints are written.
  const std::string script = kEnv + quote(kExe) + " " + run_args(scene, c) + " & pid=$!; for i in $(seq 1500); do " +
                             "[ \"$(cat " + quote((c / "monitors.csv").string()) +
                             " 2>/dev/null | wc -l)\" -ge 26 ] && [ \"$(ls " + quote((c / "checkpoints").string()) +
                             " 2>/dev/null | grep -c 'ckpt$')\" -ge 2 ] && break; sleep 0.02; done; kill -TERM $pid; "
                             "wait $pid";
  Outcome o = run_cmd("bash -c " + quote(script));
  ASSERT_EQ(o.code, 5) << o.text;
  EXPECT_TRUE(has(o.text, "checkpoint (signal)")) << o.text;
  EXPECT_TRUE(has(o.text, "--restart")) << o.text;
  EXPECT_FALSE(fs::exists(c / "summary.csv"));
  const std::vector<std::string> names = checkpoint_names(c);
  ASSERT_EQ(names.size(), 2u) << "the last two are kept\n" << o.text;
  for (const std::string& n : names) EXPECT_TRUE(std::regex_match(n, std::regex("step_[0-9]{12}\\.ckpt"))) << n;
  // Damage the newest: its checksum no longer matches, and the restart takes the one before.
  {
    const fs::path newest = c / "checkpoints" / names.back();
    std::fstream f(newest, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(-5, std::ios::end);
    f.put('\x7f');
  }
  o = run_fdem(run_args(scene, c) + " --restart " + quote(c.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "checksum mismatch")) << o.text;
  EXPECT_TRUE(has(o.text, "continuing from " + (c / "checkpoints" / names.front()).string())) << o.text;
  expect_same_run(a, c);
}

TEST(Restart, ACheckpointOfAnotherSceneOrNoneIsRefusedWithExitTwo) {
  TempDir tmp("restart_refused");
  const fs::path scene = checkpointed(tmp.path, "short", 120, 100);
  const fs::path d = tmp.path / "d";
  ASSERT_EQ(run_fdem(run_args(scene, d)).code, 0);
  ASSERT_EQ(checkpoint_names(d).size(), 1u);
  const std::string before = slurp(d / "monitors.csv");
  // Another loading rate: refused, and the folder is left as it was.
  const fs::path faster = checkpointed(tmp.path, "faster", 120, 100, {{"velocity: 1.0", "velocity: 1.5"}});
  Outcome o = run_fdem(run_args(faster, d) + " --restart " + quote(d.string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "step_000000000100.ckpt")) << o.text;
  EXPECT_TRUE(has(o.text, "another model or scene")) << o.text;
  EXPECT_EQ(slurp(d / "monitors.csv"), before);
  // The same scene with its end moved before the checkpoint: refused, the rows after it kept (the
  // run used to drop them, take one step and stop).
  const fs::path shorter = checkpointed(tmp.path, "shorter", 80, 100);
  o = run_fdem(run_args(shorter, d) + " --restart " + quote(d.string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "is at step 100, t = ")) << o.text;
  EXPECT_TRUE(has(o.text, "the scene's end is already reached (step count 80 reached); nothing was changed")) << o.text;
  EXPECT_EQ(slurp(d / "monitors.csv"), before);
  EXPECT_EQ(checkpoint_names(d).size(), 1u);
  // A folder without checkpoints; the output folder named is not created.
  o = run_fdem(run_args(scene, tmp.path / "e") + " --restart " + quote(tmp.path.string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "no checkpoint there")) << o.text;
  EXPECT_FALSE(fs::exists(tmp.path / "e"));
}

TEST(Restart, ACheckpointThatCannotBeOpenedStopsItAndIsKept) {
  // The newest checkpoint unreadable (permissions: a shared folder, another user's umask): the
  // restart fell back to the one before and removed the newest with the rows after the older.
  TempDir tmp("restart_unreadable");
  const fs::path scene = checkpointed(tmp.path, "every100", 250, 100);
  const fs::path d = tmp.path / "d";
  ASSERT_EQ(run_fdem(run_args(scene, d)).code, 0);
  ASSERT_EQ(checkpoint_names(d), (std::vector<std::string>{"step_000000000100.ckpt", "step_000000000200.ckpt"}));
  const std::string before = slurp(d / "monitors.csv");
  // Root reads any file: run fdem as nobody then, in a tree nobody may write.
  const std::string as = geteuid() == 0 ? "setpriv --reuid=65534 --regid=65534 --clear-groups " : "";
  if (!as.empty()) {
    ASSERT_EQ(run_cmd("chmod -R a+rwX " + quote(tmp.path.string())).code, 0);
  }
  fs::permissions(d / "checkpoints" / "step_000000000200.ckpt", fs::perms::none);
  const Outcome o = run_cmd(kEnv + as + quote(kExe) + " " + run_args(scene, d) + " --restart " + quote(d.string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "step_000000000200.ckpt: cannot open the checkpoint (Permission denied)")) << o.text;
  EXPECT_TRUE(has(o.text, "nothing was changed")) << o.text;
  EXPECT_EQ(checkpoint_names(d).size(), 2u);
  EXPECT_EQ(slurp(d / "monitors.csv"), before);
}

TEST(Restart, ADiskThatFillsWhileAFrameIsWrittenEndsWithExitFourAndTheRestartKeepsTheFrames) {
  // A 44 kB file system (40 kB and a page for the run's lock file) fills while a ParaView frame
  // is written: HDF5's shutdown crashed on the file it could not close (exit 139), and every
  // restart failed to remove the frame cut short. Now exit 4, naming the disk as full, and the
  // restart (with room again) copies the frames the checkpoint holds into a new fields.h5 and
  // ends as the uninterrupted run does, bit for bit.
  TempDir tmp("restart_disk_full");
  const fs::path scene = tmp.path / "tiny.yaml", small = tmp.path / "small";
  std::ofstream(scene) << "name: tiny\nmesh: {file: " << (kData / "meshes" / "cube6_v22.msh").string()
                       << ", scale: 0.01}\nsolver: {end: {steps: 200}, threads: 1}\noutput: {progress_interval: 0, "
                          "plot: false, checkpoint_interval: 20, checkpoint_wall_interval: 0, monitor_interval: 10, "
                          "field_interval: 20}\n";
  const fs::path ref = tmp.path / "ref";
  ASSERT_EQ(run_fdem(run_args(scene, ref)).code, 0);
  fs::create_directory(small);
  if (run_cmd("mount -t tmpfs -o size=44k tmpfs " + quote(small.string())).code != 0)
    GTEST_SKIP() << "needs to mount a tmpfs (root)";
  struct Unmount {
    fs::path p;
    ~Unmount() { run_cmd("umount " + quote(p.string())); }
  } unmount{small};
  const fs::path run = small / "run";
  const Outcome full = run_fdem(run_args(scene, run));
  EXPECT_EQ(full.code, 4) << full.text;
  EXPECT_TRUE(has(full.text, "output failed: HDF5 output")) << full.text;
  EXPECT_TRUE(has(full.text, "the disk is full")) << full.text;
  // Read-only (a scratch file system mounted so): refused at once, naming why.
  ASSERT_EQ(run_cmd("mount -o remount,ro " + quote(small.string())).code, 0);
  const Outcome ro = run_fdem(run_args(scene, run) + " --restart " + quote(run.string()));
  EXPECT_EQ(ro.code, 2) << ro.text;
  EXPECT_TRUE(has(ro.text, "--restart: cannot write in " + run.string() + " (Read-only file system)")) << ro.text;
  ASSERT_EQ(run_cmd("mount -o remount,rw,size=4m " + quote(small.string())).code, 0);
  const Outcome again = run_fdem(run_args(scene, run) + " --restart " + quote(run.string()));
  ASSERT_EQ(again.code, 0) << again.text;
  EXPECT_TRUE(has(again.text, "frames before the checkpoint were copied into a new fields.h5")) << again.text;
  expect_same_run(ref, run);
}

TEST(Restart, AnInterruptedSeriesContinuesFromItsCheckpoint) {
  TempDir tmp("restart_series");
  const fs::path scene =
      scene_variant(tmp.path, "series", {{"checkpoint_wall_interval: 0", "checkpoint_wall_interval: 0.1"}});
  const std::string vary = " --vary platen_velocity=1.0 -t 1 -o ";
  const fs::path s1 = tmp.path / "s1", s2 = tmp.path / "s2";
  Outcome o = run_fdem("series " + quote(scene.string()) + vary + quote(s1.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  std::vector<fs::path> variants;
  for (const auto& e : fs::directory_iterator(s1))
    if (e.is_directory()) variants.push_back(e.path().filename());
  ASSERT_EQ(variants.size(), 1u);
  const fs::path run = s2 / variants[0];
  const std::string script = kEnv + quote(kExe) + " series " + quote(scene.string()) + vary + quote(s2.string()) +
                             " & pid=$!; for i in $(seq 1500); do [ \"$(cat " + quote((run / "monitors.csv").string()) +
                             " 2>/dev/null | wc -l)\" -ge 26 ] && [ \"$(ls " + quote((run / "checkpoints").string()) +
                             " 2>/dev/null | grep -c 'ckpt$')\" -ge 2 ] && break; sleep 0.02; done; kill -TERM $pid; "
                             "wait $pid";
  o = run_cmd("bash -c " + quote(script));
  ASSERT_EQ(o.code, 5) << o.text;
  EXPECT_TRUE(has(o.text, "run the same command again")) << o.text;
  o = run_fdem("series " + quote(scene.string()) + vary + quote(s2.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "continuing from the checkpoint in")) << o.text;
  expect_same_run(s1 / variants[0], run);
}

TEST(Restart, AFreshRunDropsOldCheckpointsAndARestartChecksItsMonitorFile) {
  TempDir tmp("restart_fresh");
  const fs::path every100 = checkpointed(tmp.path, "every100", 250, 100);
  const fs::path every50 = checkpointed(tmp.path, "every50", 60, 50);
  const fs::path d = tmp.path / "d", e = tmp.path / "e";
  ASSERT_EQ(run_fdem(run_args(every100, d)).code, 0);
  ASSERT_EQ(checkpoint_names(d), (std::vector<std::string>{"step_000000000100.ckpt", "step_000000000200.ckpt"}));
  // A fresh run in the same folder: the old checkpoints belong to files it replaces.
  ASSERT_EQ(run_fdem(run_args(every50, d)).code, 0);
  EXPECT_EQ(checkpoint_names(d), std::vector<std::string>{"step_000000000050.ckpt"});
  // A checkpoint restarted into another run's folder (same physics, other monitor rows): refused
  // before anything there changes.
  const fs::path rows25 =
      checkpointed(tmp.path, "rows25", 250, 100, {{"monitor_interval: 50", "monitor_interval: 25"}});
  ASSERT_EQ(run_fdem(run_args(rows25, e)).code, 0);
  const std::string before = slurp(e / "monitors.csv");
  const Outcome o =
      run_fdem(run_args(every50, e) + " --restart " + quote((d / "checkpoints" / "step_000000000050.ckpt").string()));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(
      has(o.text,
          "bytes from the monitors.csv of this checkpoint (edited, saved again by a spreadsheet, or another run's)"))
      << o.text;
  EXPECT_EQ(slurp(e / "monitors.csv"), before);
}

TEST(Restart, ACheckpointThatCannotBeWrittenWarnsAndTheRunGoesOn) {
  TempDir tmp("restart_unwritable");
  const fs::path scene =
      scene_variant(tmp.path, "every2500", {{"checkpoint_wall_interval: 0", "checkpoint_interval: 2500"}});
  const fs::path f = tmp.path / "f";
  // Once the run has started, a plain file takes the place of its checkpoints folder (long
  // before the first checkpoint: a loaded machine may take a while to see the run start).
  const std::string script = kEnv + quote(kExe) + " " + run_args(scene, f) + " & pid=$!; for i in $(seq 1500); do " +
                             "[ -s " + quote((f / "monitors.csv").string()) + " ] && break; sleep 0.01; done; rm -rf " +
                             quote((f / "checkpoints").string()) + "; touch " + quote((f / "checkpoints").string()) +
                             "; wait $pid";
  const Outcome o = run_cmd("bash -c " + quote(script));
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "warning: checkpoint (every 2500 steps) not written, the run goes on")) << o.text;
  EXPECT_TRUE(fs::exists(f / "summary.csv"));
  EXPECT_EQ(first_difference(reference_run() / "monitors.csv", f / "monitors.csv"), "");
}

// One run at a time in an output folder (io/run_lock.hpp).

namespace {

/// Runs `first` in the background until its monitors.csv in `folder` has `rows` rows, then
/// `second` (both whole fdem argument strings), then waits for the first. The first is stopped
/// (SIGSTOP) while the second runs, so a fast first run cannot end before the second starts;
/// a stopped process still holds its lock and counts as alive. The output holds
/// "pid=<first's PID>", "second=<exit code>" and "first=<exit code>", with what both printed.
Outcome overlapping_runs(const std::string& first, const fs::path& folder, int rows, const std::string& second,
                         const std::string& second_env = "", const std::string& first_env = "") {
  const std::string script =
      first_env + kEnv + quote(kExe) + " " + first + " & pid=$!; echo pid=$pid; for i in $(seq 1500); do " +
      "[ \"$(cat " + quote((folder / "monitors.csv").string()) + " 2>/dev/null | wc -l)\" -ge " +
      std::to_string(rows + 1) + " ] && break; sleep 0.02; " + "done; kill -STOP $pid; " + second_env + kEnv +
      quote(kExe) + " " + second + "; echo second=$?; kill -CONT $pid; wait $pid; echo first=$?";
  return run_cmd("bash -c " + quote(script));
}

/// The value after "<key>=" in text, or "".
std::string value_after(const std::string& text, const std::string& key) {
  std::smatch m;
  return std::regex_search(text, m, std::regex(key + "=([0-9]+)")) ? m[1].str() : "";
}

}  // namespace

TEST(RunLock, ASecondRunIntoAFolderInUseIsRefusedAndTheFirstRunsAsAlone) {
  // Two runs of one folder: the second exits 2 at once, naming the first's PID, and writes
  // nothing; the first's outputs are those of a run alone (before, both exited 0 and the folder
  // held a mix of the two).
  const fs::path& alone = reference_run();
  TempDir tmp("lock_two_runs");
  const fs::path x = tmp.path / "x";
  const Outcome o = overlapping_runs(run_args(kScene, x), x, 2, run_args(kScene, x) + " -q");
  const std::string pid = value_after(o.text, "pid");
  ASSERT_FALSE(pid.empty()) << o.text;
  EXPECT_EQ(value_after(o.text, "second"), "2") << o.text;
  EXPECT_EQ(value_after(o.text, "first"), "0") << o.text;
  EXPECT_TRUE(has(o.text, "PID " + pid + ", started ")) << o.text;
  EXPECT_TRUE(has(o.text, "nothing was written")) << o.text;
  expect_same_run(alone, x);
  // The folder is free again: a third run goes.
  EXPECT_EQ(run_fdem(run_args(kScene, x) + " -q").code, 0);
}

TEST(RunLock, RunsGuardingTheFolderByTheRecordAndByTheFileLockRespectEachOther) {
  // A run that holds the kernel lock writes its record too (and renews it), and a run that
  // guards its folder by the record alone (FDEM_RUN_LOCK=record, as where file locks do not work)
  // holds no kernel lock: each refuses a second run of the other kind.
  TempDir tmp("lock_mixed");
  for (bool record_first : {false, true}) {
    SCOPED_TRACE(record_first ? "record, then flock" : "flock, then record");
    const fs::path y = tmp.path / (record_first ? "record_first" : "flock_first");
    const std::string record = "FDEM_RUN_LOCK=record ";
    const Outcome o = overlapping_runs(run_args(kScene, y), y, 2, run_args(kScene, y) + " -q",
                                       record_first ? "" : record, record_first ? record : "");
    EXPECT_EQ(value_after(o.text, "second"), "2") << o.text;
    EXPECT_EQ(value_after(o.text, "first"), "0") << o.text;
    EXPECT_TRUE(has(o.text, "PID " + value_after(o.text, "pid") + ", started ")) << o.text;
  }
}

TEST(RunLock, AKilledRunLeavesNoLockAndItsRestartEqualsTheUninterruptedRun) {
  // kill -9 leaves the holder's record but the kernel drops its lock: the restart takes the folder
  // over with a note and continues bit for bit.
  const fs::path& a = reference_run();
  TempDir tmp("lock_kill9");
  const fs::path scene = checkpointed(tmp.path, "every500", 3000, 500), c = tmp.path / "c";
  const std::string script = kEnv + quote(kExe) + " " + run_args(scene, c) + " & pid=$!; for i in $(seq 1500); do " +
                             "[ \"$(ls " + quote((c / "checkpoints").string()) +
                             " 2>/dev/null | grep -c 'ckpt$')\" -ge 1 ] && break; sleep 0.02; done; kill -KILL $pid; "
                             "wait $pid; echo killed=$?";
  Outcome o = run_cmd("bash -c " + quote(script));
  ASSERT_EQ(value_after(o.text, "killed"), "137") << o.text;
  ASSERT_FALSE(fs::exists(c / "summary.csv")) << "killed before the end";
  ASSERT_GT(slurp(c / ".fdem.lock").size(), 0u) << "the killed run's record stays";
  o = run_fdem(run_args(kScene, c) + " --restart " + quote(c.string()));
  ASSERT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "ended without releasing it")) << o.text;
  expect_same_run(a, c);
  EXPECT_EQ(slurp(c / ".fdem.lock"), "") << "a finished run leaves the folder free";
}

TEST(RunLock, AStaleRecordIsTakenOverAndALiveOneRefusedAlsoWithoutFileLocks) {
  // A record of a process that does not exist (this host) is taken over, with or without file
  // locks (FDEM_RUN_LOCK=record: the record alone, as on file systems without working locks); a
  // live process's record, or another host's renewed within 5 minutes, is refused.
  TempDir tmp("lock_stale");
  char host[256] = {};
  gethostname(host, sizeof host - 1);
  const fs::path scene = checkpointed(tmp.path, "short", 100, 1000);
  const double now = double(std::time(nullptr));
  auto record = [&](const fs::path& dir, const std::string& on, long pid, double heartbeat) {
    fs::create_directories(dir);
    std::ofstream(dir / ".fdem.lock") << "host " << on << "\npid " << pid << "\nstarted 2026-01-01 00:00:00 UTC\n"
                                      << "heartbeat " << std::to_string(heartbeat) << "\ncommand fdem run old.yaml\n";
  };
  const long gone = 999999999;  // above Linux's PID limit
  for (const std::string mode : {"", "FDEM_RUN_LOCK=record "}) {
    SCOPED_TRACE(mode);
    const fs::path d = tmp.path / ("stale" + std::to_string(mode.size()));
    record(d, host, gone, now);
    Outcome o = run_cmd(mode + kEnv + quote(kExe) + " " + run_args(scene, d));
    EXPECT_EQ(o.code, 0) << o.text;
    EXPECT_TRUE(has(o.text, "PID " + std::to_string(gone)) && has(o.text, "taking it over")) << o.text;
    EXPECT_TRUE(fs::exists(d / "summary.csv"));
  }
  // The record alone: this test's own process is alive on this host; another host's record is
  // refused while renewed, taken over once 5 minutes old.
  const fs::path live = tmp.path / "live", other = tmp.path / "other", old = tmp.path / "old";
  const fs::path reused = tmp.path / "reused";
  record(live, host, long(getpid()), now);
  record(reused, host, long(getpid()), now - 600);  // a PID taken by another process since
  record(other, "node-elsewhere", 4242, now);
  record(old, "node-elsewhere", 4242, now - 600);
  const std::string record_only = "FDEM_RUN_LOCK=record " + kEnv + quote(kExe) + " ";
  Outcome o = run_cmd(record_only + run_args(scene, live));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "PID " + std::to_string(getpid()) + ", started")) << o.text;
  EXPECT_FALSE(fs::exists(live / "monitors.csv"));
  o = run_cmd(record_only + run_args(scene, other));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "host node-elsewhere") && has(o.text, "renewed")) << o.text;
  o = run_cmd(record_only + run_args(scene, old));
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "not renewed for")) << o.text;
  o = run_cmd(record_only + run_args(scene, reused));
  EXPECT_EQ(o.code, 0) << o.text;
  EXPECT_TRUE(has(o.text, "not renewed for")) << o.text;
  // An unknown way of locking is an input error.
  o = run_cmd("FDEM_RUN_LOCK=maybe " + kEnv + quote(kExe) + " " + run_args(scene, tmp.path / "maybe"));
  EXPECT_EQ(o.code, 2) << o.text;
  EXPECT_TRUE(has(o.text, "FDEM_RUN_LOCK=maybe")) << o.text;
}

TEST(RunLock, ASecondSeriesIntoAFolderInUseIsRefused) {
  TempDir tmp("lock_series");
  const fs::path scene = checkpointed(tmp.path, "series", 3000, 100000), s = tmp.path / "s";
  const std::string series =
      "series " + quote(scene.string()) + " --vary platen_velocity=1.0 -q -o " + quote(s.string());
  // The first series' run folder fills while the second starts.
  const Outcome o = overlapping_runs(series, s / "platen_velocity_1.0", 2, series);
  EXPECT_EQ(value_after(o.text, "second"), "2") << o.text;
  EXPECT_EQ(value_after(o.text, "first"), "0") << o.text;
  EXPECT_TRUE(has(o.text, "PID " + value_after(o.text, "pid"))) << o.text;
  EXPECT_TRUE(fs::exists(s / "series.csv"));
}
