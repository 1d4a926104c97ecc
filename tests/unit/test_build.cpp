// Model build: node splitting, CE6 insertion, fracture regions, surfaces, node groups,
// masses and colourings, checked against exact counts of a structured box.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "core/error.hpp"
#include "model/model.hpp"
#include "model/structured.hpp"
#include "physics/tet4.hpp"

using namespace fdem;

namespace {

Vec3 centroid(const Model& m, int t) {
  Vec3 c{0, 0, 0};
  for (int n : m.tet_nodes[t]) c += 0.25 * m.X[n];
  return c;
}

template <std::size_t K>
void expect_valid_colouring(const Colouring& col, const std::vector<std::array<int, K>>& elems, std::size_t nodes) {
  std::vector<int> seen(elems.size(), 0);
  for (int e : col.order) ++seen[e];
  for (int s : seen) ASSERT_EQ(s, 1);
  for (int c = 0; c < col.colours(); ++c) {
    std::vector<char> used(nodes, 0);
    for (int k = col.offsets[c]; k < col.offsets[c + 1]; ++k)
      for (int n : elems[col.order[k]]) {
        ASSERT_FALSE(used[n]) << "two elements of colour " << c << " share node " << n;
        used[n] = 1;
      }
  }
}

}  // namespace

TEST(ModelBuild, CohesiveEverywhereSplitsEveryTetAndPairsEveryInternalFace) {
  const int nx = 3, ny = 2, nz = 4;
  const Vec3 size{0.003, 0.002, 0.004};
  Scene scene;
  scene.solver.mass_scaling = 5;
  const Model m = build_model(structured_box_mesh(size, nx, ny, nz), scene);
  const std::size_t T = 6 * nx * ny * nz;
  const std::size_t boundary = 4 * (nx * ny + ny * nz + nx * nz);  // 2 triangles per cell face, 2 sides each
  ASSERT_EQ(m.tet_nodes.size(), T);
  EXPECT_EQ(m.X.size(), 4 * T);
  EXPECT_EQ(m.surface_faces.size(), boundary);
  EXPECT_EQ(m.ce6_nodes.size(), (4 * T - boundary) / 2);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    const auto& q = m.ce6_nodes[c];
    for (int i = 0; i < 3; ++i) EXPECT_EQ(norm(m.X[q[i]] - m.X[q[i + 3]]), 0.0);
    const Vec3 n = cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
    EXPECT_GT(dot(n, centroid(m, m.ce6_tets[c][1]) - centroid(m, m.ce6_tets[c][0])), 0) << "CE6 " << c;
  }
  real mass = 0, volume = 0;
  for (real v : m.mass) mass += v;
  for (real v : m.tet_V0) {
    EXPECT_GT(v, 0);
    volume += v;
  }
  EXPECT_NEAR(volume, size.x * size.y * size.z, 1e-12 * volume);
  EXPECT_NEAR(mass, 5 * scene.material.density * volume, 1e-9 * mass);
  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size());
  expect_valid_colouring(m.ce6_colours, m.ce6_nodes, m.X.size());
  EXPECT_EQ(m.tet_colours.colours(), 1);  // fully split: tets share no node
}

TEST(ModelBuild, NoFractureRegionGivesAContinuousMesh) {
  Scene scene;
  scene.fracture.everywhere = false;
  const Mesh mesh = structured_box_mesh({1, 1, 1}, 2, 2, 2);
  const Model m = build_model(mesh, scene);
  EXPECT_EQ(m.X.size(), mesh.vertices.size());
  EXPECT_TRUE(m.ce6_nodes.empty());
  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size());
  EXPECT_GT(m.tet_colours.colours(), 1);
}

TEST(ModelBuild, FractureRegionBoxLimitsCohesiveElementsToIt) {
  Scene scene;
  scene.fracture.everywhere = false;
  scene.fracture.boxes.push_back({{-1, -1, 0.5}, {2, 2, 2}});  // the upper half of a unit box
  const int n = 2;
  const Mesh mesh = structured_box_mesh({1, 1, 1}, n, n, 2 * n);
  const Model m = build_model(mesh, scene);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c)
    for (int t : m.ce6_tets[c]) EXPECT_GT(centroid(m, t).z, 0.5);
  const std::size_t upper_tets = 6 * n * n * n;
  const std::size_t upper_internal = (4 * upper_tets - 4 * (n * n + n * n + n * n)) / 2;
  // CE6 only between two upper tets: all internal faces of the upper half.
  EXPECT_EQ(m.ce6_nodes.size(), upper_internal);
  // The lower half is continuous: its (n+1)^3 vertices (mid-plane included) are single
  // nodes. An upper tet with a face on the mid-plane joins its three corners there to the
  // lower nodes (no CE6 on that face); an upper tet touching the plane only along an edge or
  // at a vertex keeps those corners as its own nodes, like all its corners above the plane.
  std::size_t own = 0;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    if (centroid(m, int(t)).z < 0.5) continue;
    int on_plane = 0;
    for (int k : m.tet_nodes[t]) on_plane += std::fabs(m.X[k].z - 0.5) < 1e-12;
    own += on_plane == 3 ? 1 : 4;
  }
  EXPECT_EQ(m.X.size(), own + std::size_t((n + 1) * (n + 1) * (n + 1)));
  std::size_t upper = 0;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) upper += centroid(m, int(t)).z > 0.5;
  EXPECT_EQ(upper, upper_tets);
  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size());
}

