#include "solver/run_observers.hpp"

#include <mpi.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"

namespace fdem {

// Checkpoint requests from signals: 1 = SIGUSR1 (write one, go on), 2 = SIGTERM or SIGINT (write
// one, stop). The handler only raises the value (lock-free atomics are async-signal-safe); the
// checkpoints take it after every step, and a series looks at it between runs.
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

real end_progress(const EndCondition& end, long step, real time, real axial_strain, real peak, real stress) {
  real p = 0;
  if (end.steps > 0) p = std::max(p, real(step) / real(end.steps));
  if (end.time > 0) p = std::max(p, time / end.time);
  if (end.axial_strain > 0) p = std::max(p, axial_strain / end.axial_strain);
  if (end.post_peak_fraction > 0 && end.post_peak_fraction < 1 && peak > 0 && stress < peak)
    p = std::max(p, (peak - stress) / (peak * (1 - end.post_peak_fraction)));
  return std::min(p, real(1));
}

RunRecord::RunRecord(Solver& s, std::ostream& l)
    : solver(s), log(l), out(s.scene().output), dist(s.distributed()), root(s.rank() == 0) {
  sum.folder = out.folder;
  csv_path = root ? (std::filesystem::path(out.folder) / "monitors.csv").string() : "/dev/null";
}

real RunRecord::elapsed() const {
  return std::chrono::duration<real>(std::chrono::steady_clock::now() - t0).count();
}

real RunRecord::axial_strain() const {
  return solver.platen_travel() / solver.model().height0;
}

void RunRecord::flush_csv() {
  csv.f.flush();
  if (!csv.f) throw OutputError("cannot write " + csv_path + ": " + write_failure(csv_path, errno));
}

void RunRecord::save(CheckpointOut& o) const {
  o.put(row);
  o.put(sum.peak_stress);
  o.put(sum.strain_at_peak);
  o.put(sum.peak_indirect_tensile);
  o.put(peak_written);
  peak_frames.save(o);
  o.put(wall_before + elapsed());
  o.put(csv.bytes);
  o.put(csv.hash);
  const FieldWriterState st = fields->state();
  o.put(st.grids);
  o.put(st.labels);
  o.put(st.mesh_tets);
  o.put(st.have_mesh);
}

void RunRecord::load(CheckpointIn& in, FieldWriterState& fields_state) {
  in.get(row);
  in.get(sum.peak_stress);
  in.get(sum.strain_at_peak);
  in.get(sum.peak_indirect_tensile);
  in.get(peak_written);
  peak_frames.load(in);
  in.get(wall_before);
  in.get(csv.bytes);
  in.get(csv.hash);
  in.get(fields_state.grids);
  in.get(fields_state.labels);
  in.get(fields_state.mesh_tets);
  in.get(fields_state.have_mesh);
}

void RunRecord::take_saved(const RunRecord& saved) {
  row = saved.row;
  sum.peak_stress = saved.sum.peak_stress;
  sum.strain_at_peak = saved.sum.strain_at_peak;
  sum.peak_indirect_tensile = saved.sum.peak_indirect_tensile;
  peak_written = saved.peak_written;
  wall_before = saved.wall_before;
  csv.bytes = saved.csv.bytes;
  csv.hash = saved.csv.hash;
}

void MonitorRows::record() {
  r_.row = r_.solver.measure();
  r_.csv.put(monitor_row(r_.row, r_.solver));
  notes();
  r_.flush_csv();
  follow_peak();
}

/// The device's note when its contact pair buffers grew, and the contact ghosts' when they were
/// gathered again. (The cpu backend allocates as it needs, like any host code: no note.)
void MonitorRows::notes() {
  const Solver& s = r_.solver;
  const DeviceLoop* d = s.device_loop();
  if (s.backend() != Backend::cpu && d->times().pair_growth != pair_growth_seen_) {
    pair_growth_seen_ = d->times().pair_growth;  // the buffers grow by half each time
    r_.log << "device: contact pair buffers grew to hold " << r_.row.contact_pairs << " pairs (device memory "
           << fmt(double(device::bytes_in_use()) / 1e6, 4) << " MB)" << std::endl;
  }
  if (const GhostGrowths& g = s.ghost_growths(); g.count != growths_seen_.count) {
    r_.log << "contact ghosts: gathered again " << g.count - growths_seen_.count << " time(s) by step " << g.step
           << " (a node had moved a quarter of the contact reach " << s.decomposition().reach << " m), "
           << g.tets - growths_seen_.tets << " tets added to the rank models ("
           << fmt(g.seconds - growths_seen_.seconds, 3) << " s)" << std::endl;
    growths_seen_ = g;
  }
}

/// The peak so far; once the stress has fallen 5 % below it, the fracture pattern before, at and
/// just after it.
void MonitorRows::follow_peak() {
  const Monitors& m = r_.row;
  RunSummary& sum = r_.sum;
  if (m.axial_stress > sum.peak_stress) {
    sum.peak_stress = m.axial_stress;
    sum.strain_at_peak = m.axial_strain;
    sum.peak_indirect_tensile = m.indirect_tensile;
    r_.peak_written = false;
    if (r_.out.peak_frames) r_.peak_frames.observe(r_.solver, m.axial_stress);
  } else if (!r_.peak_written && sum.peak_stress > 0 && m.axial_stress < 0.95 * sum.peak_stress) {
    r_.peak_written = true;
    if (r_.out.peak_frames)
      r_.peak_frames.write(*r_.fields, r_.solver);
    else
      write_frame(*r_.fields, r_.solver, "post-peak");
  }
}

std::string EndCheck::reason(bool monitor_row) const {
  const Solver& s = r_.solver;
  const long n = s.step_count();
  std::string why;
  if (end_.steps > 0 && n >= end_.steps) why = "step count " + std::to_string(end_.steps) + " reached";
  if (end_.time > 0 && s.time() >= end_.time) why = "end time reached";
  if (end_.axial_strain > 0 && r_.axial_strain() >= end_.axial_strain) why = "axial strain reached";
  if (monitor_row && end_.post_peak_fraction > 0 && r_.sum.peak_stress > 0 &&
      r_.row.axial_stress < end_.post_peak_fraction * r_.sum.peak_stress)
    why = "stress fell below " + std::to_string(end_.post_peak_fraction) + " of the peak";
  return why;
}

ProgressLine::ProgressLine(RunRecord& r) : r_(r), next_(r.out.progress_interval), first_step_(r.solver.step_count()) {
  progress0_ = end_progress(r.solver.scene().solver.end, first_step_, r.solver.time(), r.axial_strain(),
                            r.sum.peak_stress, r.row.axial_stress);
}

void ProgressLine::after_step(StepEvent& e) {
  const real wall = r_.elapsed();
  if (e.end.empty() && !(r_.out.progress_interval > 0 && wall >= next_)) return;
  const Solver& s = r_.solver;
  const real strain = r_.axial_strain();
  const real done =
      end_progress(s.scene().solver.end, e.step, s.time(), strain, r_.sum.peak_stress, r_.row.axial_stress) -
      progress0_;
  const real rate = (e.step - first_step_) / std::max(wall, real(1e-9));
  char line[256];
  std::snprintf(line, sizeof line,
                "step %ld  t %.4g s  axial strain %.3e  stress %.3f MPa  broken CE6 %ld  %.0f steps/s  ETA %s", e.step,
                s.time(), strain, r_.row.axial_stress / 1e6, r_.row.broken, rate,
                !e.end.empty() ? "done"
                : done > 0     ? duration(wall * (1 - done - progress0_) / done).c_str()
                               : "?");
  r_.log << line << std::endl;
  next_ = wall + r_.out.progress_interval;
}

std::string Checkpoints::write(const std::string& why) {
  namespace fs = std::filesystem;
  r_.flush_csv();
  sync_path(r_.csv_path);
  sync_path(r_.fields->h5_path());
  std::error_code ec;
  fs::create_directories(folder_, ec);
  char name[48];
  std::snprintf(name, sizeof name, "step_%012ld", r_.solver.step_count());
  const std::string path = (fs::path(folder_) / (name + suffix_)).string();
  CheckpointFile file(path);  // (written as it is put: the rank holds no copy of its state)
  r_.solver.save(file.out());
  r_.save(file.out());
  file.commit();
  sync_path(folder_);
  prune_checkpoints(folder_, 2, suffix_);
  last_wall_ = r_.elapsed();
  r_.log << "checkpoint (" << why << "): " << path << std::endl;
  return path;
}

/// Several ranks agree on signals and on rank 0's wall clock at monitor rows (one reduction
/// there), so that all write the same step.
void Checkpoints::due(const StepEvent& e) {
  const OutputSettings& out = r_.out;
  const real wall = r_.elapsed();
  int request = std::max(pending_request_, g_signal_request.exchange(0));
  bool wall_due = out.checkpoint_wall_interval > 0 && wall - last_wall_ >= out.checkpoint_wall_interval;
  if (r_.dist) {
    if (!e.monitor_row) {
      pending_request_ = request;
      request = 0;
      wall_due = false;
    } else {
      int v[2] = {request, r_.root && wall_due};
      MPI_Allreduce(MPI_IN_PLACE, v, 2, MPI_INT, MPI_MAX, r_.solver.comm());
      request = v[0];
      wall_due = v[1] != 0;
      pending_request_ = 0;
    }
  }
  if (request == 2) {
    const std::string path = write("signal");
    throw Interrupted("stopped by a signal at step " + std::to_string(e.step) + " after writing " + path);
  }
  std::string why;
  if (request == 1)
    why = "SIGUSR1";
  else if (out.checkpoint_interval > 0 && e.step % out.checkpoint_interval == 0)
    why = "every " + std::to_string(out.checkpoint_interval) + " steps";
  else if (wall_due)
    why = "wall-time interval";
  if (why.empty()) return;
  // A checkpoint that cannot be written (disk full, folder gone) does not end the run: the run
  // goes on and tries again at the next one.
  try {
    write(why);
  } catch (const OutputError& ex) {
    last_wall_ = r_.elapsed();
    r_.log << "warning: checkpoint (" << why << ") not written, the run goes on: " << ex.what() << std::endl;
  }
}

}  // namespace fdem
