#include "solver/run.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
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

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/fields.hpp"
#include "io/run_lock.hpp"
#include "solver/frames.hpp"
#include "solver/run_folder.hpp"

namespace fdem {

namespace {

/// A wall time for the progress line: "42s", "3m05s" or "2h07m"; "?" when not known.
std::string duration(real s) {
  if (!std::isfinite(s) || s < 0) return "?";
  char b[32];
  if (s < 60)
    std::snprintf(b, sizeof b, "%.0fs", s);
  else if (s < 3600)
    std::snprintf(b, sizeof b, "%dm%02ds", int(s / 60), int(s) % 60);
  else
    std::snprintf(b, sizeof b, "%dh%02dm", int(s / 3600), int(s / 60) % 60);
  return b;
}

}  // namespace

// Checkpoint requests from signals: 1 = SIGUSR1 (write one, go on), 2 = SIGTERM or SIGINT (write
// one, stop). The handler only raises the value (lock-free atomics are async-signal-safe); the
// time loop takes it after every step, and a series looks at it between runs.
namespace {
std::atomic<int> g_signal_request{0};
static_assert(std::atomic<int>::is_always_lock_free, "the signal flag must be lock-free");

extern "C" void on_checkpoint_signal(int sig) {
  if (sig != SIGUSR1) {
    g_signal_request.store(2);
  } else {
    int none = 0;
    g_signal_request.compare_exchange_strong(none, 1);
  }
}
}  // namespace

SignalGuard::SignalGuard() {
  struct sigaction sa {};
  sa.sa_handler = on_checkpoint_signal;
  sigemptyset(&sa.sa_mask);
  for (int sig : kSignals) sigaddset(&sa.sa_mask, sig);
  sa.sa_flags = SA_RESTART;
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &sa, &old_[i]);
}

SignalGuard::~SignalGuard() {
  for (int i = 0; i < 3; ++i) sigaction(kSignals[i], &old_[i], nullptr);
}

bool stop_requested() {
  return g_signal_request.load() == 2;
}

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

real end_progress(const EndCondition& end, long step, real time, real axial_strain, real peak, real stress) {
  real p = 0;
  if (end.steps > 0) p = std::max(p, real(step) / real(end.steps));
  if (end.time > 0) p = std::max(p, time / end.time);
  if (end.axial_strain > 0) p = std::max(p, axial_strain / end.axial_strain);
  if (end.post_peak_fraction > 0 && end.post_peak_fraction < 1 && peak > 0 && stress < peak)
    p = std::max(p, (peak - stress) / (peak * (1 - end.post_peak_fraction)));
  return std::min(p, real(1));
}

namespace {

/// One run of run_scene: its folder and files, what the loop carries from step to step, and each
/// thing done between steps as a method of its own.
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
  std::string end_reason(bool monitor_now) const;
  real elapsed() const { return std::chrono::duration<real>(std::chrono::steady_clock::now() - t0_).count(); }
  void open_folder();
  std::vector<std::string> restart_candidates() const;
  std::string load_checkpoint(const std::string& file, FieldWriterState& fields_state);
  void restart();
  void replace_earlier_run();
  void merge_index();
  std::string checkpoint(const std::string& why);
  void record_monitor_row();
  void progress(const std::string& reason);
  void checkpoints_due(bool monitor_now);
  void write_broken_ce6() const;

  Solver& solver_;
  std::ostream& log_;
  const RunOptions options_;
  const Scene& scene_;
  const OutputSettings& out_;
  const EndCondition& end_;
  // Several ranks: rank 0 writes the monitors and the summary, every rank its own field files.
  const bool dist_, root_;
  std::string csv_path_, ckpt_dir_, fields_name_, suffix_;
  std::unique_ptr<RunLock> lock_;
  // What the loop carries from step to step, besides the solver.
  RunSummary sum_;
  Monitors mon_;
  bool peak_written_ = false;
  PeakFrames peak_frames_;
  real wall_before_ = 0;  // s, spent by the run before the checkpoint it continues from
  MonitorFile csv_;
  std::unique_ptr<FieldWriter> fields_;
  int merged_frames_ = 0;  // several ranks: frames in the merged index
  long field_interval_ = 1;
  std::chrono::steady_clock::time_point t0_;
  real next_progress_ = 0, last_checkpoint_wall_ = 0;
  long first_step_ = 0;
  real progress0_ = 0;         // end_progress where this session starts
  long pair_growth_seen_ = 0;  // device backends: growths of the contact pair buffers reported
  GhostGrowths growths_seen_;  // several ranks: contact ghosts gathered again
  int pending_request_ = 0;    // several ranks: a signal waits for the next monitor row
};

