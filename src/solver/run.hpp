#pragma once
// A whole run from a scene: build, time loop, monitors to CSV, ParaView frames,
// progress lines, the end condition and the final plot.
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

/// One line per quantity: counts, the minimum altitude, the stable step and what limits it.
void report_model(const Solver& solver, std::ostream& out);

/// Run the solver to the scene's end condition, writing <folder>/monitors.csv,
/// <folder>/fields.{h5,xdmf}, <folder>/stress_strain.png and, last and atomically,
/// <folder>/summary.csv (one row: kSummaryHeader), whose presence marks a finished run. Rethrows RunError after
/// writing the monitor row and a field frame labelled "diagnostic" where possible.
RunSummary run_scene(Solver& solver, std::ostream& log);

/// Runs scripts/<script> with python3 and the arguments, without a shell and with its output
/// silenced; true when it exited with 0.
bool run_python_script(const std::string& script, std::vector<std::string> args);

/// Columns of summary.csv.
extern const char* const kSummaryHeader;

}  // namespace fdem
