// build_model on structured Kuhn boxes and small hand-made meshes: node splitting, CE6
// pairing and orientation, masses, fracture regions, colourings, surfaces, node groups,
// orientation of inverted input and rejection of degenerate / non-manifold input.
// Expected counts are derived by hand from the mesh topology, not from the builder.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/error.hpp"
#include "io/mesh_io.hpp"
#include "model/model.hpp"
#include "model/structured.hpp"

using namespace fdem;

namespace {

real signed_volume(Vec3 a, Vec3 b, Vec3 c, Vec3 d) {
  return dot(b - a, cross(c - a, d - a)) / 6;
}

Vec3 tet_centroid(const Model& m, int t) {
  Vec3 c{0, 0, 0};
  for (int n : m.tet_nodes[t]) c += 0.25 * m.X[n];
  return c;
}

/// Faces of an nx x ny x nz Kuhn box: every tet has 4, boundary faces are counted once and
/// internal ones twice. Each of the box's unit squares on the surface is cut into 2 triangles.
struct KuhnCounts {
  long tets, boundary, internal;
};
KuhnCounts kuhn_counts(long nx, long ny, long nz) {
  KuhnCounts k;
  k.tets = 6 * nx * ny * nz;
  k.boundary = 2 * (2 * nx * ny + 2 * ny * nz + 2 * nx * nz);
  k.internal = (4 * k.tets - k.boundary) / 2;
  return k;
}

Scene scene_with(const FractureRegions& fr, real mass_scaling = 1) {
  Scene s;
  s.fracture = fr;
  s.solver.mass_scaling = mass_scaling;
  return s;
}

FractureRegions no_regions() {
  FractureRegions fr;
  fr.everywhere = false;
  return fr;
}

/// Every element index once in `order`; no two elements of a colour share a node.
template <std::size_t K>
void expect_valid_colouring(const Colouring& c, const std::vector<std::array<int, K>>& elems, std::size_t nodes,
                            const char* what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(c.order.size(), elems.size());
  if (elems.empty()) return;
  ASSERT_GE(c.offsets.size(), 2u);
  EXPECT_EQ(c.offsets.front(), 0);
  EXPECT_EQ(c.offsets.back(), int(elems.size()));
  std::vector<int> seen(elems.size(), 0);
  for (int e : c.order) {
    ASSERT_GE(e, 0);
    ASSERT_LT(e, int(elems.size()));
    ++seen[e];
  }
  for (std::size_t e = 0; e < seen.size(); ++e) EXPECT_EQ(seen[e], 1) << "element " << e;
  std::vector<int> owner(nodes, -1);
  for (int col = 0; col < c.colours(); ++col) {
    ASSERT_LE(c.offsets[col], c.offsets[col + 1]);
    for (int i = c.offsets[col]; i < c.offsets[col + 1]; ++i) {
      const int e = c.order[i];
      // An element may list a node twice (a CE6 pinned at the edge of a fracture region).
      for (int n : std::set<int>(elems[e].begin(), elems[e].end())) {
        EXPECT_NE(owner[n], col) << "node " << n << " used twice in colour " << col;
        owner[n] = col;
      }
    }
  }
}

bool same_point(Vec3 a, Vec3 b) {
  return a.x == b.x && a.y == b.y && a.z == b.z;
}

}  // namespace

