// Mesh input besides the .msh reader (io/msh_reader.cpp): mesh validation, generation through
// the gmsh API, and writing a .msh file. See io/mesh_io.hpp.
#include "io/mesh_io.hpp"

#ifdef FDEM_HAVE_GMSH
#include <gmsh.h>
#endif
#include <omp.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <mutex>
#include <set>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/atomic_file.hpp"
#include "io/mesh_detail.hpp"

namespace fdem {
namespace mesh_detail {

/// A piece of file text safe to quote in a message: at most 40 characters, printable ASCII.
std::string quote(std::string_view t) {
  std::string s = "'";
  const std::size_t n = std::min<std::size_t>(t.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    s += (c >= 32 && c < 127) ? static_cast<char>(c) : '?';
  }
  if (t.size() > n) s += "...";
  return s + "'";
}

const char* const kResave =
    "re-save it from gmsh as an ASCII version 4.1 file, e.g. `gmsh in.msh -save -format msh41 "
    "-setnumber Mesh.Binary 0 -o out.msh` (or File > Export, format 'Gmsh MSH', version 4.1, "
    "binary unticked)";

// ---------------------------------------------------------------------------------------------
// Validation

double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  return dot(b - a, cross(c - a, d - a));
}

std::vector<TetFace> sorted_tet_faces(const Mesh& m) {
  std::vector<TetFace> all;
  all.reserve(4 * m.tets.size());
  for (const auto& q : m.tets)
    for (int i = 0; i < 4; ++i) {
      TetFace f{{}, {q[(i + 1) % 4], q[(i + 2) % 4], q[(i + 3) % 4]}};
      f.key = f.face;
      std::sort(f.key.begin(), f.key.end());
      all.push_back(f);
    }
  std::sort(all.begin(), all.end());
  return all;
}

void check_group_names(const std::string& source, const std::vector<MeshGroup>& groups) {
  std::set<std::pair<int, std::string>> seen;
  for (const MeshGroup& g : groups)
    if (!g.name.empty() && !seen.insert({g.dim, g.name}).second)
      throw InputError(source + ": two " + (g.dim == 3 ? "volume" : "surface") + " groups are named '" + g.name +
                       "'. Fix: give each physical group of a dimension its own name (in the .geo) and mesh again");
}

void validate(const Mesh& m, const Labels& L) {
  const std::size_t nv = m.vertices.size();
  const std::size_t nt = m.tets.size();
  if (nt == 0) throw InputError(L.prefix + ": the mesh has no tetrahedra; mesh the volume (3D), not only its surface");
  if (nv > static_cast<std::size_t>(2147483647)) throw InputError(L.prefix + ": more than 2^31-1 vertices");
  for (std::size_t v = 0; v < nv; ++v) {
    const Vec3& x = m.vertices[v];
    if (!std::isfinite(x.x) || !std::isfinite(x.y) || !std::isfinite(x.z))
      throw InputError(L.prefix + ": " + L.vertex(static_cast<int>(v)) + " has a non-finite coordinate (" + fmt(x.x) +
                       ", " + fmt(x.y) + ", " + fmt(x.z) + "); fix the coordinates");
  }
  for (std::size_t t = 0; t < nt; ++t) {
    const auto& q = m.tets[t];
    for (int i = 0; i < 4; ++i) {
      if (q[i] < 0 || static_cast<std::size_t>(q[i]) >= nv)
        throw InputError(L.tet(t) + " refers to vertex index " + std::to_string(q[i]) + ", outside [0, " +
                         std::to_string(nv) + "); fix the connectivity");
      for (int j = 0; j < i; ++j)
        if (q[i] == q[j])
          throw InputError(L.tet(t) + " uses " + L.vertex(q[i]) +
                           " twice; a tetrahedron needs 4 distinct vertices, "
                           "remove or remesh it");
    }
    const Vec3 &a = m.vertices[q[0]], &b = m.vertices[q[1]], &c = m.vertices[q[2]], &d = m.vertices[q[3]];
    const double vol = std::abs(orient(a, b, c, d)) / 6;
    const double edge = (norm(b - a) + norm(c - a) + norm(d - a) + norm(c - b) + norm(d - b) + norm(d - c)) / 6;
    if (!(vol > 1e-12 * edge * edge * edge))
      throw InputError(L.tet(t) + " has zero or near-zero volume (" + fmt(vol) + " m^3 with mean edge " + fmt(edge) +
                       " m): its 4 vertices are (nearly) coplanar; remesh with optimisation (gmsh -optimize) or "
                       "remove the element");
  }
  // Faces, bucketed by their smallest vertex: count, prefix-sum, fill, sort each bucket.
  struct Face {
    int b, c, t;
  };
  static const int kFace[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};
  std::vector<std::size_t> start(nv + 1, 0);
  auto face_of = [&](std::size_t t, int f) {
    std::array<int, 3> k = {m.tets[t][kFace[f][0]], m.tets[t][kFace[f][1]], m.tets[t][kFace[f][2]]};
    std::sort(k.begin(), k.end());
    return k;
  };
  for (std::size_t t = 0; t < nt; ++t)
    for (int f = 0; f < 4; ++f) ++start[face_of(t, f)[0] + 1];
  for (std::size_t v = 0; v < nv; ++v) start[v + 1] += start[v];
  std::vector<Face> faces(start[nv]);
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t t = 0; t < nt; ++t)
      for (int f = 0; f < 4; ++f) {
        const auto k = face_of(t, f);
        faces[fill[k[0]]++] = {k[1], k[2], static_cast<int>(t)};
      }
  }
  auto opposite = [&](int t, int a, int b, int c) {
    for (int v : m.tets[t])
      if (v != a && v != b && v != c) return v;
    return -1;
  };
  for (std::size_t a = 0; a < nv; ++a) {
    const auto first = faces.begin() + start[a], last = faces.begin() + start[a + 1];
    std::sort(first, last, [](const Face& x, const Face& y) {
      return x.b != y.b ? x.b < y.b : (x.c != y.c ? x.c < y.c : x.t < y.t);
    });
    for (auto i = first; i != last;) {
      auto j = i + 1;
      while (j != last && j->b == i->b && j->c == i->c) ++j;
      const int ia = static_cast<int>(a);
      if (j - i > 2)
        throw InputError(L.prefix + ": the face with " + L.vertices(ia, i->b, i->c) + " is shared by " +
                         std::to_string(j - i) + " tetrahedra (" + L.tet_name(i->t) + ", " + L.tet_name((i + 1)->t) +
                         ", " + L.tet_name((i + 2)->t) + (j - i > 3 ? ", ..." : "") +
                         "), a face can be shared by at most two (non-manifold mesh); remesh the volume");
      if (j - i == 2) {
        const Vec3 &pa = m.vertices[a], &pb = m.vertices[i->b], &pc = m.vertices[i->c];
        const double s1 = orient(pa, pb, pc, m.vertices[opposite(i->t, ia, i->b, i->c)]);
        const double s2 = orient(pa, pb, pc, m.vertices[opposite((i + 1)->t, ia, i->b, i->c)]);
        if ((s1 > 0) == (s2 > 0))
          throw InputError(L.prefix + ": " + L.tet_name(i->t) + " and " + L.tet_name((i + 1)->t) +
                           " share the face with " + L.vertices(ia, i->b, i->c) +
                           " and lie on the same side of it (overlapping or duplicated tetrahedra); remesh the volume");
      }
      i = j;
    }
  }
}

}  // namespace mesh_detail

