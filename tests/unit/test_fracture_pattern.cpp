// Fracture-pattern statistics: the eigen-solver against Eigen, the failure-plane angle of
// faces laid on known planes, and the planarity of scattered cracks.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "analysis/fracture_pattern.hpp"

using namespace fdem;

namespace {

constexpr real kPi = real(M_PI);

// A small triangle centred at c, lying in the plane spanned by unit vectors e1, e2.
std::array<Vec3, 3> triangle(Vec3 c, Vec3 e1, Vec3 e2, real s) {
  return {c + s * e1, c + (-s / 2) * e1 + (s * real(0.866)) * e2, c + (-s / 2) * e1 + (-s * real(0.866)) * e2};
}

}  // namespace

TEST(FracturePattern, EigenMatchesEigenLibrary) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<real> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    real a[3][3];
    Eigen::Matrix3d m;
    for (int i = 0; i < 3; ++i)
      for (int j = i; j < 3; ++j) m(i, j) = m(j, i) = a[i][j] = a[j][i] = u(rng);
    real l[3];
    Vec3 e[3];
    symmetric_eigen3(a, l, e);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> ref(m);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(l[k], ref.eigenvalues()(k), 1e-12);
      const Eigen::Vector3d v(e[k].x, e[k].y, e[k].z);
      EXPECT_NEAR((m * v - l[k] * v).norm(), 0, 1e-12);
      EXPECT_NEAR(v.norm(), 1, 1e-12);
    }
  }
}

TEST(FracturePattern, PlaneAtKnownAngleToTheAxis) {
  const Vec3 axis{0, 0, 2};  // need not be unit
  for (real deg : {0.0, 20.0, 30.0, 45.0, 60.0, 90.0}) {
    const real t = deg * kPi / 180;
    // Plane containing the y axis, tilted by t from the z axis: normal (cos t, 0, -sin t)... n.z = sin t.
    const Vec3 e1{0, 1, 0}, e2{std::sin(t), 0, std::cos(t)};
    std::vector<std::array<Vec3, 3>> faces;
    std::vector<int> mode;
    std::mt19937 rng(7);
    std::uniform_real_distribution<real> u(-0.02, 0.02);
    for (int i = 0; i < 200; ++i) {
      const Vec3 c = Vec3{0.1, 0.2, 0.3} + u(rng) * e1 + u(rng) * e2;
      faces.push_back(triangle(c, e1, e2, 0.001));
      mode.push_back(1 + i % 3);
    }
    const FracturePattern p = fracture_pattern(faces, mode, axis);
    EXPECT_NEAR(p.plane_angle_deg, deg, 1e-6) << deg;
    EXPECT_NEAR(p.mean_facet_angle_deg, deg, 1e-4) << deg;
    EXPECT_GT(p.planarity, 0.999);
    EXPECT_EQ(p.broken, 200);
    EXPECT_EQ(p.mode_I + p.mode_II + p.mixed, 200);
    EXPECT_EQ(p.mode_I, 67);
    EXPECT_NEAR(p.area, 200 * 0.75 * std::sqrt(3.0) * 1e-6 * 0.866 / (std::sqrt(3.0) / 2), 1e-9);
  }
}

TEST(FracturePattern, TiltedFacetsKeepThePlaneAngle) {
  // Facets tilted by 25 deg about the plane's in-plane direction e1 (a staircase along element
  // faces): the best-fit plane through their centres stays at 30 deg, the facets are at 55 deg.
  const real t = 30 * kPi / 180, z = 25 * kPi / 180;
  const Vec3 e1{0, 1, 0}, e2{std::sin(t), 0, std::cos(t)}, n{std::cos(t), 0, -std::sin(t)};
  std::vector<std::array<Vec3, 3>> faces;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      const Vec3 f2 = std::cos(z) * e2 + std::sin(z) * n;
      faces.push_back(triangle(real(0.001) * i * e1 + real(0.001) * j * e2, e1, f2, 0.0004));
    }
  const FracturePattern p = fracture_pattern(faces, std::vector<int>(faces.size(), 3), {0, 0, 1});
  EXPECT_NEAR(p.plane_angle_deg, 30, 1e-6);
  EXPECT_NEAR(p.mean_facet_angle_deg, 55, 1e-6);
  EXPECT_EQ(p.mixed, 1600);
}

TEST(FracturePattern, ScatteredCracksAreNotPlanar) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<real> u(0, 0.05), a(0, 2 * kPi);
  std::vector<std::array<Vec3, 3>> faces;
  for (int i = 0; i < 500; ++i) {
    const real p = a(rng), q = a(rng);
    const Vec3 e1{std::cos(p), std::sin(p), 0}, e2{-std::sin(p) * std::cos(q), std::cos(p) * std::cos(q), std::sin(q)};
    faces.push_back(triangle({u(rng), u(rng), u(rng)}, e1, e2, 0.001));
  }
  const FracturePattern p = fracture_pattern(faces, std::vector<int>(faces.size(), 1), {0, 0, 1});
  EXPECT_LT(p.planarity, 0.3);
  EXPECT_EQ(p.mode_I, 500);
}

TEST(FracturePattern, NoFacesGiveZeros) {
  const FracturePattern p = fracture_pattern({}, {}, {0, 0, 1});
  EXPECT_EQ(p.broken, 0);
  EXPECT_EQ(p.area, 0);
  EXPECT_EQ(p.planarity, 0);
}