TEST(ModelBuildKuhn, StructuredMeshHasTheExpectedTopology) {
  // Check the generator itself first: counts, volumes and face multiplicities.
  const Mesh mesh = structured_box_mesh({0.02, 0.03, 0.04}, 2, 3, 4);
  const KuhnCounts k = kuhn_counts(2, 3, 4);
  EXPECT_EQ(long(mesh.tets.size()), k.tets);
  EXPECT_EQ(mesh.vertices.size(), 3u * 4u * 5u);
  std::map<std::array<int, 3>, int> faces;
  real volume = 0;
  for (const auto& t : mesh.tets) {
    volume +=
        std::abs(signed_volume(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], mesh.vertices[t[3]]));
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> f{t[(i + 1) % 4], t[(i + 2) % 4], t[(i + 3) % 4]};
      std::sort(f.begin(), f.end());
      ++faces[f];
    }
  }
  EXPECT_NEAR(volume, 0.02 * 0.03 * 0.04, 1e-18);
  long boundary = 0, internal = 0;
  for (const auto& f : faces) {
    ASSERT_LE(f.second, 2);
    (f.second == 1 ? boundary : internal) += 1;
  }
  EXPECT_EQ(boundary, k.boundary);
  EXPECT_EQ(internal, k.internal);
}

TEST(ModelBuildKuhn, CohesiveEverywhereSplitsEveryTet) {
  for (int n : {1, 2, 3}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    const Mesh mesh = structured_box_mesh({0.01, 0.01, 0.01}, n, n, n);
    const Model m = build_model(mesh, Scene{});
    const KuhnCounts k = kuhn_counts(n, n, n);
    ASSERT_EQ(long(m.tet_nodes.size()), k.tets);
    EXPECT_EQ(long(m.X.size()), 4 * k.tets);
    EXPECT_EQ(long(m.ce6_nodes.size()), k.internal);
    EXPECT_EQ(long(m.ce6_tets.size()), k.internal);
    EXPECT_EQ(long(m.surface_faces.size()), k.boundary);
    // 1 x 1 x 1: 6 tets, 12 boundary triangles, (24 - 12) / 2 = 6 internal faces.
    if (n == 1) {
      EXPECT_EQ(m.ce6_nodes.size(), 6u);
    }
    // Every node is used by exactly one tet, and a tet's four nodes are distinct.
    std::vector<int> uses(m.X.size(), 0);
    for (const auto& t : m.tet_nodes) {
      std::set<int> distinct(t.begin(), t.end());
      EXPECT_EQ(distinct.size(), 4u);
      for (int node : t) ++uses[node];
    }
    for (std::size_t i = 0; i < uses.size(); ++i) ASSERT_EQ(uses[i], 1) << "node " << i;
    // Nodes sit on the vertex they came from; each tet covers the vertices of its input tet.
    ASSERT_EQ(m.node_vertex.size(), m.X.size());
    for (std::size_t i = 0; i < m.X.size(); ++i) EXPECT_TRUE(same_point(m.X[i], mesh.vertices[m.node_vertex[i]]));
    std::vector<int> input_seen(mesh.tets.size(), 0);
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
      const int in = m.tet_input[t];
      ++input_seen[in];
      std::set<int> a(mesh.tets[in].begin(), mesh.tets[in].end()), b;
      for (int node : m.tet_nodes[t]) b.insert(m.node_vertex[node]);
      EXPECT_EQ(a, b) << "tet " << t;
    }
    for (int s : input_seen) EXPECT_EQ(s, 1);
    // The tets need a single colour (no shared nodes at all).
    EXPECT_EQ(m.tet_colours.colours(), 1);
  }
}

