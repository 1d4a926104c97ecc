// History entries (scene `history`): monitors.csv's displacement, velocity and stress at a point
// of the rock or over a mesh group, against the closed-form state of a box under uniaxial stress
// at rest, and the errors a scene gets for entries that do not fit its mesh or its columns.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "cli_support.hpp"
#include "core/error.hpp"
#include "solver/run_folder.hpp"
#include "support.hpp"

using namespace fdem;

namespace {

/// The roller box pressed 3 um along z and then at rest, with the history points given.
Scene pressed_box(const std::string& history) {
  test::RollerBox b;
  b.extra = "history: " + history + "\n";
  // (extra goes after the conditions' list: a top-level key there ends it)
  return parse_scene(test::roller_box_scene(b), "box.yaml");
}

std::string setup_error(const std::string& history) {
  try {
    const Scene s = pressed_box(history);
    Solver solver(s, build_model(test::layered_box(), s));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(History, APointFollowsTheUniaxialStateAtRest) {
  // Rollers at xmin, ymin, zmin and the top moved down d = 3 um over L = 20 mm, then at rest:
  // uz = -d z / L, ux = nu (d / L) x, uy = nu (d / L) y, szz = -E d / L, the others 0. One point
  // at a mesh vertex (its tets tie: the lowest input number holds it), one inside a tet.
  const Scene s =
      pressed_box("[{name: vertex, at: [0.005, 0.005, 0.01]}, {name: inside, at: [0.0061, 0.0032, 0.0143]}]");
  Solver solver(s, build_model(test::layered_box(), s));
  while (solver.time() < 3e-4) solver.step();
  const Monitors r = solver.measure();
  ASSERT_EQ(r.history_columns, 24);
  EXPECT_EQ(history_column_names(s)[14], "h_inside_uz_m");
  const real d = 3e-6, L = 0.02, E = 12.2e9, nu = 0.25, strain = d / L;
  const Vec3 points[2] = {{0.005, 0.005, 0.01}, {0.0061, 0.0032, 0.0143}};
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    const real* h = r.history.data() + 12 * i;
    const Vec3 p = points[i];
    RecordProperty("uz_over_closed_form_" + std::to_string(i), std::to_string(h[2] / (-strain * p.z)));
    RecordProperty("szz_over_closed_form_" + std::to_string(i), std::to_string(h[8] / (-E * strain)));
    EXPECT_NEAR(h[0], nu * strain * p.x, 2e-3 * nu * strain * p.x) << "ux, m";
    EXPECT_NEAR(h[1], nu * strain * p.y, 2e-3 * nu * strain * p.y) << "uy, m";
    EXPECT_NEAR(h[2], -strain * p.z, 1e-3 * strain * p.z) << "uz, m";
    for (int k = 3; k < 6; ++k) EXPECT_LT(std::fabs(h[k]), 1e-6) << "at rest, m/s";
    EXPECT_NEAR(h[8], -E * strain, 1e-3 * E * strain) << "szz, Pa";
    for (int k : {6, 7, 9, 10, 11}) EXPECT_LT(std::fabs(h[k]), 1e-3 * E * strain) << "column " << k << ", Pa";
  }
}

TEST(History, AGroupFollowsItsNodesMeanAndItsTetsMeanStress) {
  // The same state over groups: the field is linear, so a group's mean displacement is the field
  // at its nodes' mean position. The upper layer, the moved end zmax and the free side xmax
  // (named by its tag) all carry szz = -E d / L.
  const Scene s = pressed_box("[{name: upper, group: upper}, {name: top, group: zmax}, {name: side, group: 9}]");
  Mesh mesh = test::layered_box();
  for (MeshGroup& g : mesh.groups)
    if (g.name == "xmax") g.name = "", g.tag = 9;  // (by tag, where the group has no name)
  Solver solver(s, build_model(mesh, s));
  while (solver.time() < 3e-4) solver.step();
  const Monitors r = solver.measure();
  const Model& m = solver.model();
  const real d = 3e-6, L = 0.02, E = 12.2e9, nu = 0.25, strain = d / L;
  const int nodes[3] = {5 * 5 * 5, 5 * 5, 5 * 9};           // (no CE6s: one node per vertex)
  const real on[3][2] = {{2, 0.01}, {2, 0.02}, {0, 0.01}};  // each group's nodes: axis, least coordinate
  for (int i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    Vec3 mean{0, 0, 0};
    real count = 0;
    for (std::size_t n = 0; n < m.X.size(); ++n)
      if (m.node_history[n] >> i & 1) {
        mean += m.X[n], count += 1;
        EXPECT_GE(m.X[n][int(on[i][0])], on[i][1] - 1e-12) << "node " << n << " is not in the group";
      }
    EXPECT_EQ(count, nodes[i]);
    mean = (1 / count) * mean;
    const real* h = r.history.data() + 12 * i;
    RecordProperty("uz_over_closed_form_" + std::to_string(i), std::to_string(h[2] / (-strain * mean.z)));
    EXPECT_NEAR(h[0], nu * strain * mean.x, 2e-3 * nu * strain * mean.x) << "ux, m";
    EXPECT_NEAR(h[1], nu * strain * mean.y, 2e-3 * nu * strain * mean.y) << "uy, m";
    EXPECT_NEAR(h[2], -strain * mean.z, 1e-3 * strain * mean.z) << "uz, m";
    EXPECT_NEAR(h[8], -E * strain, 1e-3 * E * strain) << "szz, Pa";
  }
  EXPECT_NEAR(r.history[12 + 2], -d, 1e-3 * d) << "the moved end, m";
}

TEST(History, PointsOutsideTheRockOrBadlyNamedAreRefusedWithTheFix) {
  std::string e = setup_error("[{name: far, at: [0.005, 0.005, 0.03]}]");
  EXPECT_TRUE(cli_test::has(e, "box.yaml: history[0] ('far').at: (0.005, 0.005, 0.03) m is in no tet of the model"))
      << e;
  e = setup_error("[{name: 'a,b', at: [0, 0, 0]}]");
  EXPECT_TRUE(cli_test::has(e, "history[0].name: 'a,b' holds ','")) << e;
  e = setup_error("[{name: a, at: [0, 0, 0]}, {name: a, at: [0, 0, 0.01]}]");
  EXPECT_TRUE(cli_test::has(e, "history[1].name: 'a' names two points")) << e;
  e = setup_error("[{name: a}]");
  EXPECT_TRUE(cli_test::has(e, "history[0].at: missing")) << e;
  e = setup_error("[{name: a, at: [0, 0]}]");
  EXPECT_TRUE(cli_test::has(e, "history[0].at: expected a list of three numbers")) << e;
  e = setup_error("{name: a}");
  EXPECT_TRUE(cli_test::has(e, "history: expected a list of points")) << e;
  EXPECT_EQ(setup_error("[{name: corner-0, at: [0, 0, 0]}]"), "") << "a corner of the box is in the rock";
  e = setup_error("[{name: a, group: tunnel}]");
  EXPECT_TRUE(cli_test::has(e, "history[0] ('a').group: the mesh")) << e;
  EXPECT_TRUE(cli_test::has(e, "has no group 'tunnel'; its groups: lower, upper, xmin")) << e;
  e = setup_error("[{name: a, group: upper, at: [0, 0, 0]}]");
  EXPECT_TRUE(cli_test::has(e, "history[0].group: given with at")) << e;
}
