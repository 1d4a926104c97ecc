#pragma once
// The files of a run's output folder (run_scene, series): monitors.csv and summary.csv rows,
// the checkpoint files and their names, the folder's lock, and the check before a fresh run
// replaces an earlier one.
#include <cstdint>
#include <fstream>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "io/checkpoint.hpp"
#include "solver/solver.hpp"

namespace fdem {

class RunLock;
struct RunSummary;

/// Columns of summary.csv.
extern const char* const kSummaryHeader;
/// The header line of monitors.csv (kMonitorColumns' names).
std::string monitors_header(const Scene& scene);
/// The boundary conditions' columns after kMonitorColumns: bc<i>_<surface>_force_x_N, _y_N,
/// _z_N and _work_J for each condition i.
std::vector<std::string> condition_column_names(const Scene& scene);
/// The history points' columns after those: h_<name>_ux_m, _uy_m, _uz_m, _vx_m_s, _vy_m_s,
/// _vz_m_s, _sxx_Pa, _syy_Pa, _szz_Pa, _sxy_Pa, _syz_Pa, _sxz_Pa for each point.
std::vector<std::string> history_column_names(const Scene& scene);

/// One monitor row (10 significant digits); a row with a non-finite value throws RunError
/// instead (no output file holds NaN or inf), naming the step and the column.
std::string monitor_row(const Monitors& m, const Solver& solver);

/// One row under kSummaryHeader, written atomically: its presence marks a finished run.
void write_summary(const std::string& path, const Scene& scene, const RunSummary& r);

/// monitors.csv with the length and FNV-1a of all it holds, so that a restart can check that
/// the file it cuts back is the one its checkpoint was taken with.
struct MonitorFile {
  std::ofstream f;
  std::uint64_t bytes = 0, hash = kFnvSeed;
  void put(const std::string& text);
};

/// The end of a checkpoint file name: ".ckpt" for one rank, ".rank<r>of<n>.ckpt" for rank r of n
/// (each rank writes its own file of a step: step_<n>.rank<r>of<n>.ckpt).
std::string checkpoint_suffix(int rank, int size);

/// The checkpoints under path (a checkpoint file, a run folder or its checkpoints/ folder),
/// newest first; empty if there is none.
/// Only names ending in `suffix` (checkpoint_suffix; one rank's files by default).
std::vector<std::string> find_checkpoints(const std::string& path, const std::string& suffix = ".ckpt");

/// The files of one step's checkpoint saved on `ranks` ranks, in rank order.
struct CheckpointSet {
  long step = -1;
  int ranks = 1;
  std::vector<std::string> files;
};
/// The whole sets of checkpoint files under path (a run folder, its checkpoints/ folder or a
/// file in it), of every rank count, newest step first (a set missing a rank's file is left out).
std::vector<CheckpointSet> find_checkpoint_sets(const std::string& path);

/// Keeps the newest `keep` checkpoints of a folder and removes the rest.
void prune_checkpoints(const std::string& folder, std::size_t keep, const std::string& suffix);

/// Flushes a file (or folder) to disk; best effort (a checkpoint must not end a run).
void sync_path(const std::string& path);

/// FNV-1a of the first `bytes` bytes of a file, or false if it is shorter.
bool hash_prefix(const std::string& path, std::uint64_t bytes, std::uint64_t& hash);

/// Rank 0 takes the lock of the run's folder for the whole job; where it cannot, every rank
/// throws its InputError.
std::unique_ptr<RunLock> lock_run_folder(const std::string& folder, const Solver& solver, std::ostream& log);

/// Before a fresh run removes or truncates anything of an earlier run in its folder: each of
/// `names` there is absent or a file it can replace ("checkpoints" a folder), and the folder can
/// be written. "" if so, else what stands in the way.
std::string replace_problem(const std::string& folder, const std::vector<std::string>& names);

}  // namespace fdem
