#pragma once
// A whole run from a scene: build, time loop, monitors to CSV, ParaView frames,
// progress lines, the end condition and the final plot.
#include <csignal>
#include <iosfwd>
#include <string>
#include <vector>

#include "analysis/fracture_pattern.hpp"
#include "solver/solver.hpp"

namespace fdem {

struct RunSummary {
  long steps = 0;
  real time = 0;  // simulated, s
  real wall_seconds = 0;
  real peak_stress = 0;  // Pa
  real strain_at_peak = 0;
  real peak_indirect_tensile = 0;  // Pa, 2 P / (pi D t) at the peak of a line-loaded disc, else 0
  Monitors last;
  FracturePattern fracture;  // broken CE6s at the end: modes and the main failure plane
  std::string end_reason;
  std::string folder;
};

struct RunOptions {
  /// Continue from a checkpoint: a checkpoint file, a run's output folder or its checkpoints/
  /// folder (the newest readable checkpoint is used). Empty: start from step 0.
  std::string restart;
  /// The caller holds the output folder's lock (RunLock) already, as a series does for each of
  /// its runs; otherwise run_scene takes it (rank 0, for every rank).
  bool folder_locked = false;
};

/// One line per quantity: counts, the minimum altitude, the stable step and what limits it.
void report_model(const Solver& solver, std::ostream& out);

/// Run the solver to the scene's end condition, holding the lock of the output folder
/// (io/run_lock.hpp: a second run into it is refused with InputError, nothing written there),
/// writing <folder>/monitors.csv, <folder>/fields.{h5,xdmf}, <folder>/stress_strain.png and,
/// last and atomically, <folder>/summary.csv (one row: kSummaryHeader, solver/run_folder.hpp),
/// whose presence marks a finished run. Rethrows RunError after writing the monitor row and a
/// field frame labelled "diagnostic" where possible.
///
/// Checkpoints go to <folder>/checkpoints/step_<n>.ckpt (the last two are kept) every
/// output.checkpoint_interval steps, every output.checkpoint_wall_interval seconds of wall time,
/// on SIGUSR1 (the run goes on) and on SIGTERM or SIGINT (the run then stops with Interrupted).
/// With options.restart the run continues from a checkpoint in the same output folder: the
/// monitor rows and field frames written after it are dropped and written again, so the
/// continued run's files equal an uninterrupted run's (bit for bit on the CPU backend with the
/// same thread count).
RunSummary run_scene(Solver& solver, std::ostream& log, const RunOptions& options = {});

/// Installs fdem's handlers of SIGTERM, SIGINT (checkpoint, then stop) and SIGUSR1 (checkpoint,
/// go on) for its lifetime and puts the earlier ones back; run_scene and series hold one.
class SignalGuard {
 public:
  SignalGuard();
  ~SignalGuard();
  SignalGuard(const SignalGuard&) = delete;
  SignalGuard& operator=(const SignalGuard&) = delete;

 private:
  static constexpr int kSignals[3] = {SIGTERM, SIGINT, SIGUSR1};
  struct sigaction old_[3];
};

/// True once SIGTERM or SIGINT asked to stop and no run has taken the request yet (a series
/// checks it before starting the next run).
bool stop_requested();

/// Runs scripts/<script> with python3 and the arguments, without a shell and with its output
/// silenced; true when it exited with 0.
bool run_python_script(const std::string& script, std::vector<std::string> args);

/// How far a run is towards its end, 0 to 1: the furthest of its end conditions, each by its
/// own measure (steps, time, axial strain; after the peak, the fall of the stress from the peak
/// towards end.post_peak_fraction of it). The progress lines' ETA extrapolates it, so that the
/// estimate falls as the stress falls after the peak, where the steps slow down (contact) and
/// the run ends long before the axial strain; 0 where no condition measures progress.
real end_progress(const EndCondition& end, long step, real time, real axial_strain, real peak, real stress);

}  // namespace fdem
