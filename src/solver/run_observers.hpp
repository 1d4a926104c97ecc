#pragma once
// What a run does after each step, one observer each: the monitor rows (with the peak and its
// frames), the field frames, the end condition, the progress line and the checkpoints. The run
// loop (run.cpp) takes a step, then calls them in that order. They share the run's record: its files, its last row, the
// peak and the clock.
#include <chrono>
#include <memory>
#include <ostream>
#include <string>

#include "io/checkpoint.hpp"
#include "io/fields.hpp"
#include "solver/frames.hpp"
#include "solver/run.hpp"
#include "solver/run_folder.hpp"
#include "solver/solver.hpp"

namespace fdem {

/// What the observers of a run share. A checkpoint holds its part after the solver's.
struct RunRecord {
  RunRecord(Solver& solver, std::ostream& log);
  Solver& solver;
  std::ostream& log;
  const OutputSettings& out;
  const bool dist, root;  // several ranks; rank 0, which writes the monitors and the summary
  std::string csv_path;   // rank 0's monitors.csv ("/dev/null" on the others)
  MonitorFile csv;
  std::unique_ptr<FieldWriter> fields;
  Monitors row;               // the last monitor row
  RunSummary sum;             // the peak so far; at the end, the totals and the end's reason
  bool peak_written = false;  // the frames of the peak that passed are written
  PeakFrames peak_frames;
  real wall_before = 0;  // s, spent by the run before the checkpoint it continues from
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();

  /// s, the wall time of this session (since t0).
  real elapsed() const;
  /// The top platen's travel over the height.
  real axial_strain() const;
  /// monitors.csv to the disk's cache; OutputError where it cannot be written.
  void flush_csv();
  /// Its part of a checkpoint: the last row, the peak, the wall time, monitors.csv's length and
  /// hash, and the field writer's state (which load() hands back for a new writer).
  void save(CheckpointOut& o) const;
  void load(CheckpointIn& in, FieldWriterState& fields_state);
  /// The values every rank saved alike (the row, the peak, the wall time, monitors.csv's
  /// length and hash) from a record of another rank count.
  void take_saved(const RunRecord& saved);
};

/// A step as its observers see it, in turn.
struct StepEvent {
  long step = 0;
  bool monitor_row = false;  // a step of output.monitor_interval
  std::string end;           // why the run ends after this step ("" while it goes on)
};

class StepObserver {
 public:
  virtual ~StepObserver() = default;
  virtual void after_step(StepEvent& e) = 0;
};

/// Monitor rows: measured and written, with notes on grown device buffers and gathered contact
/// ghosts. Then the peak: followed, and its frames written once the stress is 5 % below it.
class MonitorRows final : public StepObserver {
 public:
  explicit MonitorRows(RunRecord& r) : r_(r), growths_seen_(r.solver.ghost_growths()) {}
  void after_step(StepEvent& e) override {
    if (e.monitor_row) record();
  }

 private:
  void record();
  void notes();
  void follow_peak();
  RunRecord& r_;
  long pair_growth_seen_ = 0;  // device backends: growths of the contact pair buffers noted
  GhostGrowths growths_seen_;  // several ranks: contact ghosts gathered again
};

/// A field frame every `interval` steps.
class FieldFrames final : public StepObserver {
 public:
  FieldFrames(RunRecord& r, long interval) : r_(r), interval_(interval) {}
  void after_step(StepEvent& e) override {
    if (e.step % interval_ == 0) write_frame(*r_.fields, r_.solver, "");
  }

 private:
  RunRecord& r_;
  long interval_;
};

/// The scene's end condition (solver.end).
class EndCheck final : public StepObserver {
 public:
  explicit EndCheck(RunRecord& r) : r_(r), end_(r.solver.scene().solver.end) {}
  void after_step(StepEvent& e) override { e.end = reason(e.monitor_row); }
  /// Why the run ends at its state, or "". The fall after the peak is checked on monitor rows.
  std::string reason(bool monitor_row) const;

 private:
  RunRecord& r_;
  const EndCondition& end_;
};

/// The progress line, every output.progress_interval s of wall time and at the end. The ETA
/// extrapolates the end condition's own progress (end_progress) made in this session.
class ProgressLine final : public StepObserver {
 public:
  explicit ProgressLine(RunRecord& r);
  void after_step(StepEvent& e) override;

 private:
  RunRecord& r_;
  real next_ = 0;        // s, of wall time
  long first_step_ = 0;  // where this session started, and its progress then
  real progress0_ = 0;
};

/// Checkpoints: by steps, by wall time, or asked for by a signal (SIGTERM and SIGINT: then the
/// run stops, Interrupted). Not after the last step.
class Checkpoints final : public StepObserver {
 public:
  Checkpoints(RunRecord& r, std::string folder, std::string suffix)
      : r_(r), folder_(std::move(folder)), suffix_(std::move(suffix)) {}
  void after_step(StepEvent& e) override {
    if (e.end.empty()) due(e);
  }
  /// Writes a checkpoint of this step (the files it refers to reach the disk first); its path.
  std::string write(const std::string& why);

 private:
  void due(const StepEvent& e);
  RunRecord& r_;
  const std::string folder_, suffix_;
  int pending_request_ = 0;  // several ranks: a signal waits for the next monitor row
  real last_wall_ = 0;       // s, of the last checkpoint (elapsed())
};

}  // namespace fdem
