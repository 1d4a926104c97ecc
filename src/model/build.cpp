// Mesh -> Model: node splitting, CE6 insertion, surfaces, node groups, masses, colourings.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>

#include "core/error.hpp"
#include "model/conditions.hpp"
#include "model/heterogeneity.hpp"
#include "model/joints.hpp"
#include "model/laws.hpp"
#include "model/materials.hpp"
#include "model/model.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"

namespace fdem {
namespace {

struct FaceRef {
  std::array<int, 3> key;  // sorted vertex ids
  int tet, local;          // local = index of the tet vertex opposite the face
};

int find_root(std::vector<int>& parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

void unite(std::vector<int>& parent, int a, int b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a != b) parent[std::max(a, b)] = std::min(a, b);
}

bool in_region(const FractureRegions& fr, Vec3 c) {
  if (fr.everywhere) return true;
  for (const auto& b : fr.boxes)
    if (c.x >= b.min.x && c.x <= b.max.x && c.y >= b.min.y && c.y <= b.max.y && c.z >= b.min.z && c.z <= b.max.z)
      return true;
  return false;
}

/// Greedy colouring: element e gets the smallest colour unused at all of its nodes.
template <std::size_t K>
Colouring colour_elements(const std::vector<std::array<int, K>>& elems, std::size_t n_nodes, const char* what) {
  std::vector<std::uint64_t> used(n_nodes, 0);
  std::vector<int> colour(elems.size());
  int n_colours = 0;
  for (std::size_t e = 0; e < elems.size(); ++e) {
    std::uint64_t mask = 0;
    for (int n : elems[e]) mask |= used[n];
    int c = 0;
    while (c < 64 && (mask >> c & 1u)) ++c;
    if (c == 64)
      throw InputError(std::string("model build: more than 64 ") + what +
                       " colours needed; the mesh has a vertex shared by too many elements");
    colour[e] = c;
    for (int n : elems[e]) used[n] |= std::uint64_t(1) << c;
    n_colours = std::max(n_colours, c + 1);
  }
  Colouring out;
  out.offsets.assign(n_colours + 1, 0);
  for (int c : colour) ++out.offsets[c + 1];
  for (int c = 0; c < n_colours; ++c) out.offsets[c + 1] += out.offsets[c];
  out.order.resize(elems.size());
  std::vector<int> fill(out.offsets.begin(), out.offsets.end() - 1);
  for (std::size_t e = 0; e < elems.size(); ++e) out.order[fill[colour[e]]++] = int(e);
  return out;
}

/// CE6s renumbered colour by colour, so that each colour is a contiguous range of ids: the time
/// loop's CE6 passes then read their arrays in order, and on one rank the loop works on the
/// Solver's CE6 state in place (no second copy in colour order).
void number_ce6_in_colour_order(Model& m) {
  const std::vector<int>& order = m.ce6_colours.order;
  auto reorder = [&](auto& a) {
    auto by_colour = a;
    for (std::size_t k = 0; k < order.size(); ++k) by_colour[k] = a[order[k]];
    a = std::move(by_colour);
  };
  reorder(m.ce6_nodes);
  reorder(m.ce6_tets);
  reorder(m.ce6_h);
  reorder(m.ce6_law);
  std::iota(m.ce6_colours.order.begin(), m.ce6_colours.order.end(), 0);
}

using TetVertices = std::vector<std::array<int, 4>>;

/// The mesh's tets with their vertices ordered for a positive volume. Also checks that every
/// vertex exists, and gives the mean edge length (the model's length scale).
TetVertices oriented_tets(const Mesh& mesh, real& mean_edge) {
  const int nt = int(mesh.tets.size());
  TetVertices tv = mesh.tets;
  real edge_sum = 0;
  for (int t = 0; t < nt; ++t) {
    auto& q = tv[t];
    for (int i = 0; i < 4; ++i)
      if (q[i] < 0 || q[i] >= int(mesh.vertices.size()))
        throw InputError(mesh.source + ": tet " + std::to_string(t + 1) + " refers to vertex " +
                         std::to_string(q[i] + 1) + " which does not exist");
    Vec3 x[4] = {mesh.vertices[q[0]], mesh.vertices[q[1]], mesh.vertices[q[2]], mesh.vertices[q[3]]};
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) edge_sum += norm(x[j] - x[i]);
    if (tet4_volume(x) < 0) std::swap(q[2], q[3]);
  }
  mean_edge = edge_sum / (6.0 * nt);
  return tv;
}

Vec3 centroid_of(const Mesh& mesh, const std::array<int, 4>& q) {
  Vec3 c{0, 0, 0};
  for (int i = 0; i < 4; ++i) c += 0.25 * mesh.vertices[q[i]];
  return c;
}

/// Renumbers the tets along a Morton (Z-order) curve of their centroids, so that the nodes and
/// CE6s that follow them are close in memory when neighbours are close in space. Sets
/// m.tet_input, each tet's number in the mesh.
void order_along_morton_curve(const Mesh& mesh, TetVertices& tv, Model& m) {
  const int nt = int(tv.size());
  Vec3 lo = mesh.vertices[tv[0][0]], hi = lo;
  for (const Vec3& x : mesh.vertices)
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], x[d]), hi[d] = std::max(hi[d], x[d]);
  std::vector<std::pair<std::uint64_t, int>> key(nt);
  for (int t = 0; t < nt; ++t) {
    const Vec3 c = centroid_of(mesh, tv[t]);
    std::uint64_t code = 0;
    for (int d = 0; d < 3; ++d) {
      const real u = hi[d] > lo[d] ? (c[d] - lo[d]) / (hi[d] - lo[d]) : 0;
      const auto q = std::uint64_t(std::min<real>(u * (1 << 21), (1 << 21) - 1));
      for (int b = 0; b < 21; ++b) code |= ((q >> b) & 1u) << (3 * b + d);
    }
    key[t] = {code, t};
  }
  std::sort(key.begin(), key.end());
  TetVertices sorted(nt);
  m.tet_input.resize(nt);
  for (int t = 0; t < nt; ++t) {
    sorted[t] = tv[key[t].second];
    m.tet_input[t] = key[t].second;
  }
  tv.swap(sorted);
}

