// The progress towards a run's end that its ETA extrapolates (solver/run.hpp, end_progress).
#include <gtest/gtest.h>

#include "solver/run.hpp"

using namespace fdem;

TEST(EndProgress, TheFurthestEndConditionByItsOwnMeasure) {
  EndCondition end;
  end.axial_strain = 0.006;
  end.post_peak_fraction = 0.3;
  // Before the peak, the strain: a quarter of the way.
  EXPECT_DOUBLE_EQ(end_progress(end, 1000, 1e-3, 0.0015, 16e6, 16e6), 0.25);
  // After the peak the run ends when the stress is 30 % of it: at 65 % it has fallen half of the
  // 70 % it falls in all, further than the strain (0.2 of the way), and the estimate follows it.
  EXPECT_NEAR(end_progress(end, 2000, 2e-3, 0.0012, 16e6, 0.65 * 16e6), 0.5, 1e-12);
  EXPECT_NEAR(end_progress(end, 3000, 3e-3, 0.0013, 16e6, 0.3 * 16e6), 1.0, 1e-12);
  // As the stress falls the progress only grows, whatever the strain does meanwhile.
  real last = 0;
  for (real f = 1.0; f >= 0.3; f -= 0.05) {
    const real p = end_progress(end, 2000, 2e-3, 0.0012, 16e6, f * 16e6);
    EXPECT_GE(p, last);
    last = p;
  }
  // Steps and time by theirs; none at all: 0 (the ETA is then "?").
  EndCondition steps;
  steps.steps = 400;
  steps.time = 1e-3;
  EXPECT_DOUBLE_EQ(end_progress(steps, 100, 5e-4, 0, 0, 0), 0.5);
  EXPECT_DOUBLE_EQ(end_progress(EndCondition{}, 100, 5e-4, 0.001, 1e6, 0.5e6), 0.0);
}
