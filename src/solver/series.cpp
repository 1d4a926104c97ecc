#include "solver/series.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/checkpoint.hpp"
#include "io/run_lock.hpp"
#include "solver/pipeline.hpp"
#include "solver/run.hpp"
#include "solver/run_folder.hpp"

namespace fdem {
namespace {

namespace fs = std::filesystem;

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream t;
  t << in.rdbuf();
  return t.str();
}

real number(SeriesKey key, const std::string& value) {
  const double v = decimal(value);
  if (std::isnan(v))
    throw InputError(std::string(name_of(key)) + "=" + value +
                     ": not a number; give SI values such as 5e6 (Pa) or 0.1 (m/s)");
  return v;
}

void require(bool ok, SeriesKey key, const std::string& value, const std::string& what) {
  if (!ok) throw InputError(std::string(name_of(key)) + "=" + value + ": " + what);
}

std::string folder_name(const SeriesValues& values) {
  std::string n;
  for (const auto& [k, v] : values) n += (n.empty() ? "" : "_") + std::string(name_of(k)) + "_" + v;
  return n;
}

// summary.csv of a run stopped as unstable: its name, empty numbers, then end_reason (the
// last column) with the reason.
void write_unstable_summary(const std::string& path, const std::string& name, std::string why) {
  for (char& c : why)
    if (c == '\n') c = ' ';
  const std::string header = kSummaryHeader;
  write_file_atomically(path, header + '\n' + csv_field(name) +
                                  std::string(std::count(header.begin(), header.end(), ','), ',') +
                                  csv_field("unstable: " + why) + "\n");
}

}  // namespace

bool series_key_named(const std::string& word, SeriesKey& key) {
  return choice_named(word == "platen_speed" ? std::string("platen_velocity") : word, key);
}

SeriesAxis parse_series_axis(const std::string& arg) {
  const std::size_t eq = arg.find('=');
  const std::string keys = choice_list<SeriesKey>(", ");
  if (eq == std::string::npos || eq == 0)
    throw InputError("--vary " + arg + ": expected key=value1,value2,... with key one of " + keys);
  SeriesAxis a;
  const std::string key = arg.substr(0, eq);
  if (key == "precision")
    throw InputError("--vary " + arg +
                     ": fdem computes in double precision only (core/config.hpp); a single-precision solver is not "
                     "built, and casting the outputs would not measure its error, so there is no precision axis");
  if (!series_key_named(key, a.key))
    throw InputError("--vary " + arg + ": unknown key '" + key + "'; allowed: " + keys);
  // The same value twice (also spelled differently: 1 and 1.0, 1e6 and 1000000) would run twice
  // and, in fdem triaxial, count twice in the Mohr-Coulomb fit.
  auto same = [](const std::string& x, const std::string& y) { return x == y || decimal(x) == decimal(y); };
  std::stringstream in(arg.substr(eq + 1));
  for (std::string v; std::getline(in, v, ',');) {
    if (v.empty()) throw InputError("--vary " + arg + ": an empty value; separate values by single commas");
    for (const std::string& seen : a.values)
      if (same(seen, v)) throw InputError("--vary " + arg + ": value " + v + " is given twice (as " + seen + ")");
    a.values.push_back(v);
  }
  if (arg.back() == ',') throw InputError("--vary " + arg + ": an empty value after the last comma; remove it");
  if (a.values.empty()) throw InputError("--vary " + arg + ": no values after '='");
  return a;
}

namespace {

/// sigma3: the confining pressure, with confinement on where it is above 0.
void set_confining_pressure(Scene& s, const std::string& value) {
  const SeriesKey key = SeriesKey::sigma3;
  const real v = number(key, value);
  require(v >= 0 && v <= Confinement::kMaxPressure, key, value,
          "the confining pressure must be in [0, " + fmt(Confinement::kMaxPressure) + "] Pa");
  require(v == 0 || v >= 1e3, key, value,
          "values are in Pa: a confining pressure below 1 kPa is surely a slip (did you mean " + value + "e6?)");
  s.confinement.enabled = v > 0;
  s.confinement.pressure = v;
  require(v == 0 || s.platens.enabled || s.confinement.path == ConfinementPath::constant, key, value,
          "the hydrostatic path follows the axial stress, which needs platens; enable platens or set "
          "confinement.path: constant in " +
              s.file);
}

/// diameter or element_size of a generated mesh; a new diameter scales the height with it.
void set_mesh_size(Scene& s, SeriesKey key, const std::string& value) {
  const real v = number(key, value);
  require(v > 0, key, value, "must be > 0 m");
  require(s.mesh.generated() && (key == SeriesKey::element_size || s.mesh.shape != MeshShape::box), key, value,
          "needs a generated cylinder or disc mesh (mesh.generate in " + s.file + ")");
  if (key == SeriesKey::element_size) {
    s.mesh.element_size = v;
  } else {
    s.mesh.height *= v / s.mesh.diameter;
    s.mesh.diameter = v;
  }
  require(s.mesh.element_size < std::min(s.mesh.diameter, s.mesh.height), key, value,
          "the element size must be smaller than the specimen (diameter " + fmt(s.mesh.diameter) + " m, height " +
              fmt(s.mesh.height) + " m)");
}

}  // namespace