/// Every tet face as (sorted vertex triple, tet, local), sorted so that the two sides of an
/// internal face are neighbours.
std::vector<FaceRef> sorted_faces(const TetVertices& tv) {
  std::vector<FaceRef> faces;
  faces.reserve(4 * tv.size());
  for (int t = 0; t < int(tv.size()); ++t)
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> k{tv[t][(i + 1) % 4], tv[t][(i + 2) % 4], tv[t][(i + 3) % 4]};
      std::sort(k.begin(), k.end());
      faces.push_back({k, t, i});
    }
  std::sort(faces.begin(), faces.end(),
            [](const FaceRef& a, const FaceRef& b) { return a.key != b.key ? a.key < b.key : a.tet < b.tet; });
  return faces;
}

/// The corner (4 t + i) of tet t at a mesh vertex; -1 when the tet does not have it.
int corner_of(const TetVertices& tv, int t, int vertex) {
  for (int i = 0; i < 4; ++i)
    if (tv[t][i] == vertex) return 4 * t + i;
  return -1;
}

/// The internal faces split into those that get a CE6 and those whose corners join.
struct FaceSplit {
  struct CohesivePair {
    int a, b;  // tets, a < b
    std::array<int, 3> key;
    int joint;  // index into scene.joints, or -1
  };
  std::vector<CohesivePair> cohesive;  // in the order of their first tet (Morton order too)
  std::vector<FaceRef> surface;        // faces of one tet only
  std::vector<int> corner_parent;      // union-find over corners 4t+i: joined corners are one node
};

