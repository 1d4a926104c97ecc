#include "solver/study.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "analysis/run_comparison.hpp"
#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "solver/run.hpp"

namespace fdem {
namespace {

namespace fs = std::filesystem;

// How exact a value of an axis is: larger is more exact; NaN where there is no order.
real exactness(SeriesKey key, const std::string& value) {
  switch (key) {
    case SeriesKey::activation: {
      Activation a = Activation::none;
      choice_named(value, a);  // (checked by apply_series_value before any run)
      return a == Activation::full ? 2 : a == Activation::adaptive ? 1 : 0;
    }
    case SeriesKey::mass_scaling:
    case SeriesKey::platen_velocity:
    case SeriesKey::element_size:
    case SeriesKey::time_step_safety:
      return -decimal(value);
    case SeriesKey::sigma3:
    case SeriesKey::diameter:
      return NAN;
  }
  return NAN;
}

std::string get(const SeriesValues& v, SeriesKey key) {
  for (const SeriesValue& kv : v)
    if (kv.key == key) return kv.value;
  return "";
}

std::string label_of(const SeriesValues& v) {
  std::string s;
  for (const auto& [k, x] : v) s += (s.empty() ? "" : " ") + std::string(name_of(k)) + "=" + x;
  return s;
}

bool unstable(const SeriesRow& r) {
  return r.summary.count("end_reason") && r.summary.at("end_reason").rfind("unstable", 0) == 0;
}

/// The variant the user named: exactly one must match every named value.
int named_reference(const std::vector<SeriesValues>& combos, const std::vector<SeriesAxis>& axes,
                    const SeriesValues& reference) {
  for (const auto& [k, v] : reference) {
    bool varied = false;
    for (const SeriesAxis& a : axes) varied |= a.key == k;
    if (!varied)
      throw InputError(std::string("--reference ") + name_of(k) + "=" + v + ": " + name_of(k) +
                       " is not varied (--vary " + name_of(k) + "=...)");
  }
  int ref = -1;
  for (std::size_t i = 0; i < combos.size(); ++i) {
    bool match = true;
    for (const auto& [k, v] : reference) match = match && get(combos[i], k) == v;
    if (match) {
      if (ref >= 0) throw InputError("--reference matches several variants; name a value for every varied key");
      ref = int(i);
    }
  }
  if (ref < 0) throw InputError("--reference names no variant: use values given to --vary");
  return ref;
}

/// The variant with each axis at its most exact value (exactness()).
int most_exact_variant(const std::vector<SeriesValues>& combos, const std::vector<SeriesAxis>& axes) {
  SeriesValues best;
  for (const SeriesAxis& a : axes) {
    std::string pick;
    for (const std::string& v : a.values) {
      const real e = exactness(a.key, v);
      if (std::isnan(e))
        throw InputError(std::string(name_of(a.key)) +
                         " has no most exact value: name the reference, e.g. --reference " + name_of(a.key) + "=" +
                         a.values.front());
      if (pick.empty() || e > exactness(a.key, pick)) pick = v;
    }
    best.push_back({a.key, pick});
  }
  for (std::size_t i = 0; i < combos.size(); ++i)
    if (combos[i] == best) return int(i);
  return -1;
}

/// What every variant is compared with: the reference run's curve, breaks, peak and wall time.
struct ReferenceRun {
  StressStrainCurve curve;
  std::vector<long> broken_set;
  real peak = 0, strain_at_peak = 0, broken = 0, wall = 0, end_strain = 0;
  const SeriesRow* row = nullptr;
};

/// The reference's results; errors against a reference that was unstable or had no peak
/// would be undefined (x/0, or no pre-peak curve).
ReferenceRun read_reference(const SeriesRow& r0) {
  if (unstable(r0))
    throw RunError("the reference variant (" + label_of(r0.values) + ") was unstable: " + r0.summary.at("end_reason") +
                   "; choose a stable one with --reference");
  ReferenceRun ref;
  ref.row = &r0;
  ref.curve = read_stress_strain((fs::path(r0.folder) / "monitors.csv").string());
  ref.broken_set = read_broken_ce6((fs::path(r0.folder) / "broken_ce6.csv").string());
  ref.peak = r0.number("peak_stress_Pa");
  ref.strain_at_peak = r0.number("strain_at_peak");
  ref.broken = r0.number("broken_ce6");
  if (!(ref.peak > 0) || !(ref.strain_at_peak > 0))
    throw RunError(
        "the reference variant (" + label_of(r0.values) + ") " +
        (ref.peak > 0 ? "peaked at axial strain " + fmt(ref.strain_at_peak, 3) + " (before the platens moved)"
                      : "reached no peak: peak stress " + fmt(ref.peak, 3) + " Pa") +
        " when it ended (" + (r0.summary.count("end_reason") ? r0.summary.at("end_reason") : std::string("?")) +
        "), so the errors against it are undefined. Fix: load the specimen (platens) past the peak "
        "(solver.end: post_peak_fraction, or a larger axial_strain); the runs are kept in " +
        fs::path(r0.folder).parent_path().string());
  ref.wall = r0.number("wall_s");
  ref.end_strain = ref.curve.strain.empty() ? 0 : ref.curve.strain.back();
  return ref;
}

/// One variant against the reference: speed-up, every error, and whether the budget holds.
StudyRow compare(const SeriesRow& r, const ReferenceRun& ref, const StudyBudget& budget) {
  StudyRow row;
  row.run = r;
  row.reference = &r == ref.row;
  row.wall = r.number("wall_s");
  row.steps = r.number("steps");
  row.seconds_per_step = row.wall / row.steps;
  row.stable = !unstable(r);
  row.error.by_metric.fill(NAN);
  row.speedup = NAN;
  if (row.stable) {
    row.speedup = ref.wall / row.wall;
    const StressStrainCurve c = read_stress_strain((fs::path(r.folder) / "monitors.csv").string());
    row.error[StudyMetric::peak] = std::fabs(r.number("peak_stress_Pa") - ref.peak) / ref.peak;
    row.error[StudyMetric::strain_at_peak] =
        std::fabs(r.number("strain_at_peak") - ref.strain_at_peak) / ref.strain_at_peak;
    row.error[StudyMetric::curve_pre] = curve_error(ref.curve, c, 0, ref.strain_at_peak).error;
    row.error[StudyMetric::curve_post] = curve_error(ref.curve, c, ref.strain_at_peak, ref.end_strain).error;
    row.error[StudyMetric::broken] = std::fabs(r.number("broken_ce6") - ref.broken) / std::max<real>(ref.broken, 1);
    // Broken-face sets compare only on the same mesh.
    const SeriesValues& v0 = ref.row->values;
    if (get(r.values, SeriesKey::element_size) == get(v0, SeriesKey::element_size) &&
        get(r.values, SeriesKey::diameter) == get(v0, SeriesKey::diameter))
      row.error[StudyMetric::jaccard] =
          jaccard(read_broken_ce6((fs::path(r.folder) / "broken_ce6.csv").string()), ref.broken_set);
  }
  row.within_budget = row.stable;
  for (const auto& [m, limit] : budget) {
    const real e = row.error[m];
    row.within_budget = row.within_budget && !std::isnan(e) && (m == StudyMetric::jaccard ? e >= limit : e <= limit);
  }
  return row;
}

}  // namespace

StudyBudget parse_budget(const std::vector<std::string>& args) {
  StudyBudget b;
  const std::string names = choice_list<StudyMetric>(", ");
  for (const std::string& arg : args) {
    std::stringstream in(arg);
    for (std::string item; std::getline(in, item, ',');) {
      const std::size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      StudyMetric metric{};
      if (eq == std::string::npos || !choice_named(key, metric))
        throw InputError("--budget " + arg + ": '" + item + "' should be metric=limit with metric one of " + names);
      std::string v = item.substr(eq + 1);
      const bool pct = !v.empty() && v.back() == '%';
      if (pct) v.pop_back();
      real x = decimal(v);
      if (pct) x /= 100;
      const bool jac = metric == StudyMetric::jaccard;
      if (!(x >= 0) || (jac && x > 1))
        throw InputError("--budget " + arg + ": '" + item + "' needs a limit >= 0 such as 2% or 0.02" +
                         (jac ? " (jaccard: the least overlap accepted, <= 1)" : ""));
      // A fraction above 1 is an error of more than 100 %: surely per cent meant without the sign.
      if (!pct && !jac && x > 1)
        throw InputError("--budget " + arg + ": '" + item + "' is " + fmt(100 * x) +
                         " % (limits are fractions); write " + v + "% for " + v + " per cent, or " + fmt(100 * x) +
                         "% if that is meant");
      if (b.count(metric)) throw InputError("--budget " + arg + ": " + key + " is given twice; give one limit for it");
      b[metric] = x;
    }
  }
  return b;
}

SeriesValues parse_reference(const std::string& arg) {
  SeriesValues ref;
  std::stringstream in(arg);
  for (std::string kv; std::getline(in, kv, ',');) {
    const std::size_t eq = kv.find('=');
    if (eq == std::string::npos) throw InputError("--reference " + arg + ": expected key=value[,key=value]");
    const std::string key = kv.substr(0, eq);
    SeriesValue v{SeriesKey::sigma3, kv.substr(eq + 1)};
    if (!series_key_named(key, v.key))
      throw InputError("--reference " + kv + ": " + key + " is not varied (--vary takes " +
                       choice_list<SeriesKey>(", ") + ")");
    ref.push_back(v);
  }
  return ref;
}

StudyResult run_study(const std::string& scene_path, const std::vector<SeriesAxis>& axes, const SeriesValues& reference,
                      const StudyBudget& budget, const std::string& folder, int threads, bool quiet, std::ostream& log,
                      std::unique_ptr<RunLock>* hold) {
  const std::vector<SeriesValues> combos = series_combinations(axes);
  // The reference, found before anything runs.
  const int ref = reference.empty() ? most_exact_variant(combos, axes) : named_reference(combos, axes, reference);
  StudyResult res;
  res.budget = budget;
  res.reference = ref;
  res.plotted = budget.empty() ? StudyMetric::peak : budget.begin()->first;
  const std::vector<SeriesRow> runs = run_series(scene_path, axes, folder, threads, quiet, log, hold);
  const ReferenceRun r0 = read_reference(runs[ref]);
  for (const SeriesRow& r : runs) res.rows.push_back(compare(r, r0, budget));
  std::vector<real> speed, err;
  for (const StudyRow& row : res.rows) {
    speed.push_back(row.speedup);
    const real e = row.error[res.plotted];
    err.push_back(res.plotted == StudyMetric::jaccard ? 1 - e : e);
  }
  const std::vector<bool> front = pareto_front(speed, err);
  for (std::size_t i = 0; i < res.rows.size(); ++i) {
    res.rows[i].pareto = front[i];
    if (res.rows[i].within_budget && (res.recommended < 0 || res.rows[i].speedup > res.rows[res.recommended].speedup))
      res.recommended = int(i);
  }
  return res;
}

bool write_study(const std::string& folder, const StudyResult& r) {
  std::ostringstream csv, md;
  csv << std::setprecision(8);
  const auto& keys = r.rows.front().run.values;
  for (const SeriesValue& kv : keys) csv << name_of(kv.key) << ',';
  csv << "reference,stable,wall_s,steps,seconds_per_step,speedup";
  for (const char* m : ChoiceNames<StudyMetric>::words) csv << ",error_" << m;
  csv << ",pareto,within_budget,recommended,folder\n";
  md << "| variant | wall (s) | steps | s/step | speed-up |";
  for (const char* m : ChoiceNames<StudyMetric>::words) md << ' ' << m << " |";
  md << " front |\n|";
  for (std::size_t i = 0; i < 6 + kStudyMetrics; ++i) md << " --- |";
  md << '\n';
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const StudyRow& row = r.rows[i];
    for (const SeriesValue& kv : row.run.values) csv << csv_field(kv.value) << ',';
    csv << row.reference << ',' << row.stable << ',' << row.wall << ',' << row.steps << ',' << row.seconds_per_step
        << ',' << row.speedup;
    for (real e : row.error.by_metric) csv << ',' << e;
    csv << ',' << row.pareto << ',' << row.within_budget << ',' << (int(i) == r.recommended) << ','
        << csv_field(row.run.folder) << '\n';
    md << "| " << label_of(row.run.values) << (row.reference ? " (reference)" : "")
       << (int(i) == r.recommended ? " **recommended**" : "") << " | " << fmt(row.wall, 3) << " | " << row.steps
       << " | " << fmt(row.seconds_per_step, 3) << " | " << (row.stable ? fmt(row.speedup, 3) + "×" : "unstable")
       << " |";
    for (std::size_t m = 0; m < kStudyMetrics; ++m) {
      const real e = row.error.by_metric[m];
      md << ' '
         << (std::isnan(e)                            ? "–"
             : StudyMetric(m) == StudyMetric::jaccard ? fmt(e, 3)
                                                      : fmt(100 * e, 3) + " %")
         << " |";
    }
    md << (row.pareto ? " Pareto" : "") << " |\n";
  }
  md << "\nErrors against the reference: peak stress, strain at peak, relative L2 of the stress-strain curve "
        "before and after the reference's peak, broken-CE6 count; jaccard is the overlap of the broken-CE6 sets "
        "(same mesh only). Pareto: no other variant is both faster and closer in "
     << name_of(r.plotted) << ".\n";
  if (!r.budget.empty()) {
    md << "\nBudget:";
    for (const auto& [m, v] : r.budget)
      md << ' ' << name_of(m) << (m == StudyMetric::jaccard ? " >= " + fmt(v, 3) : " <= " + fmt(100 * v, 3) + " %");
    md << ". ";
  } else {
    md << "\nNo budget given (--budget): ";
  }
  if (r.recommended >= 0)
    md << "fastest variant within it: " << label_of(r.rows[r.recommended].run.values) << ".\n";
  else
    md << "no variant is within it.\n";
  write_file_atomically((fs::path(folder) / "study.csv").string(), csv.str());
  write_file_atomically((fs::path(folder) / "study.md").string(), md.str());
  return run_python_script("plot_study.py", {(fs::path(folder) / "study.csv").string(),
                                             (fs::path(folder) / "study.png").string(), "--error", name_of(r.plotted)});
}

}  // namespace fdem
