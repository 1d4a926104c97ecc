#include "solver/run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/fields.hpp"
#include "io/run_lock.hpp"
#include "model/conditions.hpp"
#include "model/initial_stress.hpp"
#include "model/joints.hpp"
#include "model/materials.hpp"
#include "solver/frames.hpp"
#include "solver/run_folder.hpp"
#include "solver/run_observers.hpp"

namespace fdem {

bool run_python_script(const std::string& script, std::vector<std::string> args) {
  const std::string py = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  args.insert(args.begin(), {py, std::string(FDEM_SCRIPTS_DIR) + "/" + script});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t quiet;
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int rc = posix_spawnp(&pid, argv[0], &quiet, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&quiet);
  int status = 0;
  return rc == 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

/// A tet whose least altitude is below this fraction of the mean edge is named as a sliver: it
/// alone sets the stable step (a gmsh mesh's least altitude is about 0.1 to 0.2 of its mean edge).
constexpr real kSliver = 1e-2;

void report_model(const Solver& solver, std::ostream& out) {
  const Model& m = solver.model();
  const StableStep& st = solver.stable_step();
  const Decomposition& dd = solver.decomposition();
  if (dd.distributed()) {
    long own = 0;
    for (auto o : dd.tet_owned) own += o;
    out << "model " << m.source << "\n"
        << "  tets " << dd.global_tets << ", CE6 " << dd.global_ce6 << ", nodes " << dd.global_nodes << " on "
        << dd.size << " MPI ranks (contact reach " << dd.reach << " m); rank " << dd.rank << " holds " << own
        << " own and " << m.tet_nodes.size() - own << " ghost tets, " << m.X.size() << " nodes\n";
  } else {
    out << "model " << m.source << "\n"
        << "  tets " << m.tet_nodes.size() << ", CE6 " << m.ce6_nodes.size() << ", nodes " << m.X.size()
        << ", surface faces " << m.surface_faces.size() << "\n";
  }
  out << describe_materials(solver.scene(), m, dd.distributed() ? " (this rank)" : "");
  out << describe_joints(solver.scene(), m, dd.distributed() ? " (this rank)" : "");
  out << describe_conditions(solver.scene(), m, dd.distributed() ? " (this rank)" : "");
  out << describe_initial_stress(solver.scene());
  out << describe_excavation(solver.scene(), m, dd.distributed() ? " (this rank)" : "");
  out << "  height " << m.height0 << " m, loaded area " << m.area0 << " m^2, mean edge " << m.mean_edge
      << " m, minimum altitude " << m.min_altitude << " m\n"
      << (m.min_altitude < kSliver * m.mean_edge && m.min_altitude_tet >= 0
              ? "  warning: tet " + std::to_string(m.min_altitude_tet + 1) + " of " + m.source +
                    " is a sliver (altitude " + fmt(m.min_altitude, 3) + " m, " + fmt(m.min_altitude / m.mean_edge, 2) +
                    " of the mean edge): it sets the stable step. Fix: remesh or optimise the mesh (gmsh "
                    "-optimize_netgen)\n"
              : std::string())
      << "  stable step " << solver.stable_bound() << " s limited by " << st.limit << " (TET4 " << st.dt_tet
      << " s, CE6 " << st.dt_ce6 << " s, platens " << st.dt_platen << " s, contact " << st.dt_contact << " s)\n"
      << "  backend " << backend_name(solver.backend())
      << (solver.backend() == Backend::cuda ? " (" + cuda_device_description() + ")" : std::string())
      << (solver.device_loop() ? solver.device_loop()->integrates()
                                     ? ", TET4, CE6, the forces held for their nodes and the step fused in one pass"
                                 : solver.device_loop()->fused() ? ", TET4 and CE6 fused in one pass"
                                                                 : ", TET4 and CE6 colour by colour"
                               : "")
      << (solver.device_loop() && dd.distributed() ? solver.device_loop()->halo_passes_device_buffers()
                                                         ? ", halo: device buffers to MPI"
                                                         : ", halo: staged through host memory"
                                                   : "")
      << "\n"
      << "  time step " << solver.dt() << " s ("
      << (solver.scene().solver.time_step > 0
              ? "solver.time_step, " + fmt(solver.dt() / solver.stable_bound(), 3) + " x the stable-step bound"
              : "safety " + fmt(solver.scene().solver.time_step_safety))
      << ", mass scaling " << solver.scene().solver.mass_scaling << ")\n";
}

namespace {

/// One run of run_scene: its folder and files, then the loop: a step, then each observer of the
/// step in turn (solver/run_observers.hpp).
class RunSession {
 public:
  RunSession(Solver& solver, std::ostream& log, const RunOptions& options);
  /// The first monitor row and frame of a fresh run.
  void start();
  /// Steps to the scene's end; an unstable step's RunError is rethrown after the diagnostic frame.
  void loop();
  /// The last row and frame, the plot, broken_ce6.csv and, last, summary.csv.
  RunSummary finish();

 private:
  bool all_ranks(bool ok) const;
  /// The ranks that write fields.h5 together; none (this process alone) on one rank.
  MPI_Comm field_ranks() const { return r_.dist ? r_.solver.comm() : MPI_COMM_NULL; }
  void write_diagnostic_frame() const;
  void open_folder();
  /// A checkpoint to restart from: this rank's file of a step, or every file of a step saved
  /// on another rank count.
  struct Candidate {
    long step = -1;                  // rank 0's step, the same on every rank
    std::string file;                // this rank's ("" where it has none of the step)
    std::vector<std::string> saved;  // another rank count's files, in rank order
    std::string name() const { return saved.empty() ? file : saved[0]; }
  };
  std::vector<Candidate> restart_candidates() const;
  std::vector<CheckpointSet> other_rank_counts() const;
  std::string load_checkpoint(const std::string& file, FieldWriterState& fields_state);
  std::string load_saved_ranks(const std::vector<std::string>& files, FieldWriterState& fields_state);
  std::string check_saved_ranks(const std::vector<std::string>& files);
  std::string check_outputs(const std::string& file) const;
  void restart();
  void replace_earlier_run();
  void write_broken_ce6() const;

  RunRecord r_;
  const RunOptions options_;
  const Scene& scene_;
  const OutputSettings& out_;
  std::string ckpt_dir_, suffix_;
  std::unique_ptr<RunLock> lock_;
  // The observers of a step, in the order they are called; the index and the checkpoints also
  // by name.
  std::vector<std::unique_ptr<StepObserver>> observers_;
};

RunSession::RunSession(Solver& solver, std::ostream& log, const RunOptions& options)
    : r_(solver, log), options_(options), scene_(solver.scene()), out_(scene_.output) {
  namespace fs = std::filesystem;
  ckpt_dir_ = (fs::path(out_.folder) / "checkpoints").string();
  suffix_ = checkpoint_suffix(solver.rank(), r_.dist ? solver.decomposition().size : 1);
  open_folder();
  if (!options_.restart.empty())
    restart();
  else
    replace_earlier_run();
  if (!r_.csv.f) throw InputError(scene_.file + ": output.folder: cannot write '" + r_.csv_path + "'");
  if (!r_.fields) {
    r_.csv.put(monitors_header(scene_));
    r_.fields = std::make_unique<FieldWriter>(out_.folder, "fields", field_ranks());
  }
  // The automatic field interval: about 20 frames over the steps the end takes.
  const real end_steps = solver.end_steps().steps;
  const real expected = std::isfinite(end_steps) ? end_steps : 0;
  const long field_interval = out_.field_interval > 0 ? out_.field_interval : std::max<long>(1, long(expected / 20));
  r_.t0 = std::chrono::steady_clock::now();
  observers_.push_back(std::make_unique<MonitorRows>(r_));
  observers_.push_back(std::make_unique<FieldFrames>(r_, field_interval));
  observers_.push_back(std::make_unique<EndCheck>(r_));
  observers_.push_back(std::make_unique<ProgressLine>(r_));
  observers_.push_back(std::make_unique<Checkpoints>(r_, ckpt_dir_, suffix_));
}

bool RunSession::all_ranks(bool ok) const {
  if (!r_.dist) return ok;
  int v = ok;
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, r_.solver.comm());
  return v != 0;
}

/// A fresh run creates its folder; a restart continues in one that holds the run (not created,
/// so that a wrong one is not left behind empty) and that it can write. Then the lock.
void RunSession::open_folder() {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (options_.restart.empty()) fs::create_directories(out_.folder, ec);
  if (ec) throw InputError(scene_.file + ": output.folder: cannot create '" + out_.folder + "': " + ec.message());
  if (!options_.restart.empty() && fs::is_directory(out_.folder, ec) && ::access(out_.folder.c_str(), W_OK) != 0)
    throw InputError("--restart: cannot write in " + out_.folder + " (" + std::strerror(errno) +
                     "), where the run goes on; nothing was changed. Fix: make the folder writable, or copy it "
                     "somewhere writable and restart there (with -o)");
  // One run at a time in the folder (a restart's folder that does not exist is named later).
  if (!options_.folder_locked && (options_.restart.empty() || all_ranks(fs::is_directory(out_.folder, ec))))
    lock_ = lock_run_folder(out_.folder, r_.solver, r_.log);
}

/// The checkpoints to restart from, newest first. Several ranks: rank 0's steps are the
/// candidates, and each rank's file of each ("" where it has none). Sets of another rank count
/// follow, or come first where newer.
std::vector<RunSession::Candidate> RunSession::restart_candidates() const {
  const std::vector<std::string> found = find_checkpoints(options_.restart, suffix_);
  auto step_of = [](const std::string& file) {
    const std::string name = std::filesystem::path(file).filename().string();
    return name.rfind("step_", 0) == 0 ? std::atol(name.c_str() + 5) : -1L;
  };
  std::vector<long> steps;  // rank 0's
  for (const std::string& f : found) steps.push_back(step_of(f));
  if (r_.dist) {
    long n = long(steps.size());
    MPI_Bcast(&n, 1, MPI_LONG, 0, r_.solver.comm());
    steps.resize(n);
    MPI_Bcast(steps.data(), int(n), MPI_LONG, 0, r_.solver.comm());
  }
  std::vector<Candidate> all;
  for (long st : steps) {
    Candidate c{st, "", {}};
    for (const std::string& f : found)
      if (step_of(f) == st) c.file = f;
    all.push_back(c);
  }
  std::size_t own = 0;  // (a step of this rank count before another's of the same step)
  for (CheckpointSet& set : other_rank_counts()) {
    while (own < all.size() && all[own].step >= set.step) ++own;
    all.insert(all.begin() + long(own++), Candidate{set.step, "", std::move(set.files)});
  }
  if (all.empty())
    throw InputError("--restart " + options_.restart + ": no checkpoint there (files checkpoints/step_<n>.ckpt or " +
                     "step_<n>.rank<r>of<N>.ckpt). Fix: give the output folder of the interrupted run" +
                     (r_.dist ? "" : " or one of its .ckpt files"));
  return all;
}

/// The whole checkpoint sets under --restart saved on another rank count, newest first (none
/// where --restart names one file of a one-rank run). Rank 0 looks; every rank gets its list.
std::vector<CheckpointSet> RunSession::other_rank_counts() const {
  namespace fs = std::filesystem;
  const int ranks = r_.dist ? r_.solver.decomposition().size : 1;
  std::string list;  // step, rank count and files, one per line
  std::error_code ec;
  const bool one_file = !r_.dist && fs::is_regular_file(options_.restart, ec) &&
                        fs::path(options_.restart).filename().string().find(".rank") == std::string::npos;
  if (r_.root && !one_file)
    for (const CheckpointSet& set : find_checkpoint_sets(options_.restart)) {
      if (set.ranks == ranks) continue;
      list += std::to_string(set.step) + "\n" + std::to_string(set.ranks) + "\n";
      for (const std::string& f : set.files) list += f + "\n";
    }
  if (r_.dist) {
    long n = long(list.size());
    MPI_Bcast(&n, 1, MPI_LONG, 0, r_.solver.comm());
    list.resize(std::size_t(n));
    MPI_Bcast(list.data(), int(n), MPI_CHAR, 0, r_.solver.comm());
  }
  std::vector<CheckpointSet> sets;
  std::istringstream in(list);
  std::string line;
  while (std::getline(in, line)) {
    CheckpointSet& set = sets.emplace_back();
    set.step = std::atol(line.c_str());
    std::getline(in, line);
    set.ranks = std::atoi(line.c_str());
    for (int r = 0; r < set.ranks && std::getline(in, line); ++r) set.files.push_back(line);
  }
  return sets;
}

/// Loads a checkpoint into the solver and the session; returns why it cannot be used ("" where
/// it can): damaged, or its monitors.csv or fields file is not the one in this folder.
std::string RunSession::load_checkpoint(const std::string& file, FieldWriterState& fields_state) {
  namespace fs = std::filesystem;
  if (file.empty()) return "rank " + std::to_string(r_.solver.rank()) + " has no file of the step rank 0 has";
  std::optional<CheckpointIn> in;
  try {
    in.emplace(read_checkpoint(file));
  } catch (const CannotOpen& e) {
    // Not damaged, only unreadable: falling back would drop its rows and remove it.
    throw InputError("--restart " + options_.restart + ": " + e.what() + "; nothing was changed");
  } catch (const InputError& e) {
    return e.what();
  }
  r_.solver.load(*in);
  r_.load(*in, fields_state);
  in->finish();
  return check_outputs(file);
}

/// Loads the files of a checkpoint saved on another rank count, every rank reading each in
/// turn; returns why it cannot be used, as load_checkpoint does. Each file is checked whole
/// before any is taken, so that a damaged one changes nothing.
std::string RunSession::load_saved_ranks(const std::vector<std::string>& files, FieldWriterState& fields_state) {
  if (const std::string why = check_saved_ranks(files); !all_ranks(why.empty()))
    return why.empty() ? files[0] + ": another rank cannot use a file of this step" : why;
  for (std::size_t k = 0; k < files.size(); ++k) {
    CheckpointIn in = read_checkpoint(files[k]);
    const EntityMap map = r_.solver.read_saved_rank(in);
    RunRecord saved(r_.solver, r_.log);
    FieldWriterState fields;
    saved.load(in, fields);
    in.finish();
    if (k == 0) {
      r_.take_saved(saved);
      fields_state = std::move(fields);
      fields_state.mesh_tets.clear();  // (this rank's slab is another: its frames write their own tets)
    }
    r_.peak_frames.take_saved(saved.peak_frames, map, r_.solver, k == 0);
  }
  r_.solver.finish_saved_ranks();
  r_.peak_frames.finish_saved(r_.solver);
  return "";
}

/// Why a set of another rank count cannot be used ("" where it can), before any of it is taken:
/// a file that is damaged, or the outputs in the folder not those of its saved rank 0.
std::string RunSession::check_saved_ranks(const std::vector<std::string>& files) {
  for (std::size_t k = 0; k < files.size(); ++k) try {
      CheckpointIn in = read_checkpoint(files[k]);
      if (k > 0) continue;
      r_.solver.check_saved_rank(in);
      RunRecord saved(r_.solver, r_.log);
      FieldWriterState fields;
      saved.load(in, fields);
      in.finish();
      r_.take_saved(saved);  // (the row and monitors.csv's length and hash, for the check)
    } catch (const CannotOpen& e) {
      throw InputError("--restart " + options_.restart + ": " + e.what() + "; nothing was changed");
    } catch (const InputError& e) {
      return e.what();
    }
  return check_outputs(files[0]);
}

/// Why the outputs in the folder are not the checkpoint's ("" where they are): monitors.csv
/// missing, shorter or changed, or fields.h5 missing.
std::string RunSession::check_outputs(const std::string& file) const {
  namespace fs = std::filesystem;
  std::uint64_t hash = 0;
  std::error_code ec;
  const fs::path h5 = fs::path(out_.folder) / "fields.h5";
  const std::string back =
      ". Fix: put back the monitors.csv the run wrote, or restart in the interrupted run's folder (output.folder or "
      "-o)";
  if (r_.root && !fs::is_regular_file(r_.csv_path, ec)) return file + ": " + r_.csv_path + " is missing" + back;
  if (r_.root && !hash_prefix(r_.csv_path, r_.csv.bytes, hash))
    return file + ": " + r_.csv_path + " holds " + std::to_string(fs::file_size(r_.csv_path, ec)) +
           " bytes, fewer than the " + std::to_string(r_.csv.bytes) +
           " it held at this checkpoint (cut short, or another run's)" + back;
  if (r_.root && hash != r_.csv.hash)
    return file + ": " + r_.csv_path + " differs in its first " + std::to_string(r_.csv.bytes) +
           " bytes from the monitors.csv of this checkpoint (edited, saved again by a spreadsheet, or another "
           "run's)" +
           back;
  if (!fs::is_regular_file(h5, ec)) return file + ": " + h5.string() + " is missing";
  return "";
}

/// Continues from the newest checkpoint that reads and matches the files here (a damaged one, or
/// one whose monitors.csv is not the one in this folder, falls back to the one before). The rows
/// and frames written after it are dropped (the loop writes them again), and so are newer
/// checkpoints (damaged, or of the history being replaced).
void RunSession::restart() {
  namespace fs = std::filesystem;
  const std::vector<Candidate> found = restart_candidates();
  std::string problems;
  for (std::size_t k = 0; k < found.size(); ++k) {
    const Candidate& c = found[k];
    const std::string& file = c.name();
    FieldWriterState fields_state;
    std::string why = c.saved.empty() ? load_checkpoint(file, fields_state) : load_saved_ranks(c.saved, fields_state);
    if (!all_ranks(why.empty())) {
      if (why.empty()) why = (file.empty() ? "step " : file + ": ") + std::string("another rank cannot use its file");
      if (r_.dist && !r_.root) why = "rank " + std::to_string(r_.solver.rank()) + ": " + why;
      (r_.root ? r_.log : std::cerr) << "warning: " << why << std::endl;
      problems += "\n  " + why;
      continue;
    }
    // A scene whose end was moved before the checkpoint: the loop would take one step more
    // and stop, after the rows and frames past the checkpoint had been dropped.
    if (const std::string reason = EndCheck(r_).reason(true); !reason.empty())
      throw InputError("--restart " + options_.restart + ": " + file + " is at step " +
                       std::to_string(r_.solver.step_count()) + ", t = " + fmt(r_.solver.time(), 6) +
                       " s, where the scene's end is already reached (" + reason +
                       "); nothing was changed. Fix: move solver.end in " + scene_.file +
                       " past it to continue the run, or run without --restart to start again");
    r_.fields = std::make_unique<FieldWriter>(out_.folder, "fields", fields_state, field_ranks());
    if (!r_.fields->repaired().empty())
      (r_.root ? r_.log : std::cerr) << "warning: " << r_.fields->repaired() << std::endl;
    std::error_code ec;
    if (r_.root) {
      fs::resize_file(r_.csv_path, r_.csv.bytes, ec);
      if (ec) throw OutputError("cannot truncate " + r_.csv_path + ": " + ec.message());
    }
    r_.csv.f.open(r_.csv_path, std::ios::app);
    for (std::size_t j = 0; j < k; ++j) {  // (newer ones: damaged, or of the history replaced)
      if (!found[j].file.empty() && fs::path(found[j].file).parent_path() == fs::path(file).parent_path())
        fs::remove(found[j].file, ec);
      if (r_.root)
        for (const std::string& f : found[j].saved) fs::remove(f, ec);
    }
    r_.log << "restart: continuing from " << file;
    if (!c.saved.empty())
      r_.log << " and the other files of its step, saved on " << c.saved.size() << " rank"
             << (c.saved.size() > 1 ? "s" : "") << " and taken into " << (r_.dist ? r_.solver.decomposition().size : 1)
             << " now";
    else if (r_.dist)
      r_.log << " (and the other ranks' files of that step)";
    r_.log << " at step " << r_.solver.step_count() << ", t = " << r_.solver.time() << " s" << std::endl;
    return;
  }
  throw InputError("--restart " + options_.restart + ": no usable checkpoint:" + problems +
                   "\nnothing was changed; without a usable checkpoint the run can only start afresh (without "
                   "--restart)");
}

/// A fresh run replaces an earlier run's outputs in this folder: first a check that it can (on
/// every rank), so that a failure leaves them whole; then its checkpoints, summary, plot and
/// broken-CE6 list go (they belong to the files replaced), and the rest is overwritten.
void RunSession::replace_earlier_run() {
  namespace fs = std::filesystem;
  std::vector<std::string> names;
  if (r_.root)
    names = {"fields.h5",      "fields.xdmf",       "monitors.csv", "summary.csv",
             "broken_ce6.csv", "stress_strain.png", "checkpoints"};
  const std::string problem = replace_problem(out_.folder, names);
  if (!all_ranks(problem.empty()))
    throw OutputError(("the run cannot replace the outputs of an earlier one: " +
                       (problem.empty() ? "another rank found one in the way" : problem)) +
                      "; nothing was changed. Fix: move it away, or give the run another output folder (-o)");
  if (r_.root) {
    std::error_code ec;
    fs::remove_all(ckpt_dir_, ec);
    for (const char* stale : {"summary.csv", "broken_ce6.csv", "stress_strain.png"})
      fs::remove(fs::path(out_.folder) / stale, ec);
    std::vector<fs::path> diagnostic;  // an earlier run's diagnostic frames of its ranks
    for (fs::directory_iterator e(out_.folder, ec), end; !ec && e != end; e.increment(ec))
      if (e->path().filename().string().rfind("diagnostic_rank", 0) == 0) diagnostic.push_back(e->path());
    for (const fs::path& p : diagnostic) fs::remove(p, ec);
  }
  r_.csv.f.open(r_.csv_path);
}

void RunSession::start() {
  if (!options_.restart.empty()) return;
  r_.row = r_.solver.measure();
  r_.csv.put(monitor_row(r_.row, r_.solver));
  write_frame(*r_.fields, r_.solver, "initial");
}

void RunSession::loop() {
  try {
    for (;;) {
      r_.solver.step();
      StepEvent e;
      e.step = r_.solver.step_count();
      e.monitor_row = e.step % out_.monitor_interval == 0;
      for (const auto& o : observers_) o->after_step(e);
      if (!e.end.empty()) {
        r_.sum.end_reason = e.end;
        break;
      }
    }
    r_.row = r_.solver.measure();
    if (r_.solver.step_count() % out_.monitor_interval != 0) r_.csv.put(monitor_row(r_.row, r_.solver));
  } catch (const RunError&) {
    write_diagnostic_frame();
    throw;
  }
}

/// The diagnostic frame of a run stopped as unstable. Several ranks: the rank that stopped may
/// be alone, so each writes its own diagnostic_rank<r>.{h5,xdmf} rather than the shared file.
void RunSession::write_diagnostic_frame() const {
  if (!r_.dist) return write_diagnostic(*r_.fields, r_.solver);
  try {
    FieldWriter own(out_.folder, "diagnostic_rank" + std::to_string(r_.solver.rank()));
    write_diagnostic(own, r_.solver);
  } catch (const std::exception&) {
    // Nothing more to show; the frames of fields.h5 remain valid.
  }
}

/// broken_ce6.csv: the broken CE6s by global id and mode, and the joint of those on one (the
/// fracture pattern, for comparisons such as fdem study). Several ranks send theirs (owned ones)
/// to rank 0.
void RunSession::write_broken_ce6() const {
  std::vector<long> broken;  // id, mode, joint (-1: rock)
  r_.solver.sync_host();
  const ElementLaws& laws = r_.solver.laws();
  for (std::size_t i = 0; i < r_.solver.state.ce6.size(); ++i)
    if (r_.solver.state.ce6.damage[i].mode != 0 && r_.solver.state.ce6.damage[i].mode != kCe6Excavated &&
        r_.solver.owned_ce6()[i])
      broken.insert(broken.end(),
                    {r_.dist ? r_.solver.decomposition().ce6_global[i] : long(i),
                     long(r_.solver.state.ce6.damage[i].mode), long(laws.joint_of_law(r_.solver.model().ce6_law[i]))});
  if (r_.dist) {
    const int size = r_.solver.decomposition().size;
    int len = int(broken.size());
    std::vector<int> lens(size), offs(size + 1, 0);
    MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, r_.solver.comm());
    for (int r = 0; r < size; ++r) offs[r + 1] = offs[r] + lens[r];
    std::vector<long> all(r_.root ? offs[size] : 0);
    MPI_Gatherv(broken.data(), len, MPI_LONG, all.data(), lens.data(), offs.data(), MPI_LONG, 0, r_.solver.comm());
    std::vector<std::array<long, 3>> rows;
    for (std::size_t k = 0; k + 2 < all.size(); k += 3) rows.push_back({all[k], all[k + 1], all[k + 2]});
    std::sort(rows.begin(), rows.end());
    broken.clear();
    for (const auto& r : rows) broken.insert(broken.end(), r.begin(), r.end());
  }
  if (!r_.root) return;
  const std::string path = (std::filesystem::path(out_.folder) / "broken_ce6.csv").string();
  std::ofstream o(path);
  o << "ce6,mode,joint\n";
  for (std::size_t k = 0; k + 2 < broken.size(); k += 3)
    o << broken[k] << ',' << broken[k + 1] << ','
      << (broken[k + 2] < 0 ? "" : csv_field(scene_.joints[broken[k + 2]].name)) << '\n';
  if (!o) throw OutputError("cannot write " + path);
}

RunSummary RunSession::finish() {
  namespace fs = std::filesystem;
  r_.csv.f.close();
  if (!r_.csv.f) throw OutputError("cannot write " + r_.csv_path + ": " + write_failure(r_.csv_path, errno));
  write_frame(*r_.fields, r_.solver, "final");
  r_.sum.steps = r_.solver.step_count();
  r_.sum.time = r_.solver.time();
  r_.sum.wall_seconds = r_.wall_before + r_.elapsed();
  r_.sum.last = r_.row;
  {
    std::vector<std::array<Vec3, 3>> faces;
    std::vector<int> mode;
    r_.solver.broken_faces(faces, mode);
    r_.sum.fracture = fracture_pattern(faces, mode, {0, 0, 1});
  }
  if (out_.plot && r_.root) {
    const std::string png = (fs::path(out_.folder) / "stress_strain.png").string();
    if (!run_python_script("plot_curves.py", {r_.csv_path, png, "--title=" + scene_.name}))
      r_.log << "warning: could not plot " << png << " (needs python3-matplotlib); the curves are in " << r_.csv_path
             << std::endl;
  }
  write_broken_ce6();
  if (r_.root) write_summary((fs::path(out_.folder) / "summary.csv").string(), scene_, r_.sum);
  return r_.sum;
}

}  // namespace

RunSummary run_scene(Solver& solver, std::ostream& log, const RunOptions& options) {
  RunSession run(solver, log, options);
  const SignalGuard signals;
  run.start();
  run.loop();
  return run.finish();
}

}  // namespace fdem