RunSession::RunSession(Solver& solver, std::ostream& log, const RunOptions& options)
    : solver_(solver),
      log_(log),
      options_(options),
      scene_(solver.scene()),
      out_(scene_.output),
      end_(scene_.solver.end),
      dist_(solver.distributed()),
      root_(solver.rank() == 0) {
  namespace fs = std::filesystem;
  sum_.folder = out_.folder;
  csv_path_ = root_ ? (fs::path(out_.folder) / "monitors.csv").string() : "/dev/null";
  ckpt_dir_ = (fs::path(out_.folder) / "checkpoints").string();
  fields_name_ = dist_ ? "fields_rank" + std::to_string(solver.rank()) : "fields";
  suffix_ = checkpoint_suffix(solver.rank(), dist_ ? solver.decomposition().size : 1);
  open_folder();
  if (!options_.restart.empty())
    restart();
  else
    replace_earlier_run();
  if (!csv_.f) throw InputError(scene_.file + ": output.folder: cannot write '" + csv_path_ + "'");
  if (!fields_) {
    csv_.put(monitors_header());
    fields_ = std::make_unique<FieldWriter>(out_.folder, fields_name_);
  }
  // Several ranks: the merged index after every change of the frames (collective); at once
  // after a restart, which may have dropped frames.
  merged_frames_ = options_.restart.empty() ? 0 : -1;
  merge_index();
  // The automatic field interval: about 20 frames over the steps the end takes.
  const real end_steps = solver_.end_steps().steps;
  const real expected = std::isfinite(end_steps) ? end_steps : 0;
  field_interval_ = out_.field_interval > 0 ? out_.field_interval : std::max<long>(1, long(expected / 20));
  t0_ = std::chrono::steady_clock::now();
  next_progress_ = out_.progress_interval;
  first_step_ = solver_.step_count();
  progress0_ = end_progress(end_, first_step_, solver_.time(), solver_.platen_travel() / solver_.model().height0,
                            sum_.peak_stress, mon_.axial_stress);
  growths_seen_ = solver_.ghost_growths();
}

bool RunSession::all_ranks(bool ok) const {
  if (!dist_) return ok;
  int v = ok;
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_MIN, solver_.comm());
  return v != 0;
}

std::string RunSession::end_reason(bool monitor_now) const {
  const long n = solver_.step_count();
  const real strain = solver_.platen_travel() / solver_.model().height0;
  std::string reason;
  if (end_.steps > 0 && n >= end_.steps) reason = "step count " + std::to_string(end_.steps) + " reached";
  if (end_.time > 0 && solver_.time() >= end_.time) reason = "end time reached";
  if (end_.axial_strain > 0 && strain >= end_.axial_strain) reason = "axial strain reached";
  if (monitor_now && end_.post_peak_fraction > 0 && sum_.peak_stress > 0 &&
      mon_.axial_stress < end_.post_peak_fraction * sum_.peak_stress)
    reason = "stress fell below " + std::to_string(end_.post_peak_fraction) + " of the peak";
  return reason;
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
    lock_ = lock_run_folder(out_.folder, solver_, log_);
}

/// The checkpoints to restart from, newest first. Several ranks: rank 0's steps are the
/// candidates, and each rank's file of each ("" where it has none).
std::vector<std::string> RunSession::restart_candidates() const {
  std::vector<std::string> found = find_checkpoints(options_.restart, suffix_);
  auto step_of = [](const std::string& file) {
    const std::string name = std::filesystem::path(file).filename().string();
    return name.rfind("step_", 0) == 0 ? std::atol(name.c_str() + 5) : -1L;
  };
  if (dist_) {
    std::vector<long> steps;
    for (const std::string& f : found) steps.push_back(step_of(f));
    long n = long(steps.size());
    MPI_Bcast(&n, 1, MPI_LONG, 0, solver_.comm());
    steps.resize(n);
    MPI_Bcast(steps.data(), int(n), MPI_LONG, 0, solver_.comm());
    std::vector<std::string> mine;
    for (long st : steps) {
      std::string file;
      for (const std::string& f : found)
        if (step_of(f) == st) file = f;
      mine.push_back(file);
    }
    found.swap(mine);
  }
  if (found.empty())
    throw InputError("--restart " + options_.restart + ": no checkpoint there (files checkpoints/step_<n>" + suffix_ +
                     "). Fix: give the output folder of the interrupted run" +
                     (dist_ ? " and run it on as many ranks as it had" : " or one of its .ckpt files"));
  return found;
}