/// A face shared by two tets both in a fracture region, or on a joint, gets a CE6; any other
/// internal face joins the corners on its two sides into one node. Rejects faces of more than
/// two tets. Marks the joint faces found inside.
FaceSplit split_faces(const Mesh& mesh, const TetVertices& tv, const std::vector<FaceRef>& faces,
                      const std::vector<char>& region, JointFaces& joints) {
  FaceSplit s;
  s.corner_parent.resize(4 * tv.size());
  std::iota(s.corner_parent.begin(), s.corner_parent.end(), 0);
  for (std::size_t i = 0; i < faces.size();) {
    std::size_t j = i + 1;
    while (j < faces.size() && faces[j].key == faces[i].key) ++j;
    if (j - i > 2) {
      const auto& k = faces[i].key;
      throw InputError(mesh.source + ": face (" + std::to_string(k[0] + 1) + ", " + std::to_string(k[1] + 1) + ", " +
                       std::to_string(k[2] + 1) + ") is shared by " + std::to_string(j - i) +
                       " tets (non-manifold); remesh so that each face joins at most two tets");
    }
    if (j - i == 1) {
      s.surface.push_back(faces[i]);
    } else {
      const int a = faces[i].tet, b = faces[i + 1].tet;
      const auto joint = joints.find(faces[i].key);
      if (joint != joints.end()) joint->second.internal = true;
      if (joint != joints.end() || (region[a] && region[b])) {
        s.cohesive.push_back({a, b, faces[i].key, joint != joints.end() ? joint->second.joint : -1});
      } else {
        for (int v : faces[i].key) unite(s.corner_parent, corner_of(tv, a, v), corner_of(tv, b, v));
      }
    }
    i = j;
  }
  std::sort(s.cohesive.begin(), s.cohesive.end(),
            [](const FaceSplit::CohesivePair& p, const FaceSplit::CohesivePair& q) {
              return p.a != q.a ? p.a < q.a : p.b < q.b;
            });
  return s;
}

/// Per tet of m, the gmsh tag of the first volume group that lists it (0: none), for the
/// ParaView field; empty where the mesh has no volume groups.
std::vector<int> volume_group_tags(const Mesh& mesh, const Model& m) {
  std::vector<int> of_input(mesh.tets.size(), 0);
  bool any = false;
  for (const MeshGroup& g : mesh.groups)
    if (g.dim == 3)
      for (int k : g.tets)
        if (of_input[k] == 0) of_input[k] = g.tag, any = true;
  if (!any) return {};
  std::vector<int> tags(m.tet_input.size());
  for (std::size_t t = 0; t < tags.size(); ++t) tags[t] = of_input[m.tet_input[t]];
  return tags;
}

/// Nodes numbered compactly in the order of their first corner (deterministic): m.X,
/// m.node_vertex and m.tet_nodes.
void number_nodes(const Mesh& mesh, const TetVertices& tv, std::vector<int>& corner_parent, Model& m) {
  std::vector<int> node_of_root(corner_parent.size(), -1);
  m.tet_nodes.resize(tv.size());
  for (int t = 0; t < int(tv.size()); ++t)
    for (int i = 0; i < 4; ++i) {
      const int r = find_root(corner_parent, 4 * t + i);
      if (node_of_root[r] < 0) {
        node_of_root[r] = int(m.X.size());
        m.X.push_back(mesh.vertices[tv[t][i]]);
        m.node_vertex.push_back(tv[t][i]);
      }
      m.tet_nodes[t][i] = node_of_root[r];
    }
}