TEST(ModelBuildKuhn, CohesiveElementsPairCoincidentNodesAndPointFromAToB) {
  const Mesh mesh = structured_box_mesh({0.02, 0.03, 0.01}, 2, 3, 1);
  const Model m = build_model(mesh, Scene{});
  ASSERT_EQ(long(m.ce6_nodes.size()), kuhn_counts(2, 3, 1).internal);
  std::set<std::pair<int, int>> tet_pairs;
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    SCOPED_TRACE("CE6 " + std::to_string(c));
    const auto& q = m.ce6_nodes[c];
    const int a = m.ce6_tets[c][0], b = m.ce6_tets[c][1];
    ASSERT_NE(a, b);
    EXPECT_TRUE(tet_pairs.insert({std::min(a, b), std::max(a, b)}).second) << "two CE6 on one tet pair";
    const std::set<int> na(m.tet_nodes[a].begin(), m.tet_nodes[a].end());
    const std::set<int> nb(m.tet_nodes[b].begin(), m.tet_nodes[b].end());
    for (int i = 0; i < 3; ++i) {
      EXPECT_TRUE(same_point(m.X[q[i]], m.X[q[i + 3]])) << "pair " << i;
      EXPECT_NE(q[i], q[i + 3]);
      EXPECT_EQ(na.count(q[i]), 1u) << "node " << i << " is not on tet A";
      EXPECT_EQ(nb.count(q[i + 3]), 1u) << "node " << i + 3 << " is not on tet B";
    }
    const Vec3 normal = cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
    const Vec3 ab = tet_centroid(m, b) - tet_centroid(m, a);
    EXPECT_GT(dot(normal, ab), 0);
    // A's centroid lies behind the face plane, B's in front of it.
    EXPECT_LT(dot(normal, tet_centroid(m, a) - m.X[q[0]]), 0);
    EXPECT_GT(dot(normal, tet_centroid(m, b) - m.X[q[0]]), 0);
    // h is the mean edge length of the face.
    const real h = (norm(m.X[q[1]] - m.X[q[0]]) + norm(m.X[q[2]] - m.X[q[1]]) + norm(m.X[q[0]] - m.X[q[2]])) / 3;
    EXPECT_NEAR(m.ce6_h[c], h, 1e-15);
  }
}

TEST(ModelBuildKuhn, MassIsScaledDensityTimesVolume) {
  const Vec3 size{0.01, 0.02, 0.03};
  const real V = size.x * size.y * size.z;
  for (bool everywhere : {true, false}) {
    FractureRegions fr;
    fr.everywhere = everywhere;
    const Scene s = scene_with(fr, 5);
    const Model m = build_model(structured_box_mesh(size, 2, 2, 3), s);
    real total = 0, vol = 0;
    for (real x : m.mass) {
      EXPECT_GT(x, 0);
      total += x;
    }
    for (real v : m.tet_V0) vol += v;
    EXPECT_NEAR(vol, V, 1e-12 * V);
    EXPECT_NEAR(total, 5 * s.material().density * V, 1e-12 * 5 * s.material().density * V);
    if (everywhere) {
      // Each node carries a quarter of its one tet's mass.
      for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
        for (int n : m.tet_nodes[t]) EXPECT_NEAR(m.mass[n], 5 * 1800.0 * m.tet_V0[t] / 4, 1e-9 * m.mass[n]);
    }
  }
}

TEST(ModelBuildKuhn, NoFractureRegionsGiveTheContinuousMesh) {
  const Mesh mesh = structured_box_mesh({0.03, 0.02, 0.02}, 3, 2, 2);
  const Model m = build_model(mesh, scene_with(no_regions()));
  EXPECT_EQ(m.X.size(), mesh.vertices.size());
  EXPECT_TRUE(m.ce6_nodes.empty());
  EXPECT_TRUE(m.ce6_tets.empty());
  EXPECT_EQ(m.ce6_colours.colours(), 0);
  EXPECT_EQ(long(m.surface_faces.size()), kuhn_counts(3, 2, 2).boundary);
  // One node per vertex.
  std::set<int> vertices(m.node_vertex.begin(), m.node_vertex.end());
  EXPECT_EQ(vertices.size(), mesh.vertices.size());
  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size(), "TET4");
  EXPECT_GT(m.tet_colours.colours(), 1);  // tets share nodes now
}