using mesh_detail::quote;
namespace {

// ---------------------------------------------------------------------------------------------
// gmsh session (builds without gmsh read .msh files only)
#ifdef FDEM_HAVE_GMSH

std::mutex g_gmsh_mutex;

std::string exception_text() {
  try {
    throw;
  } catch (const std::exception& e) {
    return e.what();
  } catch (const std::string& s) {  // gmsh 4.8 throws the last error message as a std::string
    return s;
  } catch (...) {
    return "unknown error";
  }
}

class GmshSession {
 public:
  GmshSession() {
#if GMSH_API_VERSION_MAJOR > 4 || (GMSH_API_VERSION_MAJOR == 4 && GMSH_API_VERSION_MINOR >= 11)
    owns_ = !gmsh::isInitialized();
#else
    owns_ = true;  // no way to ask gmsh < 4.11; fdem initialises gmsh only here
#endif
    if (owns_) gmsh::initialize(0, nullptr, /*readConfigFiles=*/false);
    try {
      // gmsh applies General.NumThreads to the process-wide OpenMP setting; the solver's
      // thread count must not be left at gmsh's 1 (see ~GmshSession).
      gmsh::option::setNumber("General.Terminal", std::getenv("FDEM_GMSH_VERBOSE") ? 1 : 0);
      gmsh::model::add("fdem");
    } catch (...) {
      if (owns_) gmsh::finalize();
      throw;
    }
  }
  ~GmshSession() {
    try {
      gmsh::model::remove();
      if (owns_) gmsh::finalize();
    } catch (...) {
    }
    omp_set_num_threads(omp_threads_);
  }
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;