/// Per-tet constants (inverse reference shape, volume, damping) and the lumped node masses, each
/// from the tet's material. Returns each tet's smallest altitude. Rejects tets of near-zero volume.
std::vector<real> set_tet_constants(const Mesh& mesh, const Scene& scene, Model& m) {
  const SolverSettings& sol = scene.solver;
  const int nt = int(m.tet_nodes.size());
  const real vol_floor = 1e-9 * m.mean_edge * m.mean_edge * m.mean_edge;
  m.mass.assign(m.X.size(), 0);
  m.tet_Xinv.resize(nt);
  m.tet_V0.resize(nt);
  m.tet_eta.resize(nt);
  std::vector<real> tet_hmin(nt);
  m.min_altitude = 1e300;
  for (int t = 0; t < nt; ++t) {
    const Material& mat = scene.materials[m.tet_material[t]];
    const real density = sol.mass_scaling * mat.density;
    Vec3 X[4];
    for (int i = 0; i < 4; ++i) X[i] = m.X[m.tet_nodes[t][i]];
    const Tet4Reference ref = tet4_reference(X);
    if (!(ref.V0 > vol_floor))
      throw InputError(mesh.source + ": tet " + std::to_string(m.tet_input[t] + 1) + " has zero or near-zero volume (" +
                       std::to_string(ref.V0) + " m^3); remove or remesh degenerate elements");
    m.tet_Xinv[t] = ref.Xinv;
    m.tet_V0[t] = ref.V0;
    tet_hmin[t] = tet4_min_altitude(X);
    if (tet_hmin[t] < m.min_altitude) {
      m.min_altitude = tet_hmin[t];
      m.min_altitude_tet = m.tet_input[t];
    }
    const real youngs = mat.youngs_modulus * (m.tet_stiffness.empty() ? 1 : m.tet_stiffness[t]);
    m.tet_eta[t] = sol.damping_scale * critical_damping(tet_hmin[t], sol.mass_scaling, mat.density, youngs);
    for (int i = 0; i < 4; ++i) m.mass[m.tet_nodes[t][i]] += density * ref.V0 / 4;
  }
  return tet_hmin;
}

/// The node of tet t at a mesh vertex.
int node_at(const TetVertices& tv, const Model& m, int t, int vertex) {
  return m.tet_nodes[t][corner_of(tv, t, vertex) - 4 * t];
}

/// A face's vertices (key) reordered so that the right-hand normal points away from a centroid.
std::array<int, 3> outward_vertices(const Mesh& mesh, const std::array<int, 3>& key, Vec3 centroid) {
  std::array<int, 3> v = key;
  const Vec3 a = mesh.vertices[v[0]], b = mesh.vertices[v[1]], c = mesh.vertices[v[2]];
  if (dot(cross(b - a, c - a), centroid - a) > 0) std::swap(v[1], v[2]);
  return v;
}

/// The CE6s: the A side (the lower tet) ordered so that its normal points into B, the B side at
/// the same vertices, the characteristic length h (the face's mean edge) and the law: a joint's
/// on its faces, else the one between the two tets' materials.
void insert_ce6(const Mesh& mesh, const Scene& scene, const TetVertices& tv, const FaceSplit& split,
                const std::vector<Vec3>& centroid, Model& m) {
  m.ce6_nodes.reserve(split.cohesive.size());
  for (const FaceSplit::CohesivePair& p : split.cohesive) {
    const std::array<int, 3> v = outward_vertices(mesh, p.key, centroid[p.a]);
    auto a_node = [&](int k) { return node_at(tv, m, p.a, v[k]); };
    auto b_node = [&](int k) { return node_at(tv, m, p.b, v[k]); };
    m.ce6_nodes.push_back({a_node(0), a_node(1), a_node(2), b_node(0), b_node(1), b_node(2)});
    m.ce6_tets.push_back({p.a, p.b});
    m.ce6_law.push_back(p.joint >= 0 ? std::uint8_t(joint_law(scene, p.joint))
                                     : ce6_law_between(scene, m.tet_material[p.a], m.tet_material[p.b]));
    const Vec3 a = mesh.vertices[p.key[0]], b = mesh.vertices[p.key[1]], c = mesh.vertices[p.key[2]];
    m.ce6_h.push_back((norm(b - a) + norm(c - b) + norm(a - c)) / 3);
  }
}

