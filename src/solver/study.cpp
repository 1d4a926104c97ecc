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
real exactness(const std::string& key, const std::string& value) {
  if (key == "activation") return value == "full" ? 2 : value == "adaptive" ? 1 : 0;
  if (key == "mass_scaling" || key == "platen_velocity" || key == "element_size" || key == "time_step_safety")
    return -decimal(value);
  return NAN;
}

std::string get(const SeriesValues& v, const std::string& key) {
  for (const auto& kv : v)
    if (kv.first == key) return kv.second;
  return "";
}

std::string label_of(const SeriesValues& v) {
  std::string s;
  for (const auto& [k, x] : v) s += (s.empty() ? "" : " ") + k + "=" + x;
  return s;
}

}  // namespace

const std::vector<std::string>& study_metrics() {
  static const std::vector<std::string> m = {"peak", "strain_at_peak", "curve_pre", "curve_post", "broken", "jaccard"};
  return m;
}

std::map<std::string, real> parse_budget(const std::vector<std::string>& args) {
  std::map<std::string, real> b;
  std::string names;
  for (const std::string& m : study_metrics()) names += (names.empty() ? "" : ", ") + m;
  for (const std::string& arg : args) {
    std::stringstream in(arg);
    for (std::string item; std::getline(in, item, ',');) {
      const std::size_t eq = item.find('=');
      const std::string key = item.substr(0, eq);
      if (eq == std::string::npos ||
          std::find(study_metrics().begin(), study_metrics().end(), key) == study_metrics().end())
        throw InputError("--budget " + arg + ": '" + item + "' should be metric=limit with metric one of " + names);
      std::string v = item.substr(eq + 1);
      const bool pct = !v.empty() && v.back() == '%';
      if (pct) v.pop_back();
      real x = decimal(v);
      if (pct) x /= 100;
      if (!(x >= 0) || (key == "jaccard" && x > 1))
        throw InputError("--budget " + arg + ": '" + item + "' needs a limit >= 0 such as 2% or 0.02" +
                         (key == "jaccard" ? " (jaccard: the least overlap accepted, <= 1)" : ""));
      // A fraction above 1 is an error of more than 100 %: surely per cent meant without the sign.
      if (!pct && key != "jaccard" && x > 1)
        throw InputError("--budget " + arg + ": '" + item + "' is " + fmt(100 * x) +
                         " % (limits are fractions); write " + v + "% for " + v + " per cent, or " + fmt(100 * x) +
                         "% if that is meant");
      if (b.count(key)) throw InputError("--budget " + arg + ": " + key + " is given twice; give one limit for it");
      b[key] = x;
    }
  }
  return b;
}

