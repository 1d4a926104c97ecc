// Mesh -> Model: node splitting, CE6 insertion, surfaces, node groups, masses, colourings.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>

#include "core/error.hpp"
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
  std::iota(m.ce6_colours.order.begin(), m.ce6_colours.order.end(), 0);
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
  const Material& mat = scene.material;
  const SolverSettings& sol = scene.solver;
  Model m;
  m.source = mesh.source;
  const int nt = int(mesh.tets.size());
  if (nt == 0) throw InputError(mesh.source + ": the mesh has no tetrahedra");

  // Orient every tet positively; reject degenerate ones.
  std::vector<std::array<int, 4>> tv = mesh.tets;
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
  m.mean_edge = edge_sum / (6.0 * nt);

  // Renumber tets along a Morton (Z-order) curve of their centroids, so that the nodes and
  // CE6s that follow them are close in memory when neighbours are close in space.
  {
    Vec3 lo = mesh.vertices[tv[0][0]], hi = lo;
    for (const Vec3& x : mesh.vertices)
      for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], x[d]), hi[d] = std::max(hi[d], x[d]);
    std::vector<std::pair<std::uint64_t, int>> key(nt);
    for (int t = 0; t < nt; ++t) {
      Vec3 c{0, 0, 0};
      for (int i = 0; i < 4; ++i) c += 0.25 * mesh.vertices[tv[t][i]];
      std::uint64_t code = 0;
      for (int d = 0; d < 3; ++d) {
        const real u = hi[d] > lo[d] ? (c[d] - lo[d]) / (hi[d] - lo[d]) : 0;
        const auto q = std::uint64_t(std::min<real>(u * (1 << 21), (1 << 21) - 1));
        for (int b = 0; b < 21; ++b) code |= ((q >> b) & 1u) << (3 * b + d);
      }
      key[t] = {code, t};
    }
    std::sort(key.begin(), key.end());
    std::vector<std::array<int, 4>> sorted(nt);
    m.tet_input.resize(nt);
    for (int t = 0; t < nt; ++t) {
      sorted[t] = tv[key[t].second];
      m.tet_input[t] = key[t].second;
    }
    tv.swap(sorted);
  }
  const real vol_floor = 1e-9 * m.mean_edge * m.mean_edge * m.mean_edge;

  // Faces: sort (sorted triple, tet, local) and pair equal keys.
  std::vector<FaceRef> faces;
  faces.reserve(4 * std::size_t(nt));
  for (int t = 0; t < nt; ++t)
    for (int i = 0; i < 4; ++i) {
      std::array<int, 3> k{tv[t][(i + 1) % 4], tv[t][(i + 2) % 4], tv[t][(i + 3) % 4]};
      std::sort(k.begin(), k.end());
      faces.push_back({k, t, i});
    }
  std::sort(faces.begin(), faces.end(),
            [](const FaceRef& a, const FaceRef& b) { return a.key != b.key ? a.key < b.key : a.tet < b.tet; });

  std::vector<Vec3> centroid(nt);
  std::vector<char> region(nt);
  for (int t = 0; t < nt; ++t) {
    Vec3 c{0, 0, 0};
    for (int i = 0; i < 4; ++i) c += 0.25 * mesh.vertices[tv[t][i]];
    centroid[t] = c;
    region[t] = in_region(scene.fracture, c);
  }

  // Corners 4t+i; corners across a non-cohesive internal face share a node.
  std::vector<int> parent(4 * std::size_t(nt));
  std::iota(parent.begin(), parent.end(), 0);
  struct Pair {
    int a, b;  // tets, a < b
    std::array<int, 3> key;
  };
  std::vector<Pair> cohesive;
  std::vector<FaceRef> surface;
  auto corner_of = [&](int t, int vertex) {
    for (int i = 0; i < 4; ++i)
      if (tv[t][i] == vertex) return 4 * t + i;
    return -1;
  };
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
      surface.push_back(faces[i]);
    } else {
      const int a = faces[i].tet, b = faces[i + 1].tet;
      if (region[a] && region[b]) {
        cohesive.push_back({a, b, faces[i].key});
      } else {
        for (int v : faces[i].key) unite(parent, corner_of(a, v), corner_of(b, v));
      }
    }
    i = j;
  }

  // CE6s follow their first tet, so they too are in Morton order.
  std::sort(cohesive.begin(), cohesive.end(),
            [](const Pair& p, const Pair& q) { return p.a != q.a ? p.a < q.a : p.b < q.b; });

  // Compact node numbering in order of first corner (deterministic).
  std::vector<int> node_of_root(parent.size(), -1);
  m.tet_nodes.resize(nt);
  for (int t = 0; t < nt; ++t)
    for (int i = 0; i < 4; ++i) {
      const int r = find_root(parent, 4 * t + i);
      if (node_of_root[r] < 0) {
        node_of_root[r] = int(m.X.size());
        m.X.push_back(mesh.vertices[tv[t][i]]);
        m.node_vertex.push_back(tv[t][i]);
      }
      m.tet_nodes[t][i] = node_of_root[r];
    }
  const std::size_t nn = m.X.size();
  auto node = [&](int t, int vertex) { return m.tet_nodes[t][corner_of(t, vertex) - 4 * t]; };

  // Per-tet constants, masses, damping.
  const real density = sol.mass_scaling * mat.density;
  m.mass.assign(nn, 0);
  m.tet_Xinv.resize(nt);
  m.tet_V0.resize(nt);
  m.tet_eta.resize(nt);
  std::vector<real> tet_hmin(nt);
  m.min_altitude = 1e300;
  for (int t = 0; t < nt; ++t) {
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
    m.tet_eta[t] = sol.damping_scale * critical_damping(tet_hmin[t], sol.mass_scaling, mat.density, mat.youngs_modulus);
    for (int i = 0; i < 4; ++i) m.mass[m.tet_nodes[t][i]] += density * ref.V0 / 4;
  }

  // CE6: A-side face ordered so that its right-hand normal points out of A (into B).
  m.ce6_nodes.reserve(cohesive.size());
  for (const Pair& p : cohesive) {
    std::array<int, 3> v = p.key;
    const Vec3 a = mesh.vertices[v[0]], b = mesh.vertices[v[1]], c = mesh.vertices[v[2]];
    if (dot(cross(b - a, c - a), centroid[p.a] - a) > 0) std::swap(v[1], v[2]);
    m.ce6_nodes.push_back(
        {node(p.a, v[0]), node(p.a, v[1]), node(p.a, v[2]), node(p.b, v[0]), node(p.b, v[1]), node(p.b, v[2])});
    m.ce6_tets.push_back({p.a, p.b});
    m.ce6_h.push_back((norm(b - a) + norm(c - b) + norm(a - c)) / 3);
  }

  // Surface faces (outward), bounding box, node groups.
  m.box_min = m.box_max = m.X[0];
  for (const Vec3& x : m.X)
    for (int d = 0; d < 3; ++d) {
      m.box_min[d] = std::min(m.box_min[d], x[d]);
      m.box_max[d] = std::max(m.box_max[d], x[d]);
    }
  m.axis_point = {0.5 * (m.box_min.x + m.box_max.x), 0.5 * (m.box_min.y + m.box_max.y), m.box_min.z};
  m.height0 = m.box_max.z - m.box_min.z;
  const real tol = 1e-3 * m.mean_edge;
  std::vector<real> node_area(nn, 0), node_h(nn, 0);
  std::vector<char> is_top(nn, 0), is_bottom(nn, 0), is_lateral(nn, 0), is_surface(nn, 0);
  real top_area = 0, bottom_area = 0;
  for (const FaceRef& f : surface) {
    std::array<int, 3> v = f.key;
    const Vec3 a = mesh.vertices[v[0]], b = mesh.vertices[v[1]], c = mesh.vertices[v[2]];
    if (dot(cross(b - a, c - a), centroid[f.tet] - a) > 0) std::swap(v[1], v[2]);
    const std::array<int, 3> nodes{node(f.tet, v[0]), node(f.tet, v[1]), node(f.tet, v[2])};
    m.surface_faces.push_back(nodes);
    m.surface_tet.push_back(f.tet);
    const Vec3 an = 0.5 * cross(m.X[nodes[1]] - m.X[nodes[0]], m.X[nodes[2]] - m.X[nodes[0]]);
    const real area = norm(an);
    bool top = true, bottom = true;
    for (int n : nodes) {
      top = top && m.X[n].z > m.box_max.z - tol;
      bottom = bottom && m.X[n].z < m.box_min.z + tol;
    }
    if (top) top_area += area;
    if (bottom) bottom_area += area;
    for (int n : nodes) {
      node_area[n] += area / 3;
      node_h[n] = std::max(node_h[n], tet_hmin[f.tet]);
      is_surface[n] = 1;
      (top ? is_top : bottom ? is_bottom : is_lateral)[n] = 1;
    }
  }
  m.area0 = 0.5 * (top_area + bottom_area);
  if (!(m.area0 > 0)) {
    // No flat ends (a Brazilian disc between flat platens, loaded along a line): the nominal
    // area is the loaded diametral plane, height x thickness along y, so that the axial
    // stress is P / (D t) and the indirect tensile stress 2 P / (pi D t).
    m.line_loaded = true;
    m.area0 = m.height0 * (m.box_max.y - m.box_min.y);
  }
  for (std::size_t n = 0; n < nn; ++n) {
    if (is_surface[n]) {
      m.platen_nodes.push_back(int(n));
      m.platen_node_area.push_back(node_area[n]);
      m.platen_node_h.push_back(node_h[n]);
    }
    if (is_top[n]) m.top_nodes.push_back(int(n));
    if (is_bottom[n]) m.bottom_nodes.push_back(int(n));
    if (is_lateral[n] && !is_top[n] && !is_bottom[n] && !m.line_loaded) m.lateral_nodes.push_back(int(n));
    // A disc: the lateral strain is that of its horizontal diameter, from the rim nodes at its
    // two ends (within 0.1 D of mid-height, at the x extremes).
    if (m.line_loaded && is_surface[n] && std::fabs(m.X[n].z - (m.box_min.z + 0.5 * m.height0)) < 0.1 * m.height0 &&
        std::fabs(m.X[n].x - m.axis_point.x) > 0.5 * (m.box_max.x - m.box_min.x) - 0.25 * m.mean_edge)
      m.lateral_nodes.push_back(int(n));
  }

  m.tet_colours = colour_elements(m.tet_nodes, nn, "TET4");
  m.ce6_colours = colour_elements(m.ce6_nodes, nn, "CE6");
  number_ce6_in_colour_order(m);
  return m;
}

}  // namespace fdem