 private:
  bool owns_ = true;
  int omp_threads_ = omp_get_max_threads();
};

/// The tets gmsh has meshed: its nodes that tets use, renumbered compactly in gmsh's order.
/// vertex_of (optional) gets each gmsh node tag's vertex; tet_of each gmsh tet tag's index.
Mesh gmsh_tets(const std::string& what, std::unordered_map<std::size_t, int>* vertex_of = nullptr,
               std::unordered_map<std::size_t, int>* tet_of = nullptr) {
  std::vector<std::size_t> node_tags, tet_tags, tet_nodes;
  std::vector<double> xyz, param;
  gmsh::model::mesh::getNodes(node_tags, xyz, param, -1, -1, false, false);
  gmsh::model::mesh::getElementsByType(4, tet_tags, tet_nodes);
  if (tet_tags.empty()) throw InputError(what + ": gmsh produced no tetrahedra; check the dimensions and element_size");

  // Compact renumbering in gmsh's node order, keeping only nodes used by tetrahedra.
  std::unordered_map<std::size_t, int> index;
  index.reserve(node_tags.size());
  for (std::size_t i = 0; i < node_tags.size(); ++i) index.emplace(node_tags[i], static_cast<int>(i));
  std::vector<int> used(node_tags.size(), -1);
  for (std::size_t tag : tet_nodes) {
    const auto it = index.find(tag);
    if (it == index.end()) throw InputError(what + ": gmsh returned a tetrahedron with an unknown node");
    used[it->second] = 0;
  }
  Mesh mesh;
  mesh.source = what;
  for (std::size_t i = 0; i < node_tags.size(); ++i)
    if (used[i] == 0) {
      used[i] = static_cast<int>(mesh.vertices.size());
      mesh.vertices.push_back({xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]});
      if (vertex_of) vertex_of->emplace(node_tags[i], used[i]);
    }
  mesh.tets.resize(tet_tags.size());
  for (std::size_t t = 0; t < tet_tags.size(); ++t) {
    for (int k = 0; k < 4; ++k) mesh.tets[t][k] = used[index.at(tet_nodes[4 * t + k])];
    if (tet_of) tet_of->emplace(tet_tags[t], static_cast<int>(t));
  }
  return mesh;
}

