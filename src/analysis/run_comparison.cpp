#include "analysis/run_comparison.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace fdem {

StressStrainCurve read_stress_strain(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot read the monitor CSV (was the run finished?)");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  {
    std::stringstream h(line);
    for (std::string c; std::getline(h, c, ',');) head.push_back(c);
  }
  const auto col = [&](const std::string& name) {
    const auto it = std::find(head.begin(), head.end(), name);
    if (it == head.end()) throw InputError(path + ": no column " + name + " in the header");
    return std::size_t(it - head.begin());
  };
  const std::size_t ce = col("axial_strain"), cs = col("axial_stress_Pa");
  StressStrainCurve c;
  while (std::getline(in, line)) {
    std::stringstream r(line);
    std::vector<std::string> cells;
    for (std::string x; std::getline(r, x, ',');) cells.push_back(x);
    if (cells.size() <= std::max(ce, cs)) continue;
    c.strain.push_back(std::stod(cells[ce]));
    c.stress.push_back(std::stod(cells[cs]));
  }
  return c;
}

CurveError curve_error(const StressStrainCurve& ref, const StressStrainCurve& c, real lo, real hi) {
  CurveError out;
  real num = 0, den = 0;
  std::size_t j = 0;
  for (std::size_t i = 0; i < ref.strain.size(); ++i) {
    const real e = ref.strain[i];
    if (e < lo || e > hi) continue;
    // The variant's stress at strain e: first bracketing segment (strain grows monotonically
    // with the platen travel).
    while (j + 1 < c.strain.size() && c.strain[j + 1] < e) ++j;
    if (j + 1 >= c.strain.size() || c.strain[j] > e) continue;
    const real e0 = c.strain[j], e1 = c.strain[j + 1];
    const real w = e1 > e0 ? (e - e0) / (e1 - e0) : 0;
    const real s = (1 - w) * c.stress[j] + w * c.stress[j + 1];
    num += (s - ref.stress[i]) * (s - ref.stress[i]);
    den += ref.stress[i] * ref.stress[i];
    ++out.points;
  }
  out.error = out.points > 0 && den > 0 ? std::sqrt(num / den) : NAN;
  return out;
}

std::vector<long> read_broken_ce6(const std::string& path) {
  std::vector<long> ids;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    // ce6,mode,joint: a row whose joint field is not empty is a joint's, not the rock's.
    const std::size_t second = line.find(',', line.find(',') + 1);
    const bool joint = second != std::string::npos && second + 1 < line.size();
    if (!line.empty() && !joint) ids.push_back(std::stol(line.substr(0, line.find(','))));
  }
  return ids;
}

real jaccard(std::vector<long> a, std::vector<long> b) {
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  a.erase(std::unique(a.begin(), a.end()), a.end());
  b.erase(std::unique(b.begin(), b.end()), b.end());
  if (a.empty() && b.empty()) return 1;
  std::vector<long> both;
  std::set_intersection(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(both));
  return real(both.size()) / real(a.size() + b.size() - both.size());
}

std::vector<bool> pareto_front(const std::vector<real>& speed, const std::vector<real>& error) {
  const std::size_t n = speed.size();
  std::vector<bool> front(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isnan(speed[i]) || std::isnan(error[i])) continue;
    bool dominated = false;
    for (std::size_t j = 0; j < n && !dominated; ++j) {
      if (j == i || std::isnan(speed[j]) || std::isnan(error[j])) continue;
      dominated = speed[j] >= speed[i] && error[j] <= error[i] && (speed[j] > speed[i] || error[j] < error[i]);
    }
    front[i] = !dominated;
  }
  return front;
}

}  // namespace fdem