/// Loads a checkpoint into the solver and the session; returns why it cannot be used ("" where
/// it can): damaged, or its monitors.csv or fields file is not the one in this folder.
std::string RunSession::load_checkpoint(const std::string& file, FieldWriterState& fields_state) {
  namespace fs = std::filesystem;
  if (file.empty()) return "rank " + std::to_string(solver_.rank()) + " has no file of the step rank 0 has";
  std::optional<CheckpointIn> in;
  try {
    in.emplace(read_checkpoint(file));
  } catch (const CannotOpen& e) {
    // Not damaged, only unreadable: falling back would drop its rows and remove it.
    throw InputError("--restart " + options_.restart + ": " + e.what() + "; nothing was changed");
  } catch (const InputError& e) {
    return e.what();
  }
  solver_.load(*in);
  in->get(mon_);
  in->get(sum_.peak_stress);
  in->get(sum_.strain_at_peak);
  in->get(sum_.peak_indirect_tensile);
  in->get(peak_written_);
  peak_frames_.load(*in);
  in->get(wall_before_);
  in->get(csv_.bytes);
  in->get(csv_.hash);
  in->get(fields_state.grids);
  in->get(fields_state.labels);
  in->get(fields_state.mesh_tets);
  in->get(fields_state.have_mesh);
  in->finish();
  std::uint64_t hash = 0;
  std::error_code ec;
  const fs::path h5 = fs::path(out_.folder) / (fields_name_ + ".h5");
  const std::string back =
      ". Fix: put back the monitors.csv the run wrote, or restart in the interrupted run's folder (output.folder or "
      "-o)";
  if (root_ && !fs::is_regular_file(csv_path_, ec)) return file + ": " + csv_path_ + " is missing" + back;
  if (root_ && !hash_prefix(csv_path_, csv_.bytes, hash))
    return file + ": " + csv_path_ + " holds " + std::to_string(fs::file_size(csv_path_, ec)) +
           " bytes, fewer than the " + std::to_string(csv_.bytes) +
           " it held at this checkpoint (cut short, or another run's)" + back;
  if (root_ && hash != csv_.hash)
    return file + ": " + csv_path_ + " differs in its first " + std::to_string(csv_.bytes) +
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
  const std::vector<std::string> found = restart_candidates();
  std::string problems;
  for (std::size_t k = 0; k < found.size(); ++k) {
    const std::string& file = found[k];
    FieldWriterState fields_state;
    std::string why = load_checkpoint(file, fields_state);
    if (!all_ranks(why.empty())) {
      if (why.empty()) why = (file.empty() ? "step " : file + ": ") + std::string("another rank cannot use its file");
      if (dist_ && !root_) why = "rank " + std::to_string(solver_.rank()) + ": " + why;
      (root_ ? log_ : std::cerr) << "warning: " << why << std::endl;
      problems += "\n  " + why;
      continue;
    }
    // A scene whose end was moved before the checkpoint: the loop would take one step more
    // and stop, after the rows and frames past the checkpoint had been dropped.
    if (const std::string reason = end_reason(true); !reason.empty())
      throw InputError("--restart " + options_.restart + ": " + file + " is at step " +
                       std::to_string(solver_.step_count()) + ", t = " + fmt(solver_.time(), 6) +
                       " s, where the scene's end is already reached (" + reason +
                       "); nothing was changed. Fix: move solver.end in " + scene_.file +
                       " past it to continue the run, or run without --restart to start again");
    fields_ = std::make_unique<FieldWriter>(out_.folder, fields_name_, fields_state);
    if (!fields_->repaired().empty()) (root_ ? log_ : std::cerr) << "warning: " << fields_->repaired() << std::endl;
    std::error_code ec;
    if (root_) {
      fs::resize_file(csv_path_, csv_.bytes, ec);
      if (ec) throw OutputError("cannot truncate " + csv_path_ + ": " + ec.message());
    }
    csv_.f.open(csv_path_, std::ios::app);
    for (std::size_t j = 0; j < k; ++j)
      if (!found[j].empty() && fs::path(found[j]).parent_path() == fs::path(file).parent_path())
        fs::remove(found[j], ec);
    log_ << "restart: continuing from " << file << (dist_ ? " (and the other ranks' files of that step)" : "")
         << " at step " << solver_.step_count() << ", t = " << solver_.time() << " s" << std::endl;
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
  std::vector<std::string> names{fields_name_ + ".h5", fields_name_ + ".xdmf"};
  if (root_)
    names.insert(names.end(), {"monitors.csv", "summary.csv", "broken_ce6.csv", "stress_strain.png", "checkpoints"});
  if (root_ && dist_) names.push_back("fields.xdmf");  // the merged index of the ranks' files
  const std::string problem = replace_problem(out_.folder, names);
  if (!all_ranks(problem.empty()))
    throw OutputError(("the run cannot replace the outputs of an earlier one: " +
                       (problem.empty() ? "another rank found one in the way" : problem)) +
                      "; nothing was changed. Fix: move it away, or give the run another output folder (-o)");
  if (root_) {
    std::error_code ec;
    fs::remove_all(ckpt_dir_, ec);
    for (const char* stale : {"summary.csv", "broken_ce6.csv", "stress_strain.png"})
      fs::remove(fs::path(out_.folder) / stale, ec);
  }
  csv_.f.open(csv_path_);
}

void RunSession::merge_index() {
  if (!dist_ || fields_->frames() == merged_frames_) return;
  write_merged_index(*fields_, solver_, out_.folder);
  merged_frames_ = fields_->frames();
}

/// Writes a checkpoint of this step (the files it refers to reach the disk first); its path.
std::string RunSession::checkpoint(const std::string& why) {
  namespace fs = std::filesystem;
  csv_.f.flush();
  if (!csv_.f) throw OutputError("cannot write " + csv_path_ + ": " + write_failure(csv_path_, errno));
  sync_path(csv_path_);
  sync_path(fields_->h5_path());
  std::error_code ec;
  fs::create_directories(ckpt_dir_, ec);
  CheckpointOut o;
  solver_.save(o);
  o.put(mon_);
  o.put(sum_.peak_stress);
  o.put(sum_.strain_at_peak);
  o.put(sum_.peak_indirect_tensile);
  o.put(peak_written_);
  peak_frames_.save(o);
  o.put(wall_before_ + elapsed());
  o.put(csv_.bytes);
  o.put(csv_.hash);
  const FieldWriterState st = fields_->state();
  o.put(st.grids);
  o.put(st.labels);
  o.put(st.mesh_tets);
  o.put(st.have_mesh);
  char name[48];
  std::snprintf(name, sizeof name, "step_%012ld", solver_.step_count());
  const std::string path = (fs::path(ckpt_dir_) / (name + suffix_)).string();
  write_checkpoint(path, o);
  sync_path(ckpt_dir_);
  prune_checkpoints(ckpt_dir_, 2, suffix_);
  last_checkpoint_wall_ = elapsed();
  log_ << "checkpoint (" << why << "): " << path << std::endl;
  return path;
}

void RunSession::start() {
  if (!options_.restart.empty()) return;
  mon_ = solver_.measure();
  csv_.put(monitor_row(mon_, solver_));
  write_frame(*fields_, solver_, "initial");
  merge_index();
}

/// A monitor row: measured, to monitors.csv, the device's and the ghosts' notes, and the frames
/// of the peak once the stress has fallen 5 % below it.
void RunSession::record_monitor_row() {
  mon_ = solver_.measure();
  csv_.put(monitor_row(mon_, solver_));
  // (The cpu backend allocates as it needs, like any host code: no note.)
  const DeviceLoop* d = solver_.device_loop();
  if (solver_.backend() != Backend::cpu && d->times().pair_growth != pair_growth_seen_) {
    pair_growth_seen_ = d->times().pair_growth;  // the buffers grow by half each time
    log_ << "device: contact pair buffers grew to hold " << mon_.contact_pairs << " pairs (device memory "
         << fmt(double(device::bytes_in_use()) / 1e6, 4) << " MB)" << std::endl;
  }
  if (const GhostGrowths& g = solver_.ghost_growths(); g.count != growths_seen_.count) {
    log_ << "contact ghosts: gathered again " << g.count - growths_seen_.count << " time(s) by step " << g.step
         << " (a node had moved a quarter of the contact reach " << solver_.decomposition().reach << " m), "
         << g.tets - growths_seen_.tets << " tets added to the rank models ("
         << fmt(g.seconds - growths_seen_.seconds, 3) << " s)" << std::endl;
    growths_seen_ = g;
  }
  csv_.f.flush();
  if (!csv_.f) throw OutputError("cannot write " + csv_path_ + ": " + write_failure(csv_path_, errno));
  if (mon_.axial_stress > sum_.peak_stress) {
    sum_.peak_stress = mon_.axial_stress;
    sum_.strain_at_peak = mon_.axial_strain;
    sum_.peak_indirect_tensile = mon_.indirect_tensile;
    peak_written_ = false;
    if (out_.peak_frames) peak_frames_.observe(solver_, mon_.axial_stress);
  } else if (!peak_written_ && sum_.peak_stress > 0 && mon_.axial_stress < 0.95 * sum_.peak_stress) {
    // The peak has passed: the fracture pattern before, at and just after it.
    peak_written_ = true;
    if (out_.peak_frames)
      peak_frames_.write(*fields_, solver_);
    else
      write_frame(*fields_, solver_, "post-peak");
  }
}

/// The progress line, every output.progress_interval s of wall time and at the end. The ETA
/// extrapolates the progress made since this session started at the pace so far.
void RunSession::progress(const std::string& reason) {
  const real wall = elapsed();
  if (reason.empty() && !(out_.progress_interval > 0 && wall >= next_progress_)) return;
  const long n = solver_.step_count();
  const real strain = solver_.platen_travel() / solver_.model().height0;
  const real done = end_progress(end_, n, solver_.time(), strain, sum_.peak_stress, mon_.axial_stress) - progress0_;
  const real rate = (n - first_step_) / std::max(wall, real(1e-9));
  char line[256];
  std::snprintf(line, sizeof line,
                "step %ld  t %.4g s  axial strain %.3e  stress %.3f MPa  broken CE6 %ld  %.0f steps/s  ETA %s", n,
                solver_.time(), strain, mon_.axial_stress / 1e6, mon_.broken, rate,
                !reason.empty() ? "done"
                : done > 0      ? duration(wall * (1 - done - progress0_) / done).c_str()
                                : "?");
  log_ << line << std::endl;
  next_progress_ = wall + out_.progress_interval;
}

/// Checkpoints: by steps, by wall time, or asked for by a signal (SIGTERM and SIGINT: then the
/// run stops, Interrupted). Several ranks agree on signals and on rank 0's wall clock at monitor
/// rows (one reduction there), so that all write the same step.
void RunSession::checkpoints_due(bool monitor_now) {
  const long n = solver_.step_count();
  const real wall = elapsed();
  int request = std::max(pending_request_, g_signal_request.exchange(0));
  bool wall_due = out_.checkpoint_wall_interval > 0 && wall - last_checkpoint_wall_ >= out_.checkpoint_wall_interval;
  if (dist_) {
    if (!monitor_now) {
      pending_request_ = request;
      request = 0;
      wall_due = false;
    } else {
      int v[2] = {request, root_ && wall_due};
      MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_INT, MPI_MAX, solver_.comm());
      request = v[0];
      wall_due = v[1] != 0;
      pending_request_ = 0;
    }
  }
  if (request == 2) {
    const std::string path = checkpoint("signal");
    throw Interrupted("stopped by a signal at step " + std::to_string(n) + " after writing " + path);
  }
  std::string why;
  if (request == 1)
    why = "SIGUSR1";
  else if (out_.checkpoint_interval > 0 && n % out_.checkpoint_interval == 0)
    why = "every " + std::to_string(out_.checkpoint_interval) + " steps";
  else if (wall_due)
    why = "wall-time interval";
  if (why.empty()) return;
  // A checkpoint that cannot be written (disk full, folder gone) does not end the run: the run
  // goes on and tries again at the next one.
  try {
    checkpoint(why);
  } catch (const OutputError& e) {
    last_checkpoint_wall_ = elapsed();
    log_ << "warning: checkpoint (" << why << ") not written, the run goes on: " << e.what() << std::endl;
  }
}