TEST(ModelBuildKuhn, FractureBoxCoveringHalfTheSpecimen) {
  // 4 x 2 x 3 cells of 1 cm; the region holds the cells with x < 2 cm (tet centroids are
  // strictly inside their cells, so no centroid lies on the region's face x = 2 cm).
  const real h = 0.01, xcut = 2 * h;
  const Mesh mesh = structured_box_mesh({4 * h, 2 * h, 3 * h}, 4, 2, 3);
  FractureRegions fr = no_regions();
  fr.boxes.push_back({{-1, -1, -1}, {xcut, 1, 1}});
  const Model m = build_model(mesh, scene_with(fr));

  // CE6s: exactly the internal faces of the 2 x 2 x 3 Kuhn box on the left.
  EXPECT_EQ(long(m.ce6_nodes.size()), kuhn_counts(2, 2, 3).internal);
  // A CE6's node pair is one node exactly where the pair's vertex lies on the cut and both
  // tets reach the right side's node through a face on the cut (the crack is pinned there).
  long pinned = 0;
  for (std::size_t c = 0; c < m.ce6_tets.size(); ++c) {
    for (int t : m.ce6_tets[c]) EXPECT_LT(tet_centroid(m, t).x, xcut) << "CE6 " << c;
    for (int i = 0; i < 3; ++i)
      if (m.ce6_nodes[c][i] == m.ce6_nodes[c][i + 3]) {
        ++pinned;
        EXPECT_NEAR(m.X[m.ce6_nodes[c][i]].x, xcut, 1e-15) << "CE6 " << c;
      }
  }
  EXPECT_GT(pinned, 0);

  // Nodes per vertex: left of the cut every incident tet has its own node; right of it one
  // shared node; on the cut the right side's node is shared by the left tets that have a
  // face on the cut plane, and the other left tets keep their own.
  std::vector<std::vector<int>> incident(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.tets.size(); ++t)
    for (int v : mesh.tets[t]) incident[v].push_back(int(t));
  auto input_centroid_x = [&](int t) {
    real x = 0;
    for (int v : mesh.tets[t]) x += 0.25 * mesh.vertices[v].x;
    return x;
  };
  auto on_cut = [&](int v) { return std::abs(mesh.vertices[v].x - xcut) < 1e-12; };
  long expected_nodes = 0;
  std::vector<long> expected_per_vertex(mesh.vertices.size());
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
    long e;
    if (on_cut(int(v))) {
      e = 1;
      for (int t : incident[v]) {
        if (input_centroid_x(t) > xcut) continue;
        int on_plane = 0;
        for (int w : mesh.tets[t]) on_plane += on_cut(w);
        if (on_plane < 3) ++e;  // touches the cut only along an edge or at the vertex
      }
    } else if (mesh.vertices[v].x < xcut) {
      e = long(incident[v].size());
    } else {
      e = 1;
    }
    expected_per_vertex[v] = e;
    expected_nodes += e;
  }
  std::vector<long> per_vertex(mesh.vertices.size(), 0);
  for (int v : m.node_vertex) ++per_vertex[v];
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    EXPECT_EQ(per_vertex[v], expected_per_vertex[v]) << "vertex " << v << " at x = " << mesh.vertices[v].x;
  EXPECT_EQ(long(m.X.size()), expected_nodes);

  // Across every internal face without a CE6 the two tets use the same nodes.
  std::map<std::array<int, 3>, std::vector<int>> faces;  // sorted vertex ids -> model tets
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    std::array<int, 4> v;
    for (int i = 0; i < 4; ++i) v[i] = m.node_vertex[m.tet_nodes[t][i]];
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> f{v[(i + 1) % 4], v[(i + 2) % 4], v[(i + 3) % 4]};
      std::sort(f.begin(), f.end());
      faces[f].push_back(int(t));
    }
  }
  std::set<std::pair<int, int>> cohesive;
  for (const auto& p : m.ce6_tets) cohesive.insert({std::min(p[0], p[1]), std::max(p[0], p[1])});
  long shared_faces = 0;
  for (const auto& f : faces) {
    if (f.second.size() != 2) continue;
    const int a = std::min(f.second[0], f.second[1]), b = std::max(f.second[0], f.second[1]);
    if (cohesive.count({a, b})) continue;
    ++shared_faces;
    std::set<int> na(m.tet_nodes[a].begin(), m.tet_nodes[a].end());
    int common = 0;
    for (int n : m.tet_nodes[b]) common += int(na.count(n));
    EXPECT_EQ(common, 3) << "tets " << a << " and " << b;
  }
  EXPECT_EQ(shared_faces, kuhn_counts(4, 2, 3).internal - long(m.ce6_nodes.size()));

  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size(), "TET4");
  expect_valid_colouring(m.ce6_colours, m.ce6_nodes, m.X.size(), "CE6");
}