TEST(ModelBuild, SurfacesAreOutwardAndGroupsArePlaced) {
  const Vec3 size{0.002, 0.003, 0.004};
  Scene scene;
  const Model m = build_model(structured_box_mesh(size, 2, 3, 4), scene);
  real area = 0;
  for (std::size_t f = 0; f < m.surface_faces.size(); ++f) {
    const auto& q = m.surface_faces[f];
    const Vec3 n = cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
    const Vec3 fc = (1.0 / 3) * (m.X[q[0]] + m.X[q[1]] + m.X[q[2]]);
    EXPECT_GT(dot(n, fc - centroid(m, m.surface_tet[f])), 0);
    area += 0.5 * norm(n);
  }
  const real total = 2 * (size.x * size.y + size.y * size.z + size.x * size.z);
  EXPECT_NEAR(area, total, 1e-12);
  real trib = 0;
  for (real a : m.platen_node_area) trib += a;
  EXPECT_NEAR(trib, total, 1e-12);
  EXPECT_NEAR(m.area0, size.x * size.y, 1e-15);
  EXPECT_NEAR(m.height0, size.z, 1e-15);
  for (int n : m.top_nodes) EXPECT_EQ(m.X[n].z, size.z);
  for (int n : m.bottom_nodes) EXPECT_EQ(m.X[n].z, 0);
  for (int n : m.lateral_nodes) {
    const bool side =
        m.X[n].x == 0 || m.X[n].y == 0 || std::fabs(m.X[n].x - size.x) < 1e-15 || std::fabs(m.X[n].y - size.y) < 1e-15;
    EXPECT_TRUE(side);
  }
  // Every node of a face lying in z = max is a top node, and only those.
  std::set<int> top;
  for (const auto& q : m.surface_faces)
    if (m.X[q[0]].z == size.z && m.X[q[1]].z == size.z && m.X[q[2]].z == size.z) top.insert(q.begin(), q.end());
  EXPECT_EQ(std::set<int>(m.top_nodes.begin(), m.top_nodes.end()), top);
}

TEST(ModelBuild, InvertedTetsAreReorientedAndDegenerateOnesRejected) {
  Mesh mesh = structured_box_mesh({1, 1, 1}, 1, 1, 1);
  Scene scene;
  const real v_before = [&] {
    real v = 0;
    for (real x : build_model(mesh, scene).tet_V0) v += x;
    return v;
  }();
  for (auto& t : mesh.tets) std::swap(t[0], t[1]);  // every tet inverted
  const Model m = build_model(mesh, scene);
  real v = 0;
  for (real x : m.tet_V0) {
    EXPECT_GT(x, 0);
    v += x;
  }
  EXPECT_NEAR(v, v_before, 1e-14);

  Mesh flat = mesh;
  flat.vertices.push_back({0.5, 0.5, 0});
  flat.vertices.push_back({0.6, 0.5, 0});
  flat.tets.push_back({0, 1, int(flat.vertices.size()) - 2, int(flat.vertices.size()) - 1});  // all in z = 0
  try {
    build_model(flat, scene);
    FAIL() << "a zero-volume tet was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tet 7"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("zero"), std::string::npos) << e.what();
  }

  Mesh nonmanifold = structured_box_mesh({1, 1, 1}, 1, 1, 1);
  const auto t0 = nonmanifold.tets[0];
  nonmanifold.vertices.push_back({2, 2, 2});
  nonmanifold.tets.push_back({t0[0], t0[1], t0[2], int(nonmanifold.vertices.size()) - 1});
  nonmanifold.vertices.push_back({-2, -2, -2});
  nonmanifold.tets.push_back({t0[0], t0[1], t0[2], int(nonmanifold.vertices.size()) - 1});
  try {
    build_model(nonmanifold, scene);
    FAIL() << "a face shared by three tets was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("non-manifold"), std::string::npos) << e.what();
  }
}