Mesh mesh_with_gmsh(const MeshSpec& s, const std::string& what) {
  namespace occ = gmsh::model::occ;
  const real h = s.element_size;
  gmsh::option::setNumber("General.NumThreads", 1);
  gmsh::option::setNumber("Mesh.MaxNumThreads1D", 1);
  gmsh::option::setNumber("Mesh.MaxNumThreads2D", 1);
  gmsh::option::setNumber("Mesh.MaxNumThreads3D", 1);
  gmsh::option::setNumber("Geometry.OCCParallel", 0);
  gmsh::option::setNumber("Mesh.Algorithm", 6);    // Frontal-Delaunay surfaces
  gmsh::option::setNumber("Mesh.Algorithm3D", 1);  // Delaunay volumes
  gmsh::option::setNumber("Mesh.ElementOrder", 1);
  gmsh::option::setNumber("Mesh.MeshSizeMax", h);
  gmsh::option::setNumber("Mesh.MeshSizeMin", 0.5 * h);
  gmsh::option::setNumber("Mesh.MeshSizeFromPoints", 0);
  gmsh::option::setNumber("Mesh.MeshSizeExtendFromBoundary", 1);
  gmsh::option::setNumber("Mesh.Optimize", 1);  // tetrahedron optimiser: removes slivers
  gmsh::option::setNumber("Mesh.OptimizeThreshold", s.optimize_threshold);
  gmsh::option::setNumber("Mesh.Smoothing", s.smoothing);  // Laplacian passes; with 1 a few poor tets stay

  if (s.shape == MeshShape::cylinder) {
    occ::addCylinder(0, 0, 0, 0, 0, s.height, s.diameter / 2);
  } else if (s.shape == MeshShape::disc) {
    const real r = s.diameter / 2, t = s.height;
    const int vol = occ::addCylinder(0, -t / 2, r, 0, t, 0, r);
    // The seam of the lateral surface runs along x = 0, z = diameter (checked: OCC puts it at the
    // local x axis, which is +z here). Split the lateral face along x = 0, z = 0 as well, so both
    // platen contact lines are mesh edges and the disc touches the platens exactly at z = 0, D.
    const int p0 = occ::addPoint(0, -t / 2, 0), p1 = occ::addPoint(0, t / 2, 0);
    const int line = occ::addLine(p0, p1);
    gmsh::vectorpair out;
    std::vector<gmsh::vectorpair> map;
    occ::fragment({{3, vol}}, {{1, line}}, out, map);
  } else {
    occ::addBox(0, 0, 0, s.size.x, s.size.y, s.size.z);
  }
  occ::synchronize();
  gmsh::model::mesh::generate(3);
  return gmsh_tets(what);
}

/// The physical groups of dimension 3 and 2 of the meshed .geo, as the mesh's groups.
void gmsh_groups(Mesh& mesh, const std::unordered_map<std::size_t, int>& vertex_of,
                 const std::unordered_map<std::size_t, int>& tet_of) {
  for (const int dim : {3, 2}) {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups, dim);
    for (const auto& [d, tag] : groups) {
      MeshGroup g;
      g.dim = d, g.tag = tag;
      gmsh::model::getPhysicalName(d, tag, g.name);
      std::vector<int> entities;
      gmsh::model::getEntitiesForPhysicalGroup(d, tag, entities);
      for (const int e : entities) {
        std::vector<std::size_t> tags, nodes;
        gmsh::model::mesh::getElementsByType(d == 3 ? 4 : 2, tags, nodes, e);
        for (std::size_t k = 0; k < tags.size(); ++k) {
          if (d == 3) {
            g.tets.push_back(tet_of.at(tags[k]));
            continue;
          }
          std::array<int, 3> f{};
          for (int i = 0; i < 3; ++i) {
            const auto it = vertex_of.find(nodes[3 * k + i]);
            if (it == vertex_of.end())
              throw InputError(mesh.source + ": " + g.label() + " has a triangle off the volume mesh. Fix: embed the " +
                               "surface in the volume (Surface{...} In Volume{...})");
            f[i] = it->second;
          }
          g.faces.push_back(f);
        }
      }
      std::sort(g.tets.begin(), g.tets.end());
      mesh.groups.push_back(std::move(g));
    }
  }
  mesh_detail::check_group_names(mesh.source, mesh.groups);
}

/// A .geo file meshed by gmsh (its own kernel, built-in or OpenCASCADE), with element_size as
/// the largest element when given (and min_element_size, or half of it, the smallest: the
/// script's size fields grade between them), and its physical groups.
Mesh mesh_geo(const MeshSpec& s) {
  gmsh::option::setNumber("General.NumThreads", 1);
  gmsh::option::setNumber("Mesh.ElementOrder", 1);
  gmsh::open(s.file);
  if (s.element_size > 0) {
    gmsh::option::setNumber("Mesh.MeshSizeMax", s.element_size);
    gmsh::option::setNumber("Mesh.MeshSizeMin", s.min_element_size > 0 ? s.min_element_size : 0.5 * s.element_size);
  }
  std::string error;
  gmsh::logger::getLastError(error);
  if (error.empty()) {
    gmsh::model::mesh::generate(3);
    gmsh::logger::getLastError(error);
  }
  if (!error.empty())
    throw InputError(s.file + ": gmsh could not mesh it: " + error + ". Fix: open it in gmsh and correct the geometry");
  std::unordered_map<std::size_t, int> vertex_of, tet_of;
  Mesh mesh = gmsh_tets(s.file, &vertex_of, &tet_of);
  if (s.scale != 1)
    for (Vec3& x : mesh.vertices) x = s.scale * x;
  gmsh_groups(mesh, vertex_of, tet_of);
  return mesh;
}

