// Heterogeneous rock (a material's `heterogeneity`): each CE6's strength factor is drawn from a
// Weibull or a normal distribution of mean 1. The draws follow their distribution (a
// Kolmogorov-Smirnov test that fails for the wrong one), depend on the seed and the CE6 alone,
// and a model of them runs the same on every schedule and the debug backend.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "backend_support.hpp"
#include "cli_support.hpp"
#include "model/heterogeneity.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// The Kolmogorov-Smirnov statistic of `draws` against the CDF F: the largest distance between
/// the empirical CDF and F.
real ks_distance(std::vector<real> draws, const std::function<real(real)>& F) {
  std::sort(draws.begin(), draws.end());
  const real n = real(draws.size());
  real d = 0;
  for (std::size_t i = 0; i < draws.size(); ++i) {
    const real f = F(draws[i]);
    d = std::max({d, std::fabs((i + 1) / n - f), std::fabs(i / n - f)});
  }
  return d;
}

/// The 1 % critical value of the KS statistic for n draws (large n).
real ks_critical(std::size_t n) {
  return 1.628 / std::sqrt(real(n));
}

std::vector<real> draws_of(const Heterogeneity& h, std::size_t n) {
  std::vector<real> d(n);
  for (std::size_t i = 0; i < n; ++i) d[i] = strength_draw(h, i);
  return d;
}

real weibull_cdf(real s, real m) {
  const real lambda = 1 / std::tgamma(1 + 1 / m);
  return 1 - std::exp(-std::pow(s / lambda, m));
}

real normal_cdf(real s, real mean, real deviation) {
  return 0.5 * std::erfc(-(s - mean) / (deviation * std::sqrt(2.0)));
}

Heterogeneity weibull(real m, std::uint64_t seed = 1) {
  Heterogeneity h;
  h.distribution = StrengthSpread::weibull, h.modulus = m, h.seed = seed;
  return h;
}

std::string spread_scene(const std::string& spread, const std::string& backend = "cpu") {
  return "name: spread\n"
         "mesh: {generate: {shape: box, size: [0.01, 0.01, 0.02], element_size: 0.0025}}\n"
         "materials:\n"
         "  - {name: lower, groups: [lower], heterogeneity: " +
         spread +
         "}\n"
         "  - {name: upper, groups: [upper]}\n"
         "platens: none\n"
         "contact: {activation: none}\n"
         "boundary_conditions:\n"
         "  - {surface: zmin, type: fixed}\n"
         "  - {surface: zmax, type: velocity, velocity: [0, 0, 2], time_function: {shape: smooth, duration: 1e-5}}\n"
         "solver: {threads: 1, backend: " +
         backend +
         ", end: {time: 1e-4}}\n"
         "output: {progress_interval: 0, plot: false}\n";
}

}  // namespace

TEST(Heterogeneity, WeibullDrawsFollowTheirDistributionAndNotANormalOne) {
  // 20,000 draws of modulus 6: the KS distance to Weibull(6) of mean 1 is below the 1 % critical
  // value, and to the normal of the same mean and deviation (which has no skew) above it.
  for (const real m : {3.0, 6.0, 12.0}) {
    SCOPED_TRACE(m);
    const std::vector<real> d = draws_of(weibull(m), 20000);
    const real D = ks_distance(d, [&](real s) { return weibull_cdf(s, m); });
    RecordProperty("ks_weibull_m" + std::to_string(int(m)), std::to_string(D));
    EXPECT_LT(D, ks_critical(d.size()));
    real mean = 0, var = 0;
    for (real s : d) mean += s / d.size();
    for (real s : d) var += (s - mean) * (s - mean) / (d.size() - 1);
    EXPECT_NEAR(mean, 1, 4 * std::sqrt(var / d.size())) << "mean 1";
    const real sd = std::sqrt(std::tgamma(1 + 2 / m) / std::pow(std::tgamma(1 + 1 / m), 2) - 1);
    EXPECT_NEAR(std::sqrt(var), sd, 0.03 * sd) << "Weibull's deviation";
    EXPECT_GT(ks_distance(d, [&](real s) { return normal_cdf(s, 1, sd); }), ks_critical(d.size()))
        << "the test tells Weibull from normal";
  }
}

TEST(Heterogeneity, NormalDrawsFollowTheirDistribution) {
  Heterogeneity h;
  h.distribution = StrengthSpread::normal, h.deviation = 0.2, h.seed = 3;
  const std::vector<real> d = draws_of(h, 20000);
  const real D = ks_distance(d, [&](real s) { return normal_cdf(s, 1, 0.2); });
  RecordProperty("ks_normal", std::to_string(D));
  EXPECT_LT(D, ks_critical(d.size()));
  EXPECT_GT(ks_distance(d, [&](real s) { return normal_cdf(s, 1, 0.25); }), ks_critical(d.size()))
      << "a wrong deviation is told apart";
  EXPECT_GT(*std::min_element(d.begin(), d.end()), 0) << "no strength at or below zero";
}