StudyResult run_study(const std::string& scene_path, const std::vector<SeriesAxis>& axes,
                      const std::vector<std::pair<std::string, std::string>>& reference,
                      const std::map<std::string, real>& budget, const std::string& folder, int threads, bool quiet,
                      std::ostream& log, std::unique_ptr<RunLock>* hold) {
  const std::vector<SeriesValues> combos = series_combinations(axes);
  // The reference, found before anything runs.
  int ref = -1;
  if (!reference.empty()) {
    for (const auto& [k, v] : reference) {
      bool varied = false;
      for (const SeriesAxis& a : axes) varied |= a.key == k;
      if (!varied) throw InputError("--reference " + k + "=" + v + ": " + k + " is not varied (--vary " + k + "=...)");
    }
    for (std::size_t i = 0; i < combos.size(); ++i) {
      bool match = true;
      for (const auto& [k, v] : reference) match = match && get(combos[i], k) == v;
      if (match) {
        if (ref >= 0) throw InputError("--reference matches several variants; name a value for every varied key");
        ref = int(i);
      }
    }
    if (ref < 0) throw InputError("--reference names no variant: use values given to --vary");
  } else {
    SeriesValues best;
    for (const SeriesAxis& a : axes) {
      std::string pick;
      for (const std::string& v : a.values) {
        const real e = exactness(a.key, v);
        if (std::isnan(e))
          throw InputError(a.key + " has no most exact value: name the reference, e.g. --reference " + a.key + "=" +
                           a.values.front());
        if (pick.empty() || e > exactness(a.key, pick)) pick = v;
      }
      best.push_back({a.key, pick});
    }
    for (std::size_t i = 0; i < combos.size(); ++i)
      if (combos[i] == best) ref = int(i);
  }

  StudyResult res;
  res.budget = budget;
  res.reference = ref;
  res.plotted = budget.empty() ? "peak" : budget.begin()->first;
  const std::vector<SeriesRow> runs = run_series(scene_path, axes, folder, threads, quiet, log, hold);
  const SeriesRow& r0 = runs[ref];
  if (r0.summary.count("end_reason") && r0.summary.at("end_reason").rfind("unstable", 0) == 0)
    throw RunError("the reference variant (" + label_of(r0.values) + ") was unstable: " + r0.summary.at("end_reason") +
                   "; choose a stable one with --reference");
  const StressStrainCurve c0 = read_stress_strain((fs::path(r0.folder) / "monitors.csv").string());
  const std::vector<long> b0 = read_broken_ce6((fs::path(r0.folder) / "broken_ce6.csv").string());
  const real pk0 = r0.number("peak_stress_Pa"), e0 = r0.number("strain_at_peak"), n0 = r0.number("broken_ce6");
  // Errors relative to a reference without a peak would be x/0 (peak, strain at peak) or have no
  // pre-peak curve.
  if (!(pk0 > 0) || !(e0 > 0))
    throw RunError("the reference variant (" + label_of(r0.values) + ") " +
                   (pk0 > 0 ? "peaked at axial strain " + fmt(e0, 3) + " (before the platens moved)"
                            : "reached no peak: peak stress " + fmt(pk0, 3) + " Pa") +
                   " when it ended (" +
                   (r0.summary.count("end_reason") ? r0.summary.at("end_reason") : std::string("?")) +
                   "), so the errors against it are undefined. Fix: load the specimen (platens) past the peak "
                   "(solver.end: post_peak_fraction, or a larger axial_strain); the runs are kept in " +
                   fs::path(r0.folder).parent_path().string());
  const real w0 = r0.number("wall_s"), end0 = c0.strain.empty() ? 0 : c0.strain.back();
  for (std::size_t i = 0; i < runs.size(); ++i) {
    StudyRow row;
    row.run = runs[i];
    row.reference = int(i) == ref;
    const SeriesRow& r = runs[i];
    row.wall = r.number("wall_s");
    row.steps = r.number("steps");
    row.seconds_per_step = row.wall / row.steps;
    row.stable = !(r.summary.count("end_reason") && r.summary.at("end_reason").rfind("unstable", 0) == 0);
    for (const std::string& m : study_metrics()) row.error[m] = NAN;
    if (row.stable) {
      row.speedup = w0 / row.wall;
      const StressStrainCurve c = read_stress_strain((fs::path(r.folder) / "monitors.csv").string());
      row.error["peak"] = std::fabs(r.number("peak_stress_Pa") - pk0) / pk0;
      row.error["strain_at_peak"] = std::fabs(r.number("strain_at_peak") - e0) / e0;
      row.error["curve_pre"] = curve_error(c0, c, 0, e0).error;
      row.error["curve_post"] = curve_error(c0, c, e0, end0).error;
      row.error["broken"] = std::fabs(r.number("broken_ce6") - n0) / std::max<real>(n0, 1);
      // Broken-face sets compare only on the same mesh.
      if (get(r.values, "element_size") == get(r0.values, "element_size") &&
          get(r.values, "diameter") == get(r0.values, "diameter"))
        row.error["jaccard"] = jaccard(read_broken_ce6((fs::path(r.folder) / "broken_ce6.csv").string()), b0);
    } else {
      row.speedup = NAN;
    }
    row.within_budget = row.stable;
    for (const auto& [m, limit] : budget) {
      const real e = row.error[m];
      row.within_budget = row.within_budget && !std::isnan(e) && (m == "jaccard" ? e >= limit : e <= limit);
    }
    res.rows.push_back(row);
  }
  std::vector<real> speed, err;
  for (const StudyRow& row : res.rows) {
    speed.push_back(row.speedup);
    const real e = row.error.at(res.plotted);
    err.push_back(res.plotted == "jaccard" ? 1 - e : e);
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
  for (const auto& kv : keys) csv << kv.first << ',';
  csv << "reference,stable,wall_s,steps,seconds_per_step,speedup";
  for (const std::string& m : study_metrics()) csv << ",error_" << m;
  csv << ",pareto,within_budget,recommended,folder\n";
  md << "| variant | wall (s) | steps | s/step | speed-up |";
  for (const std::string& m : study_metrics()) md << ' ' << m << " |";
  md << " front |\n|";
  for (std::size_t i = 0; i < 6 + study_metrics().size(); ++i) md << " --- |";
  md << '\n';
  for (std::size_t i = 0; i < r.rows.size(); ++i) {
    const StudyRow& row = r.rows[i];
    for (const auto& kv : row.run.values) csv << csv_field(kv.second) << ',';
    csv << row.reference << ',' << row.stable << ',' << row.wall << ',' << row.steps << ',' << row.seconds_per_step
        << ',' << row.speedup;
    for (const std::string& m : study_metrics()) csv << ',' << row.error.at(m);
    csv << ',' << row.pareto << ',' << row.within_budget << ',' << (int(i) == r.recommended) << ','
        << csv_field(row.run.folder) << '\n';
    md << "| " << label_of(row.run.values) << (row.reference ? " (reference)" : "")
       << (int(i) == r.recommended ? " **recommended**" : "") << " | " << fmt(row.wall, 3) << " | " << row.steps
       << " | " << fmt(row.seconds_per_step, 3) << " | " << (row.stable ? fmt(row.speedup, 3) + "×" : "unstable")
       << " |";
    for (const std::string& m : study_metrics()) {
      const real e = row.error.at(m);
      md << ' ' << (std::isnan(e) ? "–" : m == "jaccard" ? fmt(e, 3) : fmt(100 * e, 3) + " %") << " |";
    }
    md << (row.pareto ? " Pareto" : "") << " |\n";
  }
  md << "\nErrors against the reference: peak stress, strain at peak, relative L2 of the stress-strain curve "
        "before and after the reference's peak, broken-CE6 count; jaccard is the overlap of the broken-CE6 sets "
        "(same mesh only). Pareto: no other variant is both faster and closer in "
     << r.plotted << ".\n";
  if (!r.budget.empty()) {
    md << "\nBudget:";
    for (const auto& [m, v] : r.budget)
      md << ' ' << m << (m == "jaccard" ? " >= " + fmt(v, 3) : " <= " + fmt(100 * v, 3) + " %");
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
                                             (fs::path(folder) / "study.png").string(), "--error", r.plotted});
}

}  // namespace fdem