using Triangle = std::array<int, 3>;

/// The faces of one tet only, as its tet orders them.
std::vector<Triangle> boundary_faces(const Mesh& m) {
  const std::vector<mesh_detail::TetFace> all = mesh_detail::sorted_tet_faces(m);
  std::vector<Triangle> out;
  for (std::size_t i = 0; i < all.size(); ++i) {
    const bool twice = (i > 0 && all[i - 1].key == all[i].key) || (i + 1 < all.size() && all[i + 1].key == all[i].key);
    if (!twice) out.push_back(all[i].face);
  }
  return out;
}

/// A plane x[axis] = at that names the boundary faces on it.
struct NamedPlane {
  const char* name;
  int axis;
  real at;
};

/// The planes of a generated shape's flat faces (the lateral surface is the rest).
std::vector<NamedPlane> shape_planes(const MeshSpec& s) {
  if (s.shape == MeshShape::cylinder) return {{"top", 2, s.height}, {"bottom", 2, 0}};
  if (s.shape == MeshShape::disc) return {{"ymin", 1, -s.height / 2}, {"ymax", 1, s.height / 2}};
  return {{"xmin", 0, 0},        {"xmax", 0, s.size.x}, {"ymin", 1, 0},
          {"ymax", 1, s.size.y}, {"zmin", 2, 0},        {"zmax", 2, s.size.z}};
}

/// The generated shape's surfaces as groups, tagged from 1 in this order: a cylinder's top,
/// bottom and lateral; a disc's ymin, ymax and lateral; a box's xmin, xmax, ymin, ymax, zmin,
/// zmax. A boundary face lies on a plane when its three vertices do, within 1e-9 of the size.
void name_surfaces(Mesh& m, const MeshSpec& s) {
  const std::vector<NamedPlane> planes = shape_planes(s);
  const char* rest = s.shape == MeshShape::box ? nullptr : "lateral";
  const real tol = 1e-9 * std::max({s.diameter, s.height, s.size.x, s.size.y, s.size.z});
  std::vector<MeshGroup> groups(planes.size() + (rest ? 1 : 0));
  for (std::size_t i = 0; i < groups.size(); ++i) {
    groups[i].name = i < planes.size() ? planes[i].name : rest;
    groups[i].dim = 2;
    groups[i].tag = static_cast<int>(i + 1);
  }
  auto coord = [&](int v, int axis) {
    return axis == 0 ? m.vertices[v].x : axis == 1 ? m.vertices[v].y : m.vertices[v].z;
  };
  for (const Triangle& f : boundary_faces(m)) {
    std::size_t g = 0;
    while (g < planes.size() && !std::all_of(f.begin(), f.end(), [&](int v) {
             return std::fabs(coord(v, planes[g].axis) - planes[g].at) <= tol;
           }))
      ++g;
    if (g == groups.size()) throw InputError(m.source + ": a boundary face lies on none of the box's faces");
    groups[g].faces.push_back(f);
  }
  m.groups = std::move(groups);
}

#endif  // FDEM_HAVE_GMSH (the generated shapes' surfaces: only gmsh generates)

}  // namespace

// ---------------------------------------------------------------------------------------------

void validate_mesh(const Mesh& mesh) {
  mesh_detail::Labels L;
  L.prefix = mesh.source.empty() ? std::string("mesh") : mesh.source;
  mesh_detail::validate(mesh, L);
}