TEST(ModelBuildKuhn, ColouringsCoverEveryElementOnceWithoutSharedNodes) {
  const Mesh mesh = structured_box_mesh({0.03, 0.03, 0.03}, 3, 3, 3);
  const Model m = build_model(mesh, Scene{});
  expect_valid_colouring(m.tet_colours, m.tet_nodes, m.X.size(), "TET4");
  expect_valid_colouring(m.ce6_colours, m.ce6_nodes, m.X.size(), "CE6");
  // A split node belongs to at most 3 CE6 (one per face of its tet at that corner), so a
  // greedy colouring needs at least 3 colours here and stays small.
  EXPECT_GE(m.ce6_colours.colours(), 3);
  EXPECT_LE(m.ce6_colours.colours(), 12);
}

TEST(ModelBuildKuhn, SurfacesAreOutwardAndCoverTheBox) {
  const Vec3 L{0.02, 0.03, 0.05};
  const real total_area = 2 * (L.x * L.y + L.y * L.z + L.x * L.z);
  for (bool everywhere : {true, false}) {
    SCOPED_TRACE(everywhere ? "CE6 everywhere" : "no CE6");
    FractureRegions fr;
    fr.everywhere = everywhere;
    const Model m = build_model(structured_box_mesh(L, 2, 3, 5), scene_with(fr));
    ASSERT_EQ(m.surface_faces.size(), m.surface_tet.size());
    real area = 0;
    for (std::size_t f = 0; f < m.surface_faces.size(); ++f) {
      const auto& q = m.surface_faces[f];
      const int t = m.surface_tet[f];
      const std::set<int> nt(m.tet_nodes[t].begin(), m.tet_nodes[t].end());
      for (int n : q) EXPECT_EQ(nt.count(n), 1u) << "face " << f << " node not on its tet";
      const Vec3 an = 0.5 * cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]);
      const Vec3 fc = (1.0 / 3) * (m.X[q[0]] + m.X[q[1]] + m.X[q[2]]);
      EXPECT_GT(dot(an, fc - tet_centroid(m, t)), 0) << "face " << f << " points inwards";
      // The outward normal of a face on the box surface is the box side's normal.
      const real a = norm(an);
      area += a;
      int axis_hits = 0;
      for (int d = 0; d < 3; ++d) {
        if (std::abs(std::abs(an[d]) - a) > 1e-12 * a) continue;
        ++axis_hits;
        const bool at_max = std::abs(fc[d] - L[d]) < 1e-12, at_min = std::abs(fc[d]) < 1e-12;
        EXPECT_TRUE(at_max || at_min) << "face " << f;
        EXPECT_EQ(an[d] > 0, at_max) << "face " << f;
      }
      EXPECT_EQ(axis_hits, 1) << "face " << f << " is not on a box side";
    }
    EXPECT_NEAR(area, total_area, 1e-12 * total_area);

    // Geometry of the specimen.
    EXPECT_NEAR(m.area0, L.x * L.y, 1e-12 * L.x * L.y);
    EXPECT_NEAR(m.height0, L.z, 1e-15);
    EXPECT_TRUE(same_point(m.box_min, {0, 0, 0}));
    EXPECT_NEAR(m.box_max.x, L.x, 1e-15);
    EXPECT_NEAR(m.box_max.y, L.y, 1e-15);
    EXPECT_NEAR(m.box_max.z, L.z, 1e-15);
    EXPECT_NEAR(m.axis_point.x, L.x / 2, 1e-15);
    EXPECT_NEAR(m.axis_point.y, L.y / 2, 1e-15);
    EXPECT_EQ(m.axis_point.z, 0);

    // Platen candidates: exactly the nodes of surface faces; tributary areas add up.
    std::set<int> surface_nodes;
    for (const auto& q : m.surface_faces) surface_nodes.insert(q.begin(), q.end());
    EXPECT_EQ(std::set<int>(m.platen_nodes.begin(), m.platen_nodes.end()), surface_nodes);
    ASSERT_EQ(m.platen_node_area.size(), m.platen_nodes.size());
    ASSERT_EQ(m.platen_node_h.size(), m.platen_nodes.size());
    real trib = 0;
    for (std::size_t i = 0; i < m.platen_nodes.size(); ++i) {
      EXPECT_GT(m.platen_node_area[i], 0);
      EXPECT_GT(m.platen_node_h[i], 0);
      trib += m.platen_node_area[i];
    }
    EXPECT_NEAR(trib, total_area, 1e-12 * total_area);
  }
}