/// The bounding box, the axis point (bottom centre) and the initial height along z.
void set_bounds(Model& m) {
  m.box_min = m.box_max = m.X[0];
  for (const Vec3& x : m.X)
    for (int d = 0; d < 3; ++d) {
      m.box_min[d] = std::min(m.box_min[d], x[d]);
      m.box_max[d] = std::max(m.box_max[d], x[d]);
    }
  m.axis_point = {0.5 * (m.box_min.x + m.box_max.x), 0.5 * (m.box_min.y + m.box_max.y), m.box_min.z};
  m.height0 = m.box_max.z - m.box_min.z;
}

/// What the surface faces give each node: its share of their area, the largest altitude of
/// their tets, and on which part of the surface it lies.
struct SurfaceNodes {
  std::vector<real> area, h;
  std::vector<char> top, bottom, lateral, surface;
  real top_area = 0, bottom_area = 0;  // m^2, of the faces wholly on the top and bottom planes
};

/// The surface faces, outward, with their tets (m.surface_faces, m.surface_tet), and what they
/// give their nodes. A face is top or bottom when all its nodes are within 1e-3 of the mean
/// edge of the box's end planes, else lateral.
SurfaceNodes add_surface_faces(const Mesh& mesh, const TetVertices& tv, const FaceSplit& split,
                               const std::vector<Vec3>& centroid, const std::vector<real>& tet_hmin, Model& m) {
  const std::size_t nn = m.X.size();
  const real tol = 1e-3 * m.mean_edge;
  SurfaceNodes s{std::vector<real>(nn, 0), std::vector<real>(nn, 0), std::vector<char>(nn, 0),
                 std::vector<char>(nn, 0), std::vector<char>(nn, 0), std::vector<char>(nn, 0)};
  for (const FaceRef& f : split.surface) {
    const std::array<int, 3> v = outward_vertices(mesh, f.key, centroid[f.tet]);
    const std::array<int, 3> nodes{node_at(tv, m, f.tet, v[0]), node_at(tv, m, f.tet, v[1]),
                                   node_at(tv, m, f.tet, v[2])};
    m.surface_faces.push_back(nodes);
    m.surface_tet.push_back(f.tet);
    const Vec3 an = 0.5 * cross(m.X[nodes[1]] - m.X[nodes[0]], m.X[nodes[2]] - m.X[nodes[0]]);
    const real area = norm(an);
    bool top = true, bottom = true;
    for (int n : nodes) {
      top = top && m.X[n].z > m.box_max.z - tol;
      bottom = bottom && m.X[n].z < m.box_min.z + tol;
    }
    if (top) s.top_area += area;
    if (bottom) s.bottom_area += area;
    for (int n : nodes) {
      s.area[n] += area / 3;
      s.h[n] = std::max(s.h[n], tet_hmin[f.tet]);
      s.surface[n] = 1;
      (top ? s.top : bottom ? s.bottom : s.lateral)[n] = 1;
    }
  }
  return s;
}

/// The nominal loaded area: the mean of the flat ends, or, with none (a Brazilian disc between
/// flat platens, loaded along a line), the loaded diametral plane, height x thickness along y.
/// The axial stress is then P / (D t) and the indirect tensile stress 2 P / (pi D t).
void set_nominal_area(const SurfaceNodes& s, Model& m) {
  m.area0 = 0.5 * (s.top_area + s.bottom_area);
  if (!(m.area0 > 0)) {
    m.line_loaded = true;
    m.area0 = m.height0 * (m.box_max.y - m.box_min.y);
  }
}