Mesh generate_mesh(const MeshSpec& s) {
  const real h = s.element_size;
  std::string what;
  real volume = 0;
  auto positive = [](real v) { return v > 0 && std::isfinite(v); };
  if (!positive(h)) throw InputError("mesh.element_size must be a positive length in metres, got " + fmt(h));
  if (s.shape == MeshShape::cylinder || s.shape == MeshShape::disc) {
    const std::string shape = name_of(s.shape);
    if (!positive(s.diameter) || !positive(s.height))
      throw InputError("mesh: a " + shape + " needs diameter > 0 and height > 0 (m), got diameter " + fmt(s.diameter) +
                       ", height " + fmt(s.height));
    what = "generated " + shape + " (diameter " + fmt(s.diameter) + " m, " +
           (s.shape == MeshShape::disc ? "thickness " : "height ") + fmt(s.height) + " m, element_size " + fmt(h) +
           " m)";
    volume = 3.14159265358979323846 * s.diameter * s.diameter / 4 * s.height;
  } else if (s.shape == MeshShape::box) {
    if (!positive(s.size.x) || !positive(s.size.y) || !positive(s.size.z))
      throw InputError("mesh: a box needs size > 0 in x, y and z (m), got (" + fmt(s.size.x) + ", " + fmt(s.size.y) +
                       ", " + fmt(s.size.z) + ")");
    what = "generated box (" + fmt(s.size.x) + " x " + fmt(s.size.y) + " x " + fmt(s.size.z) + " m, element_size " +
           fmt(h) + " m)";
    volume = s.size.x * s.size.y * s.size.z;
  } else {
    throw InputError(
        std::string("mesh: nothing to generate (") +
        (s.shape == MeshShape::file ? "the shape says the mesh is read from mesh.file" : "an unknown shape") +
        "); use cylinder, disc or box, or give mesh.file");
  }
  // About 6-8 tets per h^3 of volume; refuse what gmsh would take hours on (or run out of memory).
  const double estimate = 8 * volume / (h * h * h);
  if (estimate > 5e7)
    throw InputError(what + ": would give about " + fmt(estimate / 1e6) +
                     " million tetrahedra; increase element_size or mesh it outside fdem and give mesh.file");

#ifdef FDEM_HAVE_GMSH
  std::lock_guard<std::mutex> lock(g_gmsh_mutex);
  Mesh mesh;
  try {
    GmshSession session;
    mesh = mesh_with_gmsh(s, what);
    name_surfaces(mesh, s);
  } catch (const InputError&) {
    throw;
  } catch (...) {
    throw InputError(what + ": gmsh failed: " + exception_text() + "; check the dimensions and element_size");
  }
  validate_mesh(mesh);
  return mesh;
#else
  throw InputError(what +
                   ": this fdem was built without gmsh, which generates meshes. Fix: give mesh.file (a .msh "
                   "file meshed elsewhere, or written by fdem check --write-mesh where gmsh is), or build where "
                   "gmsh is installed (apt-get install libgmsh-dev)");
#endif
}

namespace {

/// The $PhysicalNames section of the mesh's named groups ("" when none is named).
std::string physical_names(const Mesh& mesh) {
  std::string names;
  std::size_t n = 0;
  for (const MeshGroup& g : mesh.groups)
    if (!g.name.empty()) names += std::to_string(g.dim) + ' ' + std::to_string(g.tag) + " \"" + g.name + "\"\n", ++n;
  return n ? "$PhysicalNames\n" + std::to_string(n) + '\n' + names + "$EndPhysicalNames\n" : std::string();
}

/// v2.2 elements: each tet once in mesh order with its first volume group's tag (0: none), then
/// once more for each further volume group it is in, then each surface group's triangles.
std::string msh_elements(const Mesh& mesh, const std::function<void(std::string&, std::size_t)>& put) {
  std::vector<int> first(mesh.tets.size(), 0);
  std::vector<std::pair<int, int>> more;  // (tet, tag)
  std::size_t triangles = 0;
  for (const MeshGroup& g : mesh.groups) {
    triangles += g.faces.size();
    for (const int t : g.tets) {
      if (first[t] == 0)
        first[t] = g.tag;
      else
        more.push_back({t, g.tag});
    }
  }
  std::string text = "$Elements\n" + std::to_string(mesh.tets.size() + more.size() + triangles) + '\n';
  std::size_t tag = 0;
  auto element = [&](int type, int physical, const int* v, int nv) {
    put(text, ++tag);
    text +=
        ' ' + std::to_string(type) + " 2 " + std::to_string(physical) + ' ' + std::to_string(physical ? physical : 1);
    for (int i = 0; i < nv; ++i) text += ' ', put(text, std::size_t(v[i]) + 1);
    text += '\n';
  };
  for (std::size_t t = 0; t < mesh.tets.size(); ++t) element(4, first[t], mesh.tets[t].data(), 4);
  for (const auto& [t, physical] : more) element(4, physical, mesh.tets[t].data(), 4);
  for (const MeshGroup& g : mesh.groups)
    for (const auto& f : g.faces) element(2, g.tag, f.data(), 3);
  return text + "$EndElements\n";
}

}  // namespace

