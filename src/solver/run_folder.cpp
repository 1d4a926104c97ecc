#include "solver/run_folder.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/run_lock.hpp"
#include "solver/run.hpp"

namespace fdem {

const char* const kSummaryHeader =
    "name,peak_stress_Pa,strain_at_peak,peak_indirect_tensile_Pa,confining_pressure_Pa,platen_velocity_m_s,"
    "energy_error,broken_ce6,broken_mode_I,broken_mode_II,broken_mixed,broken_area_m2,failure_plane_angle_deg,"
    "planarity,mean_facet_angle_deg,crack_centroid_x_m,crack_centroid_y_m,crack_centroid_z_m,steps,time_s,wall_s,"
    "end_reason";

std::vector<std::string> condition_column_names(const Scene& scene) {
  std::vector<std::string> names;
  for (std::size_t i = 0; i < scene.conditions.size(); ++i) {
    std::string surface = scene.conditions[i].surface;
    for (char& c : surface)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') c = '_';
    const std::string stem = "bc" + std::to_string(i) + "_" + surface + "_";
    for (const char* end : {"force_x_N", "force_y_N", "force_z_N", "work_J"}) names.push_back(stem + end);
  }
  return names;
}

std::vector<std::string> history_column_names(const Scene& scene) {
  std::vector<std::string> names;
  for (const HistoryPoint& p : scene.history)
    for (const char* end : {"ux_m", "uy_m", "uz_m", "vx_m_s", "vy_m_s", "vz_m_s", "sxx_Pa", "syy_Pa", "szz_Pa",
                            "sxy_Pa", "syz_Pa", "sxz_Pa"})
      names.push_back("h_" + p.name + "_" + end);
  return names;
}

std::string monitors_header(const Scene& scene) {
  std::string h;
  for (const MonitorColumn& c : kMonitorColumns) h += (h.empty() ? "" : ",") + std::string(c.name);
  for (const std::string& name : condition_column_names(scene)) h += "," + name;
  for (const std::string& name : history_column_names(scene)) h += "," + name;
  return h + '\n';
}

std::string monitor_row(const Monitors& m, const Solver& solver) {
  std::ostringstream o;
  o << std::setprecision(10);
  for (std::size_t k = 0; k < kMonitorColumns.size(); ++k) {
    const MonitorColumn& c = kMonitorColumns[k];
    if (k > 0) o << ',';
    if (c.count)
      o << m.*c.count;
    else
      o << m.*c.value;
  }
  for (int k = 0; k < m.condition_columns; ++k) o << ',' << m.conditions[k];
  for (int k = 0; k < m.history_columns; ++k) o << ',' << m.history[k];
  o << '\n';
  const std::string row = o.str();
  if (row.find("nan") != std::string::npos || row.find("inf") != std::string::npos) {
    std::stringstream cells(row);
    std::string cell;
    std::vector<std::string> names;
    for (const MonitorColumn& c : kMonitorColumns) names.push_back(c.name);
    for (const std::string& name : condition_column_names(solver.scene())) names.push_back(name);
    for (const std::string& name : history_column_names(solver.scene())) names.push_back(name);
    for (const std::string& name : names)
      if (std::getline(cells, cell, ',') &&
          (cell.find("nan") != std::string::npos || cell.find("inf") != std::string::npos))
        throw RunError("step " + std::to_string(m.step) + ": the monitor " + name + " is " + cell +
                       ": the run is unstable. " + solver.instability_advice());
    throw RunError("step " + std::to_string(m.step) + ": a monitor is not finite: the run is unstable. " +
                   solver.instability_advice());
  }
  return row;
}

void write_summary(const std::string& path, const Scene& scene, const RunSummary& r) {
  std::ostringstream o;
  o << std::setprecision(10) << kSummaryHeader << '\n';
  const FracturePattern& f = r.fracture;
  o << csv_field(scene.name) << ',' << r.peak_stress << ',' << r.strain_at_peak << ',' << r.peak_indirect_tensile << ','
    << scene.confinement.pressure * scene.confinement.enabled << ',' << scene.platens.velocity << ','
    << r.last.energy_error << ',' << f.broken << ',' << f.mode_I << ',' << f.mode_II << ',' << f.mixed << ',' << f.area
    << ',' << f.plane_angle_deg << ',' << f.planarity << ',' << f.mean_facet_angle_deg << ',' << f.centroid.x << ','
    << f.centroid.y << ',' << f.centroid.z << ',' << r.steps << ',' << r.time << ',' << r.wall_seconds << ','
    << csv_field(r.end_reason) << '\n';
  write_file_atomically(path, o.str());
}

void MonitorFile::put(const std::string& text) {
  f << text;
  bytes += text.size();
  hash = fnv1a64(text.data(), text.size(), hash);
}

std::string checkpoint_suffix(int rank, int size) {
  return size > 1 ? ".rank" + std::to_string(rank) + "of" + std::to_string(size) + ".ckpt" : ".ckpt";
}

std::vector<std::string> find_checkpoints(const std::string& path, const std::string& suffix) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const bool one_rank = suffix == ".ckpt";
  if (one_rank && fs::is_regular_file(path, ec) &&
      fs::path(path).filename().string().find(".rank") == std::string::npos)
    return {path};
  fs::path dir = path;
  if (fs::is_regular_file(dir, ec)) dir = dir.parent_path();  // several ranks: the folder of the file
  if (fs::is_directory(dir / "checkpoints", ec)) dir /= "checkpoints";
  std::vector<std::string> found;
  auto ends_with = [](const std::string& s, const std::string& e) {
    return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
  };
  if (fs::is_directory(dir, ec))
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      if (e.is_regular_file() && ends_with(name, suffix) && (!one_rank || name.find(".rank") == std::string::npos))
        found.push_back(e.path().string());
    }
  // step_<12 digits>.ckpt: the names sort by step.
  std::sort(found.rbegin(), found.rend());
  return found;
}