/// The node groups of the loads and monitors: platen contact nodes, top, bottom and lateral.
void set_node_groups(const SurfaceNodes& s, Model& m) {
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    if (s.surface[n]) {
      m.platen_nodes.push_back(int(n));
      m.platen_node_area.push_back(s.area[n]);
      m.platen_node_h.push_back(s.h[n]);
    }
    if (s.top[n]) m.top_nodes.push_back(int(n));
    if (s.bottom[n]) m.bottom_nodes.push_back(int(n));
    if (s.lateral[n] && !s.top[n] && !s.bottom[n] && !m.line_loaded) m.lateral_nodes.push_back(int(n));
    // A disc: the lateral strain is that of its horizontal diameter, from the rim nodes at its
    // two ends (within 0.1 D of mid-height, at the x extremes).
    if (m.line_loaded && s.surface[n] && std::fabs(m.X[n].z - (m.box_min.z + 0.5 * m.height0)) < 0.1 * m.height0 &&
        std::fabs(m.X[n].x - m.axis_point.x) > 0.5 * (m.box_max.x - m.box_min.x) - 0.25 * m.mean_edge)
      m.lateral_nodes.push_back(int(n));
  }
}

}  // namespace

VertexTets::VertexTets(const Model& m) {
  int nv = 0;
  for (int v : m.node_vertex) nv = std::max(nv, v + 1);
  ptr.assign(nv + 1, 0);
  for (const auto& q : m.tet_nodes)
    for (int n : q) ++ptr[m.node_vertex[n] + 1];
  for (int i = 0; i < nv; ++i) ptr[i + 1] += ptr[i];
  tets.resize(ptr[nv]);
  std::vector<int> fill(ptr.begin(), ptr.end() - 1);
  for (int t = 0; t < int(m.tet_nodes.size()); ++t)
    for (int n : m.tet_nodes[t]) tets[fill[m.node_vertex[n]]++] = t;
}

Model build_model(const Mesh& mesh, const Scene& scene) {
  Model m;
  m.source = mesh.source;
  const int nt = int(mesh.tets.size());
  if (nt == 0) throw InputError(mesh.source + ": the mesh has no tetrahedra");
  TetVertices tv = oriented_tets(mesh, m.mean_edge);
  order_along_morton_curve(mesh, tv, m);
  std::vector<Vec3> centroid(nt);
  std::vector<char> region(nt);
  for (int t = 0; t < nt; ++t) {
    centroid[t] = centroid_of(mesh, tv[t]);
    region[t] = in_region(scene.fracture, centroid[t]);
  }
  JointFaces joints = joint_faces(mesh, scene);
  FaceSplit split = split_faces(mesh, tv, sorted_faces(tv), region, joints);
  check_joint_faces_internal(mesh, scene, joints);
  number_nodes(mesh, tv, split.corner_parent, m);
  const std::vector<std::uint8_t> material = material_of_mesh_tets(mesh, scene);
  m.tet_material.resize(nt);
  for (int t = 0; t < nt; ++t) m.tet_material[t] = material[m.tet_input[t]];
  m.tet_stiffness = draw_tet_stiffness(scene, m);
  m.tet_group = volume_group_tags(mesh, m);
  const std::vector<real> tet_hmin = set_tet_constants(mesh, scene, m);
  insert_ce6(mesh, scene, tv, split, centroid, m);
  set_bounds(m);
  const SurfaceNodes surface = add_surface_faces(mesh, tv, split, centroid, tet_hmin, m);
  set_nominal_area(surface, m);
  set_node_groups(surface, m);
  mark_condition_faces(mesh, scene, m);
  mark_history_groups(mesh, scene, m);
  mark_excavation_stages(mesh, scene, m);
  m.tet_colours = colour_elements(m.tet_nodes, m.X.size(), "TET4");
  m.ce6_colours = colour_elements(m.ce6_nodes, m.X.size(), "CE6");
  number_ce6_in_colour_order(m);
  m.tet_joint = tets_on_joints(scene, m);
  m.ce6_strength = draw_ce6_strengths(scene, m);  // (by the CE6s' final ids)
  return m;
}

}  // namespace fdem