void write_msh(const Mesh& mesh, const std::string& path) {
  std::string text = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n" + physical_names(mesh) + "$Nodes\n" +
                     std::to_string(mesh.vertices.size()) + '\n';
  text.reserve(text.size() + 64 * mesh.vertices.size() + 48 * mesh.tets.size() + 64);
  char buf[32];
  auto put = [&](std::string& out, auto v) {  // shortest round-trip text of an integer or a double
    const auto r = std::to_chars(buf, buf + sizeof buf, v);
    out.append(buf, r.ptr);
  };
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vec3& x = mesh.vertices[i];
    put(text, i + 1);
    for (const real c : {x.x, x.y, x.z}) text += ' ', put(text, c);
    text += '\n';
  }
  text += "$EndNodes\n" + msh_elements(mesh, [&](std::string& out, std::size_t v) { put(out, v); });
  write_file_atomically(path, text);
}

std::string describe_groups(const Mesh& mesh) {
  std::string out = mesh.groups.empty() ? "" : "mesh groups (scenes name them):\n";
  for (const MeshGroup& g : mesh.groups) {
    double size = 0;
    for (const int t : g.tets) {
      const auto& q = mesh.tets[t];
      size += std::fabs(mesh_detail::orient(mesh.vertices[q[0]], mesh.vertices[q[1]], mesh.vertices[q[2]],
                                            mesh.vertices[q[3]])) /
              6;
    }
    for (const auto& f : g.faces)
      size += 0.5 * norm(cross(mesh.vertices[f[1]] - mesh.vertices[f[0]], mesh.vertices[f[2]] - mesh.vertices[f[0]]));
    out += "  group " + g.label() + " (" + std::to_string(g.dim) + "D, tag " + std::to_string(g.tag) + "): " +
           (g.dim == 3 ? std::to_string(g.tets.size()) + " tets, " + fmt(size) + " m^3"
                       : std::to_string(g.faces.size()) + " triangle(s), " + fmt(size) + " m^2") +
           '\n';
  }
  return out;
}

Mesh mesh_geo_file(const MeshSpec& s) {
#ifdef FDEM_HAVE_GMSH
  std::lock_guard<std::mutex> lock(g_gmsh_mutex);
  Mesh mesh;
  try {
    GmshSession session;
    mesh = mesh_geo(s);
  } catch (const InputError&) {
    throw;
  } catch (...) {
    throw InputError(s.file + ": gmsh could not mesh it: " + exception_text() +
                     ". Fix: open it in gmsh and correct the geometry");
  }
  validate_mesh(mesh);
  return mesh;
#else
  throw InputError(s.file +
                   ": a .geo file needs gmsh to mesh it, and this fdem was built without gmsh. Fix: mesh it where "
                   "gmsh is (fdem check --write-mesh writes the .msh, groups included) and give that .msh");
#endif
}

Mesh load_mesh(const MeshSpec& spec) {
  if (!spec.file.empty()) return spec.geo() ? mesh_geo_file(spec) : read_msh(spec.file, spec.scale);
  return generate_mesh(spec);
}

}  // namespace fdem