TEST(ModelBuildGmsh, BrazilianDiscIsLineLoadedOnItsDiametralPlane) {
  // A disc (axis y, diameter along z) touches the platens along lines: no flat ends, so the
  // nominal loaded area is the diametral plane D x t, and the axial stress is P / (D t).
  Scene scene;
  const Model m = build_model(generate_mesh(MeshSpec::round(MeshShape::disc, 0.03, 0.015, 0.006)), scene);
  EXPECT_TRUE(m.line_loaded);
  EXPECT_NEAR(m.height0, 0.03, 1e-9);
  EXPECT_NEAR(m.area0, 0.03 * 0.015, 1e-9 * 0.03 * 0.015);
  // A box has flat ends: its loaded area is the end area, not a diametral plane.
  const Model box = build_model(structured_box_mesh({0.01, 0.02, 0.03}, 1, 1, 1), scene);
  EXPECT_FALSE(box.line_loaded);
  EXPECT_NEAR(box.area0, 0.01 * 0.02, 1e-15);
}

TEST(ModelBuildKuhn, NodeGroupsOfAContinuousBox) {
  // Without CE6 every vertex on the surface is one node that lies in some face of each
  // side it is on, so the groups are exactly the nodes on z = max, z = min and the sides.
  const Vec3 L{0.02, 0.02, 0.04};
  const Model m = build_model(structured_box_mesh(L, 2, 2, 4), scene_with(no_regions()));
  std::set<int> top, bottom, lateral;
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    const Vec3 x = m.X[n];
    if (x.z == L.z)
      top.insert(int(n));
    else if (x.z == 0)
      bottom.insert(int(n));
    else if (x.x == 0 || x.y == 0 || std::abs(x.x - L.x) < 1e-15 || std::abs(x.y - L.y) < 1e-15)
      lateral.insert(int(n));
  }
  EXPECT_EQ(top.size(), 9u);
  EXPECT_EQ(bottom.size(), 9u);
  EXPECT_EQ(lateral.size(), 3u * 8u);
  EXPECT_EQ(std::set<int>(m.top_nodes.begin(), m.top_nodes.end()), top);
  EXPECT_EQ(std::set<int>(m.bottom_nodes.begin(), m.bottom_nodes.end()), bottom);
  EXPECT_EQ(std::set<int>(m.lateral_nodes.begin(), m.lateral_nodes.end()), lateral);
  EXPECT_EQ(m.top_nodes.size(), top.size());  // no duplicates
  EXPECT_EQ(m.lateral_nodes.size(), lateral.size());
}