void RunSession::loop() {
  try {
    for (;;) {
      solver_.step();
      const long n = solver_.step_count();
      const bool monitor_now = n % out_.monitor_interval == 0;
      if (monitor_now) record_monitor_row();
      if (n % field_interval_ == 0) write_frame(*fields_, solver_, "");
      merge_index();
      const std::string reason = end_reason(monitor_now);
      progress(reason);
      if (!reason.empty()) {
        sum_.end_reason = reason;
        break;
      }
      checkpoints_due(monitor_now);
    }
    mon_ = solver_.measure();
    if (solver_.step_count() % out_.monitor_interval != 0) csv_.put(monitor_row(mon_, solver_));
  } catch (const RunError&) {
    write_diagnostic(*fields_, solver_);
    throw;
  }
}

/// broken_ce6.csv: the broken CE6s by global id and mode (the fracture pattern, for comparisons
/// such as fdem study). Several ranks send theirs (owned ones) to rank 0.
void RunSession::write_broken_ce6() const {
  std::vector<long> broken;  // id, mode
  solver_.sync_host();
  for (std::size_t i = 0; i < solver_.state.ce6.size(); ++i)
    if (solver_.state.ce6.damage[i].mode != 0 && solver_.owned_ce6()[i])
      broken.insert(broken.end(),
                    {dist_ ? solver_.decomposition().ce6_global[i] : long(i), long(solver_.state.ce6.damage[i].mode)});
  if (dist_) {
    const int size = solver_.decomposition().size;
    int len = int(broken.size());
    std::vector<int> lens(size), offs(size + 1, 0);
    MPI_Gather(&len, 1, MPI_INT, lens.data(), 1, MPI_INT, 0, solver_.comm());
    for (int r = 0; r < size; ++r) offs[r + 1] = offs[r] + lens[r];
    std::vector<long> all(root_ ? offs[size] : 0);
    MPI_Gatherv(broken.data(), len, MPI_LONG, all.data(), lens.data(), offs.data(), MPI_LONG, 0, solver_.comm());
    std::vector<std::array<long, 2>> rows;
    for (std::size_t k = 0; k + 1 < all.size(); k += 2) rows.push_back({all[k], all[k + 1]});
    std::sort(rows.begin(), rows.end());
    broken.clear();
    for (const auto& r : rows) broken.insert(broken.end(), {r[0], r[1]});
  }
  if (!root_) return;
  const std::string path = (std::filesystem::path(out_.folder) / "broken_ce6.csv").string();
  std::ofstream o(path);
  o << "ce6,mode\n";
  for (std::size_t k = 0; k + 1 < broken.size(); k += 2) o << broken[k] << ',' << broken[k + 1] << '\n';
  if (!o) throw OutputError("cannot write " + path);
}

RunSummary RunSession::finish() {
  namespace fs = std::filesystem;
  csv_.f.close();
  if (!csv_.f) throw OutputError("cannot write " + csv_path_ + ": " + write_failure(csv_path_, errno));
  write_frame(*fields_, solver_, "final");
  merge_index();
  sum_.steps = solver_.step_count();
  sum_.time = solver_.time();
  sum_.wall_seconds = wall_before_ + elapsed();
  sum_.last = mon_;
  {
    std::vector<std::array<Vec3, 3>> faces;
    std::vector<int> mode;
    solver_.broken_faces(faces, mode);
    sum_.fracture = fracture_pattern(faces, mode, {0, 0, 1});
  }
  if (out_.plot && root_) {
    const std::string png = (fs::path(out_.folder) / "stress_strain.png").string();
    if (!run_python_script("plot_curves.py", {csv_path_, png, "--title=" + scene_.name}))
      log_ << "warning: could not plot " << png << " (needs python3-matplotlib); the curves are in " << csv_path_
           << std::endl;
  }
  write_broken_ce6();
  if (root_) write_summary((fs::path(out_.folder) / "summary.csv").string(), scene_, sum_);
  return sum_;
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