void apply_series_value(Scene& s, SeriesKey key, const std::string& value) {
  switch (key) {
    case SeriesKey::activation:
      require(choice_named(value, s.contact.activation), key, value, "allowed: " + choice_list<Activation>(", "));
      return;
    case SeriesKey::sigma3:
      return set_confining_pressure(s, value);
    case SeriesKey::diameter:
    case SeriesKey::element_size:
      return set_mesh_size(s, key, value);
    case SeriesKey::platen_velocity: {
      const real v = number(key, value);
      require(v > 0 && v <= Platens::kMaxVelocity, key, value,
              "the platen speed must be > 0 m/s and at most " + fmt(Platens::kMaxVelocity) + " m/s");
      require(s.platens.enabled, key, value, "the scene " + s.file + " has no platens");
      s.platens.velocity = v;
      return;
    }
    case SeriesKey::mass_scaling: {
      const real v = number(key, value);
      require(v >= 1 && v <= SolverSettings::kMaxMassScaling, key, value,
              "mass scaling must be >= 1 and at most " + fmt(SolverSettings::kMaxMassScaling));
      s.solver.mass_scaling = v;
      return;
    }
    case SeriesKey::time_step_safety: {
      const real v = number(key, value);
      require(v > 0 && v <= SolverSettings::kMaxSafety, key, value,
              "the time-step safety factor must be in (0, " + fmt(SolverSettings::kMaxSafety) + "] (<= 1 is stable)");
      s.solver.time_step_safety = v;
      return;
    }
  }
}