TEST(ModelBuildKuhn, NodeGroupsWithCohesiveEverywhere) {
  // With split nodes, a group holds the corners of the tets that have a face on that side;
  // the top/bottom groups win over the lateral one at the box's edges.
  const Vec3 L{0.02, 0.02, 0.03};
  const Model m = build_model(structured_box_mesh(L, 2, 2, 3), Scene{});
  auto side_of = [&](Vec3 a, Vec3 b, Vec3 c) {
    if (a.z == L.z && b.z == L.z && c.z == L.z) return 't';
    if (a.z == 0 && b.z == 0 && c.z == 0) return 'b';
    return 'l';
  };
  std::set<int> top, bottom, lat_any;
  long faces_top = 0, faces_bottom = 0;
  std::map<std::array<int, 3>, int> count;
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const auto& q = m.tet_nodes[t];
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> f{m.node_vertex[q[(i + 1) % 4]], m.node_vertex[q[(i + 2) % 4]], m.node_vertex[q[(i + 3) % 4]]};
      std::sort(f.begin(), f.end());
      ++count[f];
    }
  }
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const auto& q = m.tet_nodes[t];
    for (int i = 0; i < 4; ++i) {
      const int a = q[(i + 1) % 4], b = q[(i + 2) % 4], c = q[(i + 3) % 4];
      std::array<int, 3> f{m.node_vertex[a], m.node_vertex[b], m.node_vertex[c]};
      std::sort(f.begin(), f.end());
      if (count[f] != 1) continue;  // internal
      const char s = side_of(m.X[a], m.X[b], m.X[c]);
      std::set<int>& g = s == 't' ? top : s == 'b' ? bottom : lat_any;
      g.insert({a, b, c});
      faces_top += s == 't';
      faces_bottom += s == 'b';
    }
  }
  EXPECT_EQ(faces_top, 2 * 2 * 2);
  EXPECT_EQ(faces_bottom, 2 * 2 * 2);
  std::set<int> lateral;
  for (int n : lat_any)
    if (!top.count(n) && !bottom.count(n)) lateral.insert(n);
  EXPECT_EQ(std::set<int>(m.top_nodes.begin(), m.top_nodes.end()), top);
  EXPECT_EQ(std::set<int>(m.bottom_nodes.begin(), m.bottom_nodes.end()), bottom);
  EXPECT_EQ(std::set<int>(m.lateral_nodes.begin(), m.lateral_nodes.end()), lateral);
  for (int n : m.top_nodes) EXPECT_EQ(m.X[n].z, L.z);
  for (int n : m.bottom_nodes) EXPECT_EQ(m.X[n].z, 0);
  // Every top vertex has at least one top node.
  std::set<int> top_vertices;
  for (int n : m.top_nodes) top_vertices.insert(m.node_vertex[n]);
  EXPECT_EQ(top_vertices.size(), 9u);
}

TEST(ModelBuildInput, InvertedTetsAreReoriented) {
  const Vec3 L{0.02, 0.01, 0.03};
  Mesh mesh = structured_box_mesh(L, 2, 1, 3);
  // The Kuhn split already lists half its tets with negative volume; flip every third one
  // more so that both orders occur in different places.
  for (std::size_t t = 0; t < mesh.tets.size(); t += 3) std::swap(mesh.tets[t][0], mesh.tets[t][1]);
  int negative = 0;
  for (const auto& t : mesh.tets)
    negative += signed_volume(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], mesh.vertices[t[3]]) < 0;
  ASSERT_GT(negative, 0);
  ASSERT_LT(negative, int(mesh.tets.size()));

  for (bool everywhere : {true, false}) {
    FractureRegions fr;
    fr.everywhere = everywhere;
    const Model m = build_model(mesh, scene_with(fr));
    const Model ref = build_model(structured_box_mesh(L, 2, 1, 3), scene_with(fr));
    real vol = 0;
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
      const auto& q = m.tet_nodes[t];
      const real v = signed_volume(m.X[q[0]], m.X[q[1]], m.X[q[2]], m.X[q[3]]);
      EXPECT_GT(m.tet_V0[t], 0);
      EXPECT_NEAR(v, m.tet_V0[t], 1e-12 * m.tet_V0[t]);
      vol += m.tet_V0[t];
    }
    EXPECT_NEAR(vol, L.x * L.y * L.z, 1e-12 * L.x * L.y * L.z);
    EXPECT_EQ(m.X.size(), ref.X.size());
    EXPECT_EQ(m.ce6_nodes.size(), ref.ce6_nodes.size());
    EXPECT_EQ(m.surface_faces.size(), ref.surface_faces.size());
    real mass = 0, ref_mass = 0;
    for (real x : m.mass) mass += x;
    for (real x : ref.mass) ref_mass += x;
    EXPECT_NEAR(mass, ref_mass, 1e-12 * ref_mass);
  }
}

