#pragma once
// `fdem study`: a series of variants of one scene measured against a reference variant for
// speed and accuracy, with a recommendation under an error budget.
//
// Runs go through run_series (same folders, same resuming). For each variant, against the
// reference: speed-up (reference wall time / variant wall time), time per step, and the errors
//   peak            |peak - peak_ref| / peak_ref
//   strain_at_peak  |e_pk - e_pk_ref| / e_pk_ref
//   curve_pre       relative L2 of the stress-strain curve on [0, e_pk_ref]
//   curve_post      relative L2 on [e_pk_ref, the reference's last strain]
//   broken          |n - n_ref| / max(n_ref, 1), n the broken-CE6 count
//   jaccard         |A n B| / |A u B| of the broken-CE6 sets (same mesh only; a minimum in budgets)
// (run_comparison.hpp). Outputs in the study folder: study.csv, study.md, study.png.
#include <array>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "solver/series.hpp"

namespace fdem {

/// The errors above, in table order.
enum class StudyMetric { peak, strain_at_peak, curve_pre, curve_post, broken, jaccard };
template <>
struct ChoiceNames<StudyMetric> {
  static constexpr std::array<const char*, 6> words{"peak",       "strain_at_peak", "curve_pre",
                                                    "curve_post", "broken",         "jaccard"};
};
constexpr std::size_t kStudyMetrics = ChoiceNames<StudyMetric>::words.size();

/// One value per metric (an error, NaN when not comparable).
struct MetricValues {
  std::array<real, kStudyMetrics> by_metric;
  real& operator[](StudyMetric m) { return by_metric[std::size_t(m)]; }
  real operator[](StudyMetric m) const { return by_metric[std::size_t(m)]; }
};

/// Limits of a budget: metric -> limit as a fraction (jaccard: the least overlap accepted).
using StudyBudget = std::map<StudyMetric, real>;

/// "peak=2%,curve_pre=0.05" (repeatable). Throws InputError.
StudyBudget parse_budget(const std::vector<std::string>& args);

struct StudyRow {
  SeriesRow run;
  bool reference = false, stable = true, pareto = false, within_budget = false;
  real wall = 0, steps = 0, seconds_per_step = 0, speedup = 0;
  MetricValues error;  // NaN when not comparable
};

struct StudyResult {
  std::vector<StudyRow> rows;
  int reference = -1;
  int recommended = -1;                     // fastest stable variant within the budget
  StudyMetric plotted = StudyMetric::peak;  // the error on the plot's axis: the budget's first in table order
  StudyBudget budget;
};

/// "key=value[,key=value]" of --reference, typed (InputError for a key that is no series key).
SeriesValues parse_reference(const std::string& arg);

/// reference: the values naming one variant; empty = for each axis its most exact value
/// (activation full; the smallest mass_scaling, platen_velocity, element_size,
/// time_step_safety); sigma3 and diameter have no most exact value and need it named.
/// hold: as run_series's (the folder's lock, for writing study.csv after the runs).
StudyResult run_study(const std::string& scene_path, const std::vector<SeriesAxis>& axes, const SeriesValues& reference,
                      const StudyBudget& budget, const std::string& folder, int threads, bool quiet, std::ostream& log,
                      std::unique_ptr<RunLock>* hold = nullptr);

/// study.csv and study.md in folder (atomically), and study.png through scripts/plot_study.py
/// (false when the plot could not be made).
bool write_study(const std::string& folder, const StudyResult& r);

}  // namespace fdem