TEST(Heterogeneity, TheDrawsDependOnTheSeedAndTheCe6Alone) {
  // Two builds draw the same factors; another seed draws others. The CE6s of the homogeneous
  // material's law keep factor 1 exactly. (Those between the two take the heterogeneous one's
  // law, the weaker on a tie of strengths, and its draws.)
  const Scene a = parse_scene(spread_scene("{distribution: weibull, modulus: 6, seed: 7}"), "spread.yaml");
  const Model m1 = build_model(test::layered_box(), a), m2 = build_model(test::layered_box(), a);
  ASSERT_EQ(m1.ce6_strength.size(), m1.ce6_nodes.size());
  EXPECT_EQ(m1.ce6_strength, m2.ce6_strength);
  const Scene b = parse_scene(spread_scene("{distribution: weibull, modulus: 6, seed: 8}"), "spread.yaml");
  const Model m3 = build_model(test::layered_box(), b);
  std::vector<real> lower;
  int same = 0;
  for (std::size_t c = 0; c < m1.ce6_nodes.size(); ++c) {
    if (m1.ce6_law[c] != 0) {
      EXPECT_EQ(m1.ce6_strength[c], 1) << "CE6 " << c << " has the homogeneous material's law";
      continue;
    }
    lower.push_back(m1.ce6_strength[c]);
    same += m1.ce6_strength[c] == m3.ce6_strength[c];
    EXPECT_EQ(m1.ce6_strength[c], strength_draw(a.materials[0].heterogeneity, c)) << "draw c of the seed";
  }
  ASSERT_GT(lower.size(), 500u);
  EXPECT_EQ(same, 0) << "another seed, other draws";
  EXPECT_LT(ks_distance(lower, [](real s) { return weibull_cdf(s, 6); }), ks_critical(lower.size()));
  // Without heterogeneity the model holds no factors (the passes read none).
  EXPECT_TRUE(build_model(test::layered_box(), parse_scene(spread_scene("{distribution: none}"), "spread.yaml"))
                  .ce6_strength.empty());
}

TEST(Heterogeneity, AHeterogeneousRockRunsTheSameOnEveryScheduleAndTheDebugBackend) {
  // The box pulled apart at 2 m/s until CE6s break in the heterogeneous layer: the strength
  // factors are read by slot, and the factors on E by tet, on the colour passes and the fused
  // pass alike.
  auto run = [&](const std::string& backend, const char* schedule) {
    test::EnvSetting env("FDEM_DEVICE_SCHEDULE", schedule);
    const Scene s = parse_scene(
        spread_scene("{distribution: weibull, modulus: 3, seed: 7, youngs_modulus: true}", backend), "spread.yaml");
    Solver solver(s, build_model(test::layered_box(), s));
    while (solver.time() < 4e-5) solver.step();
    solver.sync_host();
    return std::make_pair(solver.state.x, solver.measure());
  };
  const auto [x, row] = run("cpu", "colour");
  EXPECT_GT(row.damaged + row.broken, 0) << "the draws are tested where they act";
  for (const char* schedule : {"colour", "fused"})
    for (const char* backend : {"cpu", "debug"}) {
      SCOPED_TRACE(std::string(backend) + ", " + schedule);
      const auto [y, other] = run(backend, schedule);
      EXPECT_LT(test::largest_distance(x, y), 1e-18) << "m";
      EXPECT_EQ(row.broken, other.broken);
      EXPECT_EQ(row.damaged, other.damaged);
    }
}

TEST(Heterogeneity, TetModuliAreDrawnFromTheirOwnStream) {
  // youngs_modulus: each tet of the material draws a factor on E from a second stream, which
  // follows the distribution and is not the strengths' stream.
  const Scene a =
      parse_scene(spread_scene("{distribution: weibull, modulus: 6, seed: 7, youngs_modulus: true}"), "spread.yaml");
  const Model m = build_model(test::layered_box(), a);
  ASSERT_EQ(m.tet_stiffness.size(), m.tet_nodes.size());
  std::vector<real> lower;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (m.tet_material[t] != 0) {
      EXPECT_EQ(m.tet_stiffness[t], 1) << "tet " << t << " is homogeneous";
      continue;
    }
    EXPECT_EQ(m.tet_stiffness[t], stiffness_draw(a.materials[0].heterogeneity, t));
    lower.push_back(m.tet_stiffness[t]);
  }
  ASSERT_EQ(lower.size(), 384u);
  EXPECT_LT(ks_distance(lower, [](real s) { return weibull_cdf(s, 6); }), ks_critical(lower.size()));
  const std::vector<real> e = [&] {
    std::vector<real> d(20000);
    for (std::size_t i = 0; i < d.size(); ++i) d[i] = stiffness_draw(a.materials[0].heterogeneity, i);
    return d;
  }();
  const std::vector<real> f = draws_of(a.materials[0].heterogeneity, e.size());
  EXPECT_LT(ks_distance(e, [](real s) { return weibull_cdf(s, 6); }), ks_critical(e.size()));
  real mean_e = 0, mean_f = 0, cov = 0, var_e = 0, var_f = 0;
  for (std::size_t i = 0; i < e.size(); ++i) mean_e += e[i] / e.size(), mean_f += f[i] / f.size();
  for (std::size_t i = 0; i < e.size(); ++i) {
    cov += (e[i] - mean_e) * (f[i] - mean_f);
    var_e += (e[i] - mean_e) * (e[i] - mean_e), var_f += (f[i] - mean_f) * (f[i] - mean_f);
  }
  EXPECT_LT(std::fabs(cov / std::sqrt(var_e * var_f)), 0.03) << "the two streams are uncorrelated";
}

