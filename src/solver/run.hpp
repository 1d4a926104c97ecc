#pragma once
// A whole run from a scene: build, time loop, monitors to CSV, ParaView frames,
// progress lines, the end condition and the final plot.
#include <iosfwd>
#include <string>

#include "solver/solver.hpp"

namespace fdem {

struct RunSummary {
  long steps = 0;
  real time = 0;  // simulated, s
  real wall_seconds = 0;
  real peak_stress = 0;  // Pa
  real strain_at_peak = 0;
  Monitors last;
  std::string end_reason;
  std::string folder;
};

/// One line per quantity: counts, the minimum altitude, the stable step and what limits it.
void report_model(const Solver& solver, std::ostream& out);

/// Run the solver to the scene's end condition, writing <folder>/monitors.csv,
/// <folder>/fields.{h5,xdmf} and <folder>/stress_strain.png. Rethrows RunError after
/// writing the monitor row and a field frame labelled "diagnostic" where possible.
RunSummary run_scene(Solver& solver, std::ostream& log);

}  // namespace fdem
