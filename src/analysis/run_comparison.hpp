#pragma once
// Speed against error: how far a variant of a run is from a reference run.
//
// Curve error: the relative L2 distance of two axial stress-strain curves on the reference's
// monitor points in a strain window [lo, hi], the variant interpolated linearly:
//   e = sqrt( sum_i (s(e_i) - s_ref(e_i))^2 / sum_i s_ref(e_i)^2 ).
// Points past the end of the variant's curve are left out (and reported by `points`).
// Fracture pattern: the Jaccard index |A n B| / |A u B| of the sets of broken CE6 ids
// (1 identical, 0 disjoint; 1 when both are empty); only meaningful on the same mesh.
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

struct StressStrainCurve {
  std::vector<real> strain, stress;  // axial strain (-), axial stress (Pa), in monitor order
};

/// Reads axial_strain and axial_stress_Pa of a monitors.csv; throws InputError naming the file.
StressStrainCurve read_stress_strain(const std::string& monitors_csv);

struct CurveError {
  real error = 0;  // relative L2, NaN when no point was compared
  int points = 0;  // reference points compared
};

CurveError curve_error(const StressStrainCurve& ref, const StressStrainCurve& c, real lo, real hi);

/// Reads the ce6 column of a broken_ce6.csv, the rock's rows only (not a joint's; empty when the
/// file is missing).
std::vector<long> read_broken_ce6(const std::string& path);

real jaccard(std::vector<long> a, std::vector<long> b);

/// Points not dominated by another: for each i, no j with speed[j] >= speed[i] and
/// error[j] <= error[i], one of them strictly. NaN entries are never on the front.
std::vector<bool> pareto_front(const std::vector<real>& speed, const std::vector<real>& error);

}  // namespace fdem
