#include "analysis/fracture_pattern.hpp"

#include <algorithm>
#include <cmath>

namespace fdem {

void symmetric_eigen3(const real in[3][3], real values[3], Vec3 vectors[3]) {
  real a[3][3], v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a[i][j] = real(0.5) * (in[i][j] + in[j][i]);
  for (int sweep = 0; sweep < 50; ++sweep) {
    const real off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const real diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= real(1e-30) * diag || off == 0) break;
    for (int p = 0; p < 2; ++p)
      for (int q = p + 1; q < 3; ++q) {
        if (a[p][q] == 0) continue;
        // Rotation in the (p,q) plane that zeroes a[p][q].
        const real theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
        const real t = (theta >= 0 ? 1 : -1) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
        const real c = 1 / std::sqrt(t * t + 1), s = t * c;
        for (int k = 0; k < 3; ++k) {  // a <- a J (columns p, q)
          const real akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - s * akq;
          a[k][q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; ++k) {  // a <- J^T a (rows p, q)
          const real apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - s * aqk;
          a[q][k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; ++k) {  // v <- v J
          const real vkp = v[k][p], vkq = v[k][q];
          v[k][p] = c * vkp - s * vkq;
          v[k][q] = s * vkp + c * vkq;
        }
      }
  }
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return a[i][i] < a[j][j]; });
  for (int k = 0; k < 3; ++k) {
    values[k] = a[order[k]][order[k]];
    vectors[k] = {v[0][order[k]], v[1][order[k]], v[2][order[k]]};
  }
}

FracturePattern fracture_pattern(const std::vector<std::array<Vec3, 3>>& faces, const std::vector<int>& mode,
                                 Vec3 axis) {
  FracturePattern r;
  const real alen = norm(axis);
  if (alen > 0) axis = (1 / alen) * axis;
  constexpr real kDeg = real(180) / real(M_PI);
  real facet = 0;
  Vec3 sum{0, 0, 0};
  std::vector<Vec3> centre(faces.size());
  std::vector<real> area(faces.size());
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const auto& f = faces[i];
    const Vec3 n2 = cross(f[1] - f[0], f[2] - f[0]);
    const real a = real(0.5) * norm(n2);
    centre[i] = (real(1) / 3) * (f[0] + f[1] + f[2]);
    area[i] = a;
    r.area += a;
    sum += a * centre[i];
    if (a > 0) facet += a * std::asin(std::min(real(1), std::fabs(dot(n2, axis)) / (2 * a))) * kDeg;
    const int m = i < mode.size() ? mode[i] : 0;
    r.mode_I += m == 1;
    r.mode_II += m == 2;
    r.mixed += m == 3;
  }
  r.broken = long(faces.size());
  if (!(r.area > 0)) return r;
  r.centroid = (1 / r.area) * sum;
  r.mean_facet_angle_deg = facet / r.area;
  if (faces.size() < 3) return r;
  real c[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  for (std::size_t i = 0; i < faces.size(); ++i) {
    const Vec3 d = centre[i] - r.centroid;
    for (int p = 0; p < 3; ++p)
      for (int q = 0; q < 3; ++q) c[p][q] += area[i] * d[p] * d[q] / r.area;
  }
  real l[3];
  Vec3 e[3];
  symmetric_eigen3(c, l, e);
  r.plane_normal = e[0];
  r.plane_angle_deg = std::asin(std::min(real(1), std::fabs(dot(e[0], axis)))) * kDeg;
  r.planarity = l[1] > 0 ? std::clamp(1 - l[0] / l[1], real(0), real(1)) : 0;
  return r;
}

}  // namespace fdem