TEST(Heterogeneity, ARandomModulusStiffensTheBoxBetweenTheReussAndVoigtBounds) {
  // A box of E drawn per tet (Weibull m = 3) on rollers, its end moved 3 um and at rest: the
  // effective modulus F L / (A d) lies between the harmonic (Reuss) and arithmetic (Voigt)
  // volume means of the tets' E (FE solutions obey both: a uniform strain is a trial field of
  // the mesh, and the mesh is stiffer than the exact solid). A run ignoring the factors would
  // give E, above this draw's Voigt mean.
  test::RollerBox box;
  box.rock = "material: {heterogeneity: {distribution: weibull, modulus: 3, seed: 11, youngs_modulus: true}}\n";
  const std::string yaml = test::roller_box_scene(box);
  const Scene scene = parse_scene(yaml, "moduli.yaml");
  Solver s(scene, build_model(test::layered_box(), scene));
  const Model& m = s.model();
  real volume = 0, voigt = 0, reuss = 0;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const real E = scene.material().youngs_modulus * m.tet_stiffness[t];
    volume += m.tet_V0[t], voigt += m.tet_V0[t] * E, reuss += m.tet_V0[t] / E;
  }
  voigt /= volume, reuss = volume / reuss;
  while (s.time() < 3e-4) s.step();
  const Monitors r = s.measure();
  const real d = 0.05 * (1e-5 + 4e-5 + 1e-5), effective = -r.conditions[4 * 3 + 2] * 0.02 / (1e-4 * d);
  RecordProperty("effective_over_voigt", std::to_string(effective / voigt));
  RecordProperty("reuss_over_voigt", std::to_string(reuss / voigt));
  EXPECT_GT(effective, reuss);
  EXPECT_LT(effective, 0.995 * voigt) << "measured 0.986; E everywhere would give 1.002 of it";
  EXPECT_LT(r.kinetic, 1e-9 * r.strain) << "at rest";
}

TEST(Heterogeneity, AModelDrawnForOneLawIsRefusedByAScenesWeakerLaw) {
  // Rank files keep the factors drawn at the partition: a run whose scene gives the material a
  // fracture energy too small for the strongest draws refuses them instead of breaking those
  // CE6s with no softening.
  const std::string spread = "{distribution: weibull, modulus: 3, seed: 7}";
  const Scene drawn = parse_scene(spread_scene(spread), "spread.yaml");
  const Model m = build_model(test::layered_box(), drawn);
  std::string yaml = spread_scene(spread);
  yaml.replace(yaml.find("groups: [lower],"), 16, "groups: [lower], fracture_energy_I: 0.005,");
  const Scene weaker = parse_scene(yaml, "spread.yaml");
  ASSERT_EQ(weaker.materials[0].fracture_energy_I, 0.005);
  try {
    Solver s(weaker, m);
    ADD_FAILURE() << "the factors were taken";
  } catch (const InputError& e) {
    EXPECT_TRUE(cli_test::has(e.what(), "beyond what this scene's cohesive law takes at its size")) << e.what();
  }
  Solver same(drawn, m);  // the scene it was drawn for takes them
  EXPECT_EQ(same.model().ce6_strength, m.ce6_strength);
}

TEST(Heterogeneity, TheSceneKeysAreCheckedWithTheFix) {
  auto error_of = [](const std::string& spread) {
    return test::build_error(spread_scene(spread), "spread.yaml", test::layered_box());
  };
  std::string e = error_of("{distribution: weibull}");
  EXPECT_TRUE(cli_test::has(e, "materials[0].heterogeneity.modulus: missing")) << e;
  e = error_of("{distribution: normal, modulus: 3}");
  EXPECT_TRUE(cli_test::has(e, "heterogeneity.deviation: missing")) << e;
  EXPECT_TRUE(cli_test::has(e, "heterogeneity.modulus: is not read for distribution normal")) << e;
  e = error_of("{distribution: normal, deviation: 0.6}");
  EXPECT_TRUE(cli_test::has(e, "heterogeneity.deviation: 0.6 is out of range")) << e;
  e = error_of("{distribution: gamma}");
  EXPECT_TRUE(cli_test::has(e, "heterogeneity.distribution: 'gamma' is not recognised")) << e;
  // A draw too strong for the cohesive law at the CE6's size.
  e = error_of("{distribution: weibull, modulus: 0.6, seed: 1}");
  EXPECT_TRUE(cli_test::has(e, "materials[0] ('lower').heterogeneity: CE6")) << e;
  EXPECT_TRUE(cli_test::has(e, "narrow the spread")) << e;
}
