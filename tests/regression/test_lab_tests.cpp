// The laboratory tests users calibrate on, run as the shipped scenes describe them (reduced):
// a triaxial series whose peak strength rises with the confining pressure while the measured
// lateral stress follows the hydrostatic-then-constant path, resumed without rerunning; and a
// Brazilian disc that splits through its centre at an indirect tensile strength near f_t.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "analysis/mohr_coulomb.hpp"
#include "io/mesh_io.hpp"
#include "solver/run.hpp"
#include "solver/series.hpp"

using namespace fdem;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void replace(std::string& text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos) << "the shipped scene no longer contains '" << from << "'";
  text.replace(at, from.size(), to);
}

struct TempDir {
  fs::path path;
  TempDir() {
    path = fs::temp_directory_path() / ("fdem_lab_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

std::vector<std::map<std::string, double>> read_monitors(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  std::stringstream h(line);
  for (std::string c; std::getline(h, c, ',');) head.push_back(c);
  std::vector<std::map<std::string, double>> rows;
  while (std::getline(in, line)) {
    std::stringstream r(line);
    std::map<std::string, double> row;
    std::size_t i = 0;
    for (std::string c; std::getline(r, c, ',') && i < head.size(); ++i) row[head[i]] = std::stod(c);
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

TEST(LabTests, ReducedTriaxialSeriesStrengthensWithConfinementAndResumes) {
  // scenes/triaxial_small.yaml, coarser (5 mm elements) and at the paper's triaxial rate 0.05 m/s.
  TempDir tmp;
  std::string text = slurp(fs::path(FDEM_SOURCE_DIR) / "scenes" / "triaxial_small.yaml");
  replace(text, "element_size: 0.003", "element_size: 0.005");
  replace(text, "velocity: 0.1 ", "velocity: 0.05 ");
  replace(text, "plot: true", "plot: false");
  replace(text, "progress_interval: 2.0", "progress_interval: 0");
  const fs::path scene = tmp.path / "triaxial.yaml";
  std::ofstream(scene) << text;
  const std::vector<SeriesAxis> axes = {parse_series_axis("sigma3=0,3e6,6e6")};
  std::ostringstream log;
  const auto rows = run_series(scene.string(), axes, (tmp.path / "out").string(), 0, true, log);
  ASSERT_EQ(rows.size(), 3u);
  std::vector<real> s3, s1;
  for (const SeriesRow& r : rows) {
    EXPECT_FALSE(r.resumed);
    s3.push_back(r.number("confining_pressure_Pa"));
    s1.push_back(r.number("peak_stress_Pa"));
    std::cout << r.folder << ": sigma3 " << s3.back() / 1e6 << " MPa, peak " << s1.back() / 1e6 << " MPa, "
              << r.number("broken_ce6") << " broken, plane " << r.number("failure_plane_angle_deg") << " deg\n";
  }
  EXPECT_EQ(s3, (std::vector<real>{0, 3e6, 6e6}));
  // Strength rises with confinement, by more than sigma_3 itself (friction angle > 0).
  EXPECT_GT(s1[1], s1[0] + 3e6);
  EXPECT_GT(s1[2], s1[1] + 3e6);
  const MohrCoulombFit fit = fit_mohr_coulomb(s3, s1);
  EXPECT_GT(fit.friction_angle, 10);
  EXPECT_LT(fit.friction_angle, 45);
  RecordProperty("cohesion_MPa", std::to_string(fit.cohesion / 1e6));
  RecordProperty("friction_angle_deg", std::to_string(fit.friction_angle));

  // The lateral stress measured in the rock (middle third) follows min(axial stress, sigma_3)
  // up to the peak within 2 % of sigma_3, and the applied pressure ends at sigma_3 exactly.
  // The largest departure is a dynamic overshoot where the path turns (the radial velocity
  // reverses): about 0.05 MPa at 0.05 m/s and m = 5 whatever sigma_3, so 2.3 % of 2 MPa and
  // 1.5 % of 4 MPa (docs/validation.md); hence pressures of 3 and 6 MPa here.
  for (std::size_t i = 1; i < rows.size(); ++i) {
    const auto mon = read_monitors(fs::path(rows[i].folder) / "monitors.csv");
    std::size_t peak = 0;
    for (std::size_t k = 0; k < mon.size(); ++k)
      if (mon[k].at("axial_stress_Pa") > mon[peak].at("axial_stress_Pa")) peak = k;
    real worst = 0;
    bool held = false;
    for (std::size_t k = 0; k <= peak; ++k) {
      const real target = std::min(mon[k].at("axial_stress_Pa"), s3[i]);
      worst = std::max(worst, std::fabs(mon[k].at("lateral_stress_Pa") - target) / s3[i]);
      held = held || mon[k].at("confining_pressure_Pa") == s3[i];
    }
    EXPECT_TRUE(held);
    EXPECT_LT(worst, 0.02) << rows[i].folder;
    RecordProperty("path_error_" + std::to_string(i), std::to_string(worst));
  }

  // Run again: nothing reruns and the table is the same.
  write_series_csv((tmp.path / "a.csv").string(), rows);
  const auto again = run_series(scene.string(), axes, (tmp.path / "out").string(), 0, true, log);
  for (const SeriesRow& r : again) EXPECT_TRUE(r.resumed);
  write_series_csv((tmp.path / "b.csv").string(), again);
  EXPECT_EQ(slurp(tmp.path / "a.csv"), slurp(tmp.path / "b.csv"));
  // A changed scene reruns that run only where it changed: here, all of them.
  std::ofstream(scene, std::ios::app) << "# edited\n";
  const auto changed =
      run_series(scene.string(), {parse_series_axis("sigma3=0")}, (tmp.path / "out").string(), 0, true, log);
  EXPECT_FALSE(changed[0].resumed);
}

TEST(LabTests, BrazilianDiscSplitsThroughTheCentreNearTheTensileStrength) {
  TempDir tmp;
  Scene scene = load_scene((fs::path(FDEM_SOURCE_DIR) / "scenes" / "brazilian_small.yaml").string());
  scene.output.folder = (tmp.path / "out").string();
  scene.output.progress_interval = 0;
  scene.output.plot = false;
  // The split runs its course: to 10 % of the peak load (the scene stops at 30 %, when the
  // crack may not yet have crossed the lower part of the disc).
  scene.solver.end.post_peak_fraction = 0.1;
  Solver solver(scene, build_model(load_mesh(scene.mesh), scene));
  std::ostringstream log;
  const RunSummary r = run_scene(solver, log);
  const real ft = scene.material().tensile_strength;
  std::cout << "BTS " << r.peak_indirect_tensile / 1e6 << " MPa (f_t " << ft / 1e6 << "), " << r.fracture.broken
            << " broken, plane " << r.fracture.plane_angle_deg << " deg, planarity " << r.fracture.planarity << "\n";
  EXPECT_NEAR(r.peak_indirect_tensile, ft, 0.3 * ft);
  RecordProperty("bts_over_ft", std::to_string(r.peak_indirect_tensile / ft));

  // Through the centre: along the loaded (vertical) diameter, every fifth of its middle 60 %
  // holds broken faces within 0.1 D of it, and the best-fit crack plane contains the load axis.
  const Model& m = solver.model();
  const real D = m.height0, xc = 0.5 * (m.box_min.x + m.box_max.x), zc = m.box_min.z + 0.5 * D;
  std::vector<std::array<Vec3, 3>> faces;
  std::vector<int> mode;
  solver.broken_faces(faces, mode);
  int band[5] = {0, 0, 0, 0, 0};
  for (const auto& f : faces) {
    const Vec3 c = (real(1) / 3) * (f[0] + f[1] + f[2]);
    const real s = (c.z - (zc - 0.3 * D)) / (0.6 * D);
    if (std::fabs(c.x - xc) < 0.1 * D && s >= 0 && s < 1) ++band[int(5 * s)];
  }
  for (int b = 0; b < 5; ++b) EXPECT_GT(band[b], 0) << "no broken face near the loaded diameter in band " << b;
  std::cout << "central bands " << band[0] << " " << band[1] << " " << band[2] << " " << band[3] << " " << band[4]
            << "\n";
  EXPECT_LT(r.fracture.plane_angle_deg, 15);
  EXPECT_GT(std::fabs(r.fracture.plane_normal.x), 0.9);  // the plane of the load and the disc axis
}
