// Comparing runs: the relative L2 curve error, the Jaccard overlap of broken-CE6 sets, the
// Pareto front of speed against error, and the study budget syntax.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/run_comparison.hpp"
#include "core/error.hpp"
#include "solver/study.hpp"

using namespace fdem;

namespace {

StressStrainCurve line(real modulus, real de, int n, real offset = 0) {
  StressStrainCurve c;
  for (int i = 0; i <= n; ++i) {
    c.strain.push_back(offset + i * de);
    c.stress.push_back(modulus * (offset + i * de));
  }
  return c;
}

}  // namespace

TEST(RunComparison, CurveErrorOfAScaledCurveIsTheScale) {
  const StressStrainCurve ref = line(12e9, 1e-5, 100);
  EXPECT_NEAR(curve_error(ref, line(13.2e9, 1e-5, 100), 0, 1).error, 0.1, 1e-12);
  EXPECT_EQ(curve_error(ref, ref, 0, 1).error, 0);
  EXPECT_EQ(curve_error(ref, ref, 0, 1).points, 101);
}

TEST(RunComparison, CurveErrorInterpolatesTheVariantExactlyOnALine) {
  // The same straight line sampled at other strains: no error at the compared points.
  const StressStrainCurve ref = line(12e9, 1e-5, 100), other = line(12e9, 0.7e-5, 200, 0.3e-6);
  const CurveError e = curve_error(ref, other, 2e-4, 8e-4);
  EXPECT_NEAR(e.error, 0, 1e-13);
  EXPECT_EQ(e.points, 61);
  // Points past the variant's end are left out, not extrapolated.
  const CurveError shorter = curve_error(ref, line(12e9, 1e-5, 50), 0, 1);
  EXPECT_EQ(shorter.points, 51);
  EXPECT_TRUE(std::isnan(curve_error(ref, ref, 2, 3).error));
}

TEST(RunComparison, CurveErrorInAWindowWeighsOnlyThatWindow) {
  // Variant differs by +1 MPa only beyond strain 5e-4: no error before, the exact L2 after.
  StressStrainCurve ref = line(12e9, 1e-5, 100), v = ref;
  real num = 0, den = 0;
  for (std::size_t i = 0; i < v.strain.size(); ++i)
    if (v.strain[i] > 5e-4 + 1e-12) {
      v.stress[i] += 1e6;
      num += 1e12;
      den += ref.stress[i] * ref.stress[i];
    }
  EXPECT_NEAR(curve_error(ref, v, 0, 5e-4).error, 0, 1e-12);
  EXPECT_NEAR(curve_error(ref, v, 5.05e-4, 1).error, std::sqrt(num / den), 1e-12);
}

TEST(RunComparison, JaccardOfBrokenSets) {
  EXPECT_EQ(jaccard({1, 2, 3}, {3, 2, 1}), 1);
  EXPECT_EQ(jaccard({1, 2, 3, 4}, {3, 4, 5, 6}), 2.0 / 6.0);
  EXPECT_EQ(jaccard({1, 2}, {3}), 0);
  EXPECT_EQ(jaccard({}, {}), 1);
  EXPECT_EQ(jaccard({1, 1, 2}, {2}), 0.5);  // a set: duplicates count once
}

TEST(RunComparison, ParetoFrontKeepsTheUndominated) {
  // speed-up, error: (1, 0) reference; (2, 0.01) and (5, 0.03) on the front; (1.5, 0.02) is
  // dominated by (2, 0.01); (4, NaN) unstable.
  const std::vector<real> speed = {1, 2, 1.5, 5, 4};
  const std::vector<real> error = {0, 0.01, 0.02, 0.03, NAN};
  EXPECT_EQ(pareto_front(speed, error), (std::vector<bool>{true, true, false, true, false}));
}

TEST(RunComparison, BudgetsParsePercentAndFractions) {
  const auto b = parse_budget({"peak=2%,curve_pre=0.05", "jaccard=0.8"});
  EXPECT_DOUBLE_EQ(b.at(StudyMetric::peak), 0.02);
  EXPECT_DOUBLE_EQ(b.at(StudyMetric::curve_pre), 0.05);
  EXPECT_DOUBLE_EQ(b.at(StudyMetric::jaccard), 0.8);
  EXPECT_THROW(parse_budget({"speed=2"}), InputError);
  EXPECT_THROW(parse_budget({"peak=-1%"}), InputError);
  EXPECT_THROW(parse_budget({"jaccard=2"}), InputError);
  EXPECT_THROW(parse_budget({"peak"}), InputError);
}

TEST(RunComparison, ReferenceValuesAreTypedSeriesKeys) {
  const SeriesValues r = parse_reference("activation=full,platen_speed=0.05");
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].key, SeriesKey::activation);
  EXPECT_EQ(r[0].value, "full");
  EXPECT_EQ(r[1].key, SeriesKey::platen_velocity);  // the alias --vary accepts too
  EXPECT_EQ(r[1].value, "0.05");
  EXPECT_THROW(parse_reference("speed=2"), InputError);
  EXPECT_THROW(parse_reference("activation"), InputError);
}