TEST(ModelBuildInput, SingleHandMadeTetInEitherOrder) {
  Mesh mesh;
  mesh.source = "one tet";
  mesh.vertices = {{0, 0, 0}, {0.01, 0, 0}, {0, 0.02, 0}, {0, 0, 0.03}};
  for (std::array<int, 4> t : {std::array<int, 4>{0, 1, 2, 3}, std::array<int, 4>{1, 0, 2, 3}}) {
    mesh.tets = {t};
    const Model m = build_model(mesh, Scene{});
    ASSERT_EQ(m.tet_V0.size(), 1u);
    EXPECT_NEAR(m.tet_V0[0], 0.01 * 0.02 * 0.03 / 6, 1e-20);
    EXPECT_EQ(m.X.size(), 4u);
    EXPECT_TRUE(m.ce6_nodes.empty());
    EXPECT_EQ(m.surface_faces.size(), 4u);
    EXPECT_NEAR(m.height0, 0.03, 1e-15);
  }
}

TEST(ModelBuildInput, ZeroVolumeTetIsRejectedByNumber) {
  Mesh mesh;
  mesh.source = "handmade.msh";
  mesh.vertices = {{0, 0, 0},
                   {1, 0, 0},
                   {0, 1, 0},
                   {0, 0, 1},
                   // a flat tet far away: four points in the plane z = 5
                   {3, 3, 5},
                   {4, 3, 5},
                   {3, 4, 5},
                   {4, 4, 5}};
  mesh.tets = {{0, 1, 2, 3}, {4, 5, 6, 7}};
  try {
    build_model(mesh, Scene{});
    FAIL() << "no InputError for a zero-volume tet";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("handmade.msh"), std::string::npos) << msg;
    EXPECT_NE(msg.find("tet 2 "), std::string::npos) << msg;  // 1-based input index
    EXPECT_NE(msg.find("volume"), std::string::npos) << msg;
  }
  // The same with the flat tet first in the file.
  mesh.tets = {{4, 5, 6, 7}, {0, 1, 2, 3}};
  try {
    build_model(mesh, Scene{});
    FAIL() << "no InputError for a zero-volume tet";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tet 1 "), std::string::npos) << e.what();
  }
}

TEST(ModelBuildInput, FaceSharedByThreeTetsIsRejected) {
  Mesh mesh;
  mesh.source = "nonmanifold.msh";
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 0, -1}, {0.2, 0.2, 2}};
  mesh.tets = {{0, 1, 2, 3}, {0, 1, 2, 4}, {2, 0, 1, 5}};
  try {
    build_model(mesh, Scene{});
    FAIL() << "no InputError for a non-manifold face";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("nonmanifold.msh"), std::string::npos) << msg;
    EXPECT_NE(msg.find("face (1, 2, 3)"), std::string::npos) << msg;  // 1-based vertices
    EXPECT_NE(msg.find("3 tets"), std::string::npos) << msg;
  }
}

TEST(ModelBuildInput, MissingVertexAndEmptyMeshAreRejected) {
  Mesh mesh;
  mesh.source = "short.msh";
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.tets = {{0, 1, 2, 3}, {0, 1, 2, 7}};
  try {
    build_model(mesh, Scene{});
    FAIL();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("tet 2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("vertex 8"), std::string::npos) << msg;
  }
  mesh.tets.clear();
  EXPECT_THROW(build_model(mesh, Scene{}), InputError);
}