std::vector<SeriesValues> series_combinations(const std::vector<SeriesAxis>& axes) {
  for (std::size_t i = 0; i < axes.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (axes[i].key == axes[j].key)
        throw InputError(std::string("--vary ") + name_of(axes[i].key) +
                         " is given twice (each run takes one value of a key); give all "
                         "its values in one --vary " +
                         name_of(axes[i].key) + "=a,b,...");
  double count = 1;
  for (const SeriesAxis& a : axes) count *= double(a.values.size());
  if (count > kMaxSeriesRuns)
    throw InputError("--vary: " + fmt(count, 3) + " combinations, each a whole run; at most " +
                     std::to_string(kMaxSeriesRuns) + ". Fix: give fewer values, or split the study into series");
  std::vector<SeriesValues> combos(1);
  for (const SeriesAxis& a : axes) {
    std::vector<SeriesValues> next;
    for (const auto& c : combos)
      for (const std::string& v : a.values) {
        next.push_back(c);
        next.back().push_back({a.key, v});
      }
    combos = std::move(next);
  }
  return combos;
}

double SeriesRow::number(const std::string& column) const {
  const auto it = summary.find(column);
  if (it == summary.end()) return NAN;
  try {
    return std::stod(it->second);
  } catch (const std::exception&) {
    return NAN;
  }
}

std::map<std::string, std::string> read_summary(const std::string& path) {
  std::map<std::string, std::string> m;
  std::ifstream in(path);
  std::string head, row;
  if (!std::getline(in, head) || !std::getline(in, row)) return m;
  const auto h = split_csv(head), r = split_csv(row);
  if (h.size() != r.size()) return m;
  for (std::size_t i = 0; i < h.size(); ++i) m[h[i]] = r[i];
  return m;
}

namespace {

void make_series_folder(const std::string& folder) {
  std::error_code made;
  fs::create_directories(folder, made);
  if (made || !fs::is_directory(folder))
    throw InputError("-o " + folder + ": cannot create the folder for the runs" +
                     (made ? ": " + made.message() : std::string()) +
                     ". Fix: give -o a folder (new or existing) where you may write, not a file");
}

}  // namespace

std::vector<SeriesRow> run_series(const std::string& scene_path, const std::vector<SeriesAxis>& axes,
                                  const std::string& folder, int threads, bool quiet, std::ostream& log,
                                  std::unique_ptr<RunLock>* hold) {
  const Scene base = load_scene(scene_path);
  const std::string text = read_text(scene_path);
  // All checked before anything runs.
  const std::vector<SeriesValues> combos = series_combinations(axes);
  for (const auto& c : combos) {
    Scene s = base;
    for (const auto& [k, v] : c) apply_series_value(s, k, v);
  }
  // What a finished run is recognised by (run.txt): fdem's version, the values, the mesh file's
  // bytes and the scene's text. Not the scene's path as typed (./a.yaml and a.yaml are one scene),
  // but the mesh's content, which the scene's text does not hold.
  std::string mesh_line;
  if (!base.mesh.file.empty()) {
    const std::string bytes = read_text(base.mesh.file);
    char h[17];
    std::snprintf(h, sizeof h, "%016llx", static_cast<unsigned long long>(fnv1a64(bytes.data(), bytes.size())));
    mesh_line = "mesh " + fs::path(base.mesh.file).filename().string() + " FNV-1a " + h + "\n";
  }
  make_series_folder(folder);
  std::unique_ptr<RunLock> lock = std::make_unique<RunLock>(folder, this_command(), log);
  std::vector<SeriesRow> rows;
  const SignalGuard signals;  // a SIGTERM between runs stops the series before the next one
  for (std::size_t i = 0; i < combos.size(); ++i) {
    SeriesRow row;
    row.values = combos[i];
    row.folder = (fs::path(folder) / folder_name(combos[i])).string();
    std::ostringstream fp;
    fp << "fdem " FDEM_VERSION "\n" << mesh_line;
    for (const auto& [k, v] : combos[i]) fp << name_of(k) << " = " << v << "\n";
    fp << "---\n" << text;
    const std::string fp_path = (fs::path(row.folder) / "run.txt").string();
    const std::string summary_path = (fs::path(row.folder) / "summary.csv").string();
    const std::string label = folder_name(combos[i]);
    if (stop_requested())
      throw Interrupted("stopped by a signal before " + label +
                        "; run the same command again to continue: finished runs are skipped");
    log << "[" << i + 1 << "/" << combos.size() << "] " << label << ": ";
    const bool same_run = read_text(fp_path) == fp.str();
    if (fs::exists(summary_path) && same_run && !read_summary(summary_path).empty()) {
      row.resumed = true;
      log << "finished before, not run again (" << summary_path << ")" << std::endl;
    } else {
      // An interrupted run of the same variant continues from its newest checkpoint.
      RunOptions run_options;
      if (same_run && !find_checkpoints(row.folder).empty()) run_options.restart = row.folder;
      log << (run_options.restart.empty() ? "running in " : "continuing from the checkpoint in ") << row.folder
          << std::endl;
      Scene s = base;
      for (const auto& [k, v] : combos[i]) apply_series_value(s, k, v);
      s.name = base.name + " " + label;
      s.output.folder = row.folder;
      if (threads > 0) s.solver.threads = threads;
      if (quiet) s.output.progress_interval = 0;
      std::error_code ec;
      fs::create_directories(row.folder, ec);
      // The variant's folder is this run's before anything in it changes.
      const RunLock variant_lock(row.folder, this_command(), log);
      run_options.folder_locked = true;
      fs::remove(summary_path, ec);
      if (run_options.restart.empty()) fs::remove_all(fs::path(row.folder) / "checkpoints", ec);
      write_file_atomically(fp_path, fp.str());
      std::unique_ptr<Solver> solver;
      try {
        solver = make_solver(s, {}, MPI_COMM_SELF, log);
      } catch (const TimeStepBeyondBound& e) {
        // A fixed solver.time_step that this variant's mesh or mass scaling cannot take: an
        // unstable variant, not the end of the series.
        log << "  not run: " << e.what() << std::endl;
        write_unstable_summary(summary_path, s.name, std::string("not run: ") + e.what());
      } catch (const InputError& e) {
        throw InputError(std::string(e.what()) + " (" + label + ")");
      }
      if (solver) {
        try {
          const RunSummary r = run_scene(*solver, log, run_options);
          log << "  peak " << r.peak_stress / 1e6 << " MPa at strain " << r.strain_at_peak << ", " << r.last.broken
              << " broken CE6, " << r.wall_seconds << " s wall" << std::endl;
        } catch (const Interrupted& e) {
          throw Interrupted(std::string(e.what()) + " (" + label +
                            "); run the same command again to continue: finished runs are skipped and this one "
                            "resumes from its checkpoint");
        } catch (const RunError& e) {
          // An unstable variant is a result of the series (e.g. too much mass scaling), not its end.
          log << "  stopped: " << e.what() << std::endl;
          write_unstable_summary(summary_path, s.name, e.what());
        }
      }
    }
    row.summary = read_summary(summary_path);
    if (row.summary.empty()) throw OutputError(summary_path + ": missing or unreadable after the run");
    rows.push_back(std::move(row));
  }
  if (hold) *hold = std::move(lock);
  return rows;
}

void write_series_csv(const std::string& path, const std::vector<SeriesRow>& rows) {
  std::ostringstream o;
  const std::vector<std::string> cols = split_csv(kSummaryHeader);
  if (!rows.empty())
    for (const SeriesValue& kv : rows[0].values) o << name_of(kv.key) << ',';
  o << "folder";
  for (const std::string& c : cols) o << ',' << c;
  o << '\n';
  for (const SeriesRow& r : rows) {
    for (const SeriesValue& kv : r.values) o << csv_field(kv.value) << ',';
    o << csv_field(r.folder);
    for (const std::string& c : cols) {
      const auto it = r.summary.find(c);
      o << ',' << csv_field(it == r.summary.end() ? "" : it->second);
    }
    o << '\n';
  }
  write_file_atomically(path, o.str());
}

}  // namespace fdem
