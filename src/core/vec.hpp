#pragma once
// Small value types usable on host and device. Mat3 is row-major: a[i][j].
#include <cmath>

#include "core/config.hpp"

namespace fdem {

struct Vec3 {
  real x, y, z;
  FDEM_HD real& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  FDEM_HD real operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

FDEM_HD Vec3 operator+(Vec3 a, Vec3 b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
FDEM_HD Vec3 operator-(Vec3 a, Vec3 b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
FDEM_HD Vec3 operator-(Vec3 a) {
  return {-a.x, -a.y, -a.z};
}
FDEM_HD Vec3 operator*(real s, Vec3 a) {
  return {s * a.x, s * a.y, s * a.z};
}
FDEM_HD Vec3 operator*(Vec3 a, real s) {
  return {s * a.x, s * a.y, s * a.z};
}
FDEM_HD Vec3& operator+=(Vec3& a, Vec3 b) {
  a.x += b.x;
  a.y += b.y;
  a.z += b.z;
  return a;
}
FDEM_HD Vec3& operator-=(Vec3& a, Vec3 b) {
  a.x -= b.x;
  a.y -= b.y;
  a.z -= b.z;
  return a;
}
FDEM_HD real dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
FDEM_HD Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
FDEM_HD real norm(Vec3 a) {
  return std::sqrt(dot(a, a));
}

struct Mat3 {
  real a[3][3];
  FDEM_HD static Mat3 zero() { return {{{0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}; }
  FDEM_HD static Mat3 identity() { return {{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}; }
  /// Matrix whose columns are c0, c1, c2.
  FDEM_HD static Mat3 from_columns(Vec3 c0, Vec3 c1, Vec3 c2) {
    return {{{c0.x, c1.x, c2.x}, {c0.y, c1.y, c2.y}, {c0.z, c1.z, c2.z}}};
  }
  FDEM_HD Vec3 column(int j) const { return {a[0][j], a[1][j], a[2][j]}; }
};

FDEM_HD Mat3 operator*(const Mat3& p, const Mat3& q) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = p.a[i][0] * q.a[0][j] + p.a[i][1] * q.a[1][j] + p.a[i][2] * q.a[2][j];
  return r;
}
FDEM_HD Vec3 operator*(const Mat3& p, Vec3 v) {
  return {p.a[0][0] * v.x + p.a[0][1] * v.y + p.a[0][2] * v.z, p.a[1][0] * v.x + p.a[1][1] * v.y + p.a[1][2] * v.z,
          p.a[2][0] * v.x + p.a[2][1] * v.y + p.a[2][2] * v.z};
}
FDEM_HD Mat3 operator+(const Mat3& p, const Mat3& q) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = p.a[i][j] + q.a[i][j];
  return r;
}
FDEM_HD Mat3 operator*(real s, const Mat3& p) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = s * p.a[i][j];
  return r;
}
FDEM_HD Mat3 transpose(const Mat3& p) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.a[i][j] = p.a[j][i];
  return r;
}
FDEM_HD real trace(const Mat3& p) {
  return p.a[0][0] + p.a[1][1] + p.a[2][2];
}
FDEM_HD real det(const Mat3& p) {
  return p.a[0][0] * (p.a[1][1] * p.a[2][2] - p.a[1][2] * p.a[2][1]) -
         p.a[0][1] * (p.a[1][0] * p.a[2][2] - p.a[1][2] * p.a[2][0]) +
         p.a[0][2] * (p.a[1][0] * p.a[2][1] - p.a[1][1] * p.a[2][0]);
}
/// Inverse; the caller guarantees det(p) != 0.
FDEM_HD Mat3 inverse(const Mat3& p) {
  const real d = det(p);
  const real s = real(1) / d;
  Mat3 r;
  r.a[0][0] = s * (p.a[1][1] * p.a[2][2] - p.a[1][2] * p.a[2][1]);
  r.a[0][1] = s * (p.a[0][2] * p.a[2][1] - p.a[0][1] * p.a[2][2]);
  r.a[0][2] = s * (p.a[0][1] * p.a[1][2] - p.a[0][2] * p.a[1][1]);
  r.a[1][0] = s * (p.a[1][2] * p.a[2][0] - p.a[1][0] * p.a[2][2]);
  r.a[1][1] = s * (p.a[0][0] * p.a[2][2] - p.a[0][2] * p.a[2][0]);
  r.a[1][2] = s * (p.a[0][2] * p.a[1][0] - p.a[0][0] * p.a[1][2]);
  r.a[2][0] = s * (p.a[1][0] * p.a[2][1] - p.a[1][1] * p.a[2][0]);
  r.a[2][1] = s * (p.a[0][1] * p.a[2][0] - p.a[0][0] * p.a[2][1]);
  r.a[2][2] = s * (p.a[0][0] * p.a[1][1] - p.a[0][1] * p.a[1][0]);
  return r;
}
/// Rotation by `angle` (rad) about the axis `axis` (any length > 0; Rodrigues' formula).
FDEM_HD Mat3 rotation(Vec3 axis, real angle) {
  const Vec3 u = (real(1) / norm(axis)) * axis;
  const real c = std::cos(angle), s = std::sin(angle), t = 1 - c;
  return {{{t * u.x * u.x + c, t * u.x * u.y - s * u.z, t * u.x * u.z + s * u.y},
           {t * u.x * u.y + s * u.z, t * u.y * u.y + c, t * u.y * u.z - s * u.x},
           {t * u.x * u.z - s * u.y, t * u.y * u.z + s * u.x, t * u.z * u.z + c}}};
}

/// Symmetric 3x3 stored as xx, yy, zz, yz, xz, xy (Voigt order).
struct Sym3 {
  real xx, yy, zz, yz, xz, xy;
};
FDEM_HD Sym3 to_sym(const Mat3& p) {
  return {p.a[0][0],
          p.a[1][1],
          p.a[2][2],
          real(0.5) * (p.a[1][2] + p.a[2][1]),
          real(0.5) * (p.a[0][2] + p.a[2][0]),
          real(0.5) * (p.a[0][1] + p.a[1][0])};
}
FDEM_HD Vec3 operator*(const Sym3& s, Vec3 v) {
  return {s.xx * v.x + s.xy * v.y + s.xz * v.z, s.xy * v.x + s.yy * v.y + s.yz * v.z,
          s.xz * v.x + s.yz * v.y + s.zz * v.z};
}
FDEM_HD real von_mises(const Sym3& s) {
  const real a = s.xx - s.yy, b = s.yy - s.zz, c = s.zz - s.xx;
  return std::sqrt(real(0.5) * (a * a + b * b + c * c) + 3 * (s.yz * s.yz + s.xz * s.xz + s.xy * s.xy));
}

/// All three components zero (of either sign).
FDEM_HD bool is_zero(Vec3 a) {
  return a.x == 0 && a.y == 0 && a.z == 0;
}

/// A finite number (NaN and inf fail), on host and device alike.
FDEM_HD bool finite_value(real a) {
  return a - a == 0;
}

}  // namespace fdem
