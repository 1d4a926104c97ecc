#pragma once
// A series of runs of one scene that differ in one or more parameters: the triaxial series over
// confining pressures and the paper's loading-rate and specimen-size studies.
//
// Each run writes a normal run folder <folder>/<key>_<value>[_<key>_<value>...]/ (monitors.csv,
// fields, summary.csv) plus run.txt, the fingerprint of what was run (fdem version, the values,
// an FNV-1a hash of the mesh file's bytes, the scene file's text; not the scene's path). A run
// whose folder holds summary.csv and the same run.txt is not run again: an interrupted series
// resumes where it stopped. The series writes
// <folder>/series.csv, one row per run: the varied values, then the columns of summary.csv.
#include <iosfwd>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "scene/scene.hpp"

namespace fdem {

class RunLock;

/// One varied parameter and its values as typed (SI units). Keys:
///   sigma3           Pa   confining pressure (0 = unconfined); the path is the scene's
///                         confinement.path (hydrostatic unless it says constant)
///   platen_velocity  m/s  loading rate (also accepted as platen_speed)
///   diameter         m    specimen diameter of a generated cylinder or disc; the height
///                         (disc: thickness) scales with it, keeping the scene's ratio
///   element_size     m    of a generated mesh
///   mass_scaling     -    density factor m >= 1
///   activation       -    adaptive | full | none
///   time_step_safety -    fraction of the stable-step bound
/// A run stopped as unstable (RunError), or not run since the scene's fixed solver.time_step is
/// beyond ten times its stable-step bound, gets a summary.csv with empty numbers and end_reason
/// "unstable: <why>", and the series goes on.
enum class SeriesKey { sigma3, platen_velocity, diameter, element_size, mass_scaling, activation, time_step_safety };
template <>
struct ChoiceNames<SeriesKey> {
  static constexpr std::array<const char*, 7> words{
      "sigma3", "platen_velocity", "diameter", "element_size", "mass_scaling", "activation", "time_step_safety"};
};

struct SeriesAxis {
  SeriesKey key;
  std::vector<std::string> values;  // as typed: they name the run folders
};

/// The key a word names, platen_speed (what users also say) included; false where none.
bool series_key_named(const std::string& word, SeriesKey& key);

/// Parses "key=v1,v2,..." (throws InputError naming the argument and the fix).
SeriesAxis parse_series_axis(const std::string& arg);

/// Sets one parameter of a scene; throws InputError naming the key, the value and what is allowed.
void apply_series_value(Scene& scene, SeriesKey key, const std::string& value);

/// One varied parameter's value in one run, as typed.
struct SeriesValue {
  SeriesKey key;
  std::string value;
  bool operator==(const SeriesValue& o) const { return key == o.key && value == o.value; }
};
using SeriesValues = std::vector<SeriesValue>;

/// At most this many runs in one series (each a whole run: more is a slip).
constexpr int kMaxSeriesRuns = 10000;

/// Every combination of the axes' values, the last axis varying fastest.
std::vector<SeriesValues> series_combinations(const std::vector<SeriesAxis>& axes);

struct SeriesRow {
  SeriesValues values;
  std::string folder;
  std::map<std::string, std::string> summary;  // the run's summary.csv: column -> value
  bool resumed = false;                        // found finished, not run again

  /// summary[column] as a number (NaN when missing or not a number).
  double number(const std::string& column) const;
};

/// Runs every combination of the axes' values (the last axis varying fastest) in turn,
/// skipping finished runs. All values are checked before the first run starts. threads > 0
/// overrides solver.threads; quiet silences the progress lines of each run.
/// The series' folder is locked (io/run_lock.hpp) once the values are checked, before anything
/// is written there, and so is each run's folder, so a second command into them is refused
/// (InputError naming the run that holds it). The folder's lock goes to *hold, for a caller that
/// writes there after the runs (series.csv, study.csv); without hold it is released on return.
std::vector<SeriesRow> run_series(const std::string& scene_path, const std::vector<SeriesAxis>& axes,
                                  const std::string& folder, int threads, bool quiet, std::ostream& log,
                                  std::unique_ptr<RunLock>* hold = nullptr);

/// Writes <path> (atomically): the varied keys, then the summary columns.
void write_series_csv(const std::string& path, const std::vector<SeriesRow>& rows);

/// Reads a one-row CSV with a header (summary.csv) into column -> value; empty when missing.
std::map<std::string, std::string> read_summary(const std::string& path);

}  // namespace fdem