namespace {

/// A checkpoint's name, step_<n>.ckpt (one rank) or step_<n>.rank<r>of<N>.ckpt: its step, rank
/// and rank count. False for any other name.
bool checkpoint_name(const std::string& name, long& step, int& rank, int& ranks) {
  int used = 0;
  rank = 0, ranks = 1;
  if (std::sscanf(name.c_str(), "step_%ld.ckpt%n", &step, &used) == 1 && used == int(name.size())) return step >= 0;
  used = 0;
  return std::sscanf(name.c_str(), "step_%ld.rank%dof%d.ckpt%n", &step, &rank, &ranks, &used) == 3 &&
         used == int(name.size()) && step >= 0 && ranks > 1 && rank >= 0 && rank < ranks;
}

}  // namespace

std::vector<CheckpointSet> find_checkpoint_sets(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::path dir = path;
  if (fs::is_regular_file(dir, ec)) dir = dir.parent_path();
  if (fs::is_directory(dir / "checkpoints", ec)) dir /= "checkpoints";
  std::map<std::pair<long, int>, std::map<int, std::string>> by_step;  // (step, ranks) -> rank -> file
  if (fs::is_directory(dir, ec))
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
      const std::string name = e.path().filename().string();
      long step = -1;
      int rank = 0, ranks = 1;
      if (!checkpoint_name(name, step, rank, ranks)) continue;
      if (e.is_regular_file()) by_step[{step, ranks}][rank] = e.path().string();
    }
  std::vector<CheckpointSet> sets;
  for (auto it = by_step.rbegin(); it != by_step.rend(); ++it) {
    if (int(it->second.size()) != it->first.second) continue;
    CheckpointSet set{it->first.first, it->first.second, {}};
    for (const auto& [rank, file] : it->second) set.files.push_back(file);
    sets.push_back(std::move(set));
  }
  std::stable_sort(sets.begin(), sets.end(), [](const auto& a, const auto& b) { return a.step > b.step; });
  return sets;
}

void prune_checkpoints(const std::string& folder, std::size_t keep, const std::string& suffix) {
  std::vector<std::string> all = find_checkpoints(folder, suffix);
  for (std::size_t i = keep; i < all.size(); ++i) std::filesystem::remove(all[i]);
}

void sync_path(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

bool hash_prefix(const std::string& path, std::uint64_t bytes, std::uint64_t& hash) {
  std::ifstream in(path, std::ios::binary);
  hash = kFnvSeed;
  std::vector<char> buf(1 << 20);
  while (bytes > 0 && in) {
    in.read(buf.data(), std::streamsize(std::min<std::uint64_t>(bytes, buf.size())));
    const std::uint64_t got = std::uint64_t(in.gcount());
    hash = fnv1a64(buf.data(), got, hash);
    bytes -= got;
    if (got == 0) break;
  }
  return bytes == 0;
}

std::unique_ptr<RunLock> lock_run_folder(const std::string& folder, const Solver& solver, std::ostream& log) {
  std::unique_ptr<RunLock> lock;
  std::string refused;
  if (solver.rank() == 0) {
    try {
      lock = std::make_unique<RunLock>(folder, this_command(), log);
    } catch (const InputError& e) {
      refused = e.what();
    }
  }
  if (solver.distributed()) {
    int n = int(refused.size());
    MPI_Bcast(&n, 1, MPI_INT, 0, solver.comm());
    refused.resize(std::size_t(n));
    MPI_Bcast(refused.data(), n, MPI_CHAR, 0, solver.comm());
  }
  if (!refused.empty()) throw InputError(refused);
  return lock;
}

std::string replace_problem(const std::string& folder, const std::vector<std::string>& names) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const std::string& name : names) {
    const fs::path p = fs::path(folder) / name;
    const fs::file_status st = fs::status(p, ec);
    if (!fs::exists(st)) continue;
    const bool folder_wanted = name == "checkpoints";
    if (folder_wanted ? !fs::is_directory(st) : !fs::is_regular_file(st))
      return p.string() + " is " + (fs::is_directory(st) ? "a folder" : "not a regular file") +
             " where the run writes its " + (folder_wanted ? "checkpoint folder" : "file");
    if (!folder_wanted && ::access(p.c_str(), W_OK) != 0)
      return p.string() + " cannot be written (" + std::strerror(errno) + ")";
  }
  if (::access(folder.c_str(), W_OK | X_OK) != 0) return folder + " cannot be written (" + std::strerror(errno) + ")";
  return "";
}

}  // namespace fdem
