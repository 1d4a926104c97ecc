// The gmsh .msh reader: a hand-written parser of ASCII v2.2 and v4.1 files, strict about what
// it cannot read. See io/mesh_io.hpp (read_msh).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string_view>
#include <system_error>
#include <unordered_map>
#include <vector>

#include "core/error.hpp"
#include "core/format.hpp"
#include "io/mesh_detail.hpp"
#include "io/mesh_io.hpp"
#include "io/msh_groups.hpp"
#include "io/msh_text.hpp"

namespace fdem {
using mesh_detail::kResave;
using mesh_detail::PhysicalGroups;
using mesh_detail::quote;
using mesh_detail::RawFace;
using mesh_detail::RawTet;
using mesh_detail::Reader;
namespace {

// ---------------------------------------------------------------------------------------------
// .msh parsing

/// Hash of node tags read from the file, keyed per process: with std::hash (the identity), tags
/// that are multiples of the bucket count all share one bucket and each lookup scans every node
/// (a 5 MB mesh took 15 s instead of 0.3 s).
struct TagHash {
  static std::uint64_t process_key() {
    static const std::uint64_t k = (std::uint64_t{std::random_device{}()} << 32 | std::random_device{}()) | 1;
    return k;
  }
  std::uint64_t key = process_key();
  std::size_t operator()(std::uint64_t t) const {
    t = (t ^ key) * 0x9E3779B97F4A7C15ull;  // splitmix64 finaliser
    t = (t ^ (t >> 30)) * 0xBF58476D1CE4E5B9ull;
    t = (t ^ (t >> 27)) * 0x94D049BB133111EBull;
    return static_cast<std::size_t>(t ^ (t >> 31));
  }
};

struct MshData {
  std::vector<Vec3> coords;
  std::vector<std::uint64_t> node_tags;
  std::vector<long> node_lines;
  std::unordered_map<std::uint64_t, int, TagHash> node_index;  // tag -> index into coords
  std::vector<RawTet> tets;
  std::vector<RawFace> faces;  // triangles, which become surface groups' faces
  PhysicalGroups groups;
  std::uint64_t other_elements = 0;  // elements of types other than 4
  std::uint64_t other_volumes = 0;   // of them, volume elements (hexahedra, prisms, 10-node tets...)
  std::uint64_t first_volume_tag = 0, first_volume_type = 0;
  long first_volume_line = 0;
};

/// Number of nodes of the gmsh element types (index = type); 0 = unknown type.
int nodes_of_type(std::uint64_t type) {
  static const int n[] = {0, 2, 3, 4, 4, 8, 6, 5, 3, 6, 9, 10, 27, 18, 14, 1, 8, 20, 15, 13};
  return type < sizeof(n) / sizeof(n[0]) ? n[type] : 0;
}

/// The gmsh volume element types other than the 4-node tet (4), by name; nullptr for the points,
/// lines and surfaces a mesh file also holds (fdem passes over them).
const char* other_volume_name(std::uint64_t type) {
  switch (type) {
    case 5:
      return "an 8-node hexahedron";
    case 6:
      return "a 6-node prism";
    case 7:
      return "a 5-node pyramid";
    case 11:
      return "a 10-node tetrahedron";
    case 12:
      return "a 27-node hexahedron";
    case 13:
      return "an 18-node prism";
    case 14:
      return "a 14-node pyramid";
    case 17:
      return "a 20-node hexahedron";
    case 18:
      return "a 15-node prism";
    case 19:
      return "a 13-node pyramid";
    default:
      return nullptr;
  }
}

/// An element that is not a 4-node tet: counted, and a volume element remembered (the mesh would
/// lose its volume), or a type fdem does not know refused at its line.
void other_element(Reader& r, MshData& d, std::uint64_t tag, std::uint64_t type) {
  ++d.other_elements;
  if (other_volume_name(type)) {
    if (d.other_volumes++ == 0) d.first_volume_tag = tag, d.first_volume_type = type, d.first_volume_line = r.line_no();
  } else if (nodes_of_type(type) == 0) {
    r.fail("element tag " + std::to_string(tag) + " has type " + std::to_string(type) +
               ", not one of the first-order or quadratic gmsh types 1 to 19 fdem reads (a higher-order or unknown "
               "element)",
           "mesh with first-order elements (Mesh.ElementOrder 1, or gmsh -3 -order 1) and export again");
  }
}

void add_node(Reader& r, MshData& d, std::uint64_t tag, Vec3 x, long line) {
  if (tag == 0) r.fail_at(line, "node tag 0: gmsh's tags start at 1", "number the nodes from 1 or re-export the mesh");
  const auto ins = d.node_index.emplace(tag, static_cast<int>(d.coords.size()));
  if (!ins.second)
    r.fail_at(line,
              "node tag " + std::to_string(tag) + " is defined twice (first on line " +
                  std::to_string(d.node_lines[ins.first->second]) + ")",
              "give every node a unique tag");
  if (d.coords.size() >= static_cast<std::size_t>(2147483647))
    r.fail_at(line, "more than 2^31-1 nodes", "use a coarser mesh");
  d.coords.push_back(x);
  d.node_tags.push_back(tag);
  d.node_lines.push_back(line);
}

/// A 3-node triangle whose node tags start at token `at`.
RawFace triangle(const Reader& r, const std::vector<std::string_view>& tok, std::size_t at, std::uint64_t tag,
                 std::int64_t entity) {
  RawFace f{};
  for (int i = 0; i < 3; ++i) f.node[i] = r.u64(tok[at + i], "a node tag");
  f.tag = tag;
  f.entity = entity;
  f.line = r.line_no();
  return f;
}

void nodes_v2(Reader& r, MshData& d) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $Nodes"), tok);
  const long header = r.line_no();
  if (tok.size() != 1)
    r.fail("expected the number of nodes on this line, found " + std::to_string(tok.size()) + " values",
           "write the node count alone on the line after $Nodes");
  const std::uint64_t n = r.count(tok[0], "the number of nodes");
  d.coords.reserve(r.reserve_for(n, 8));
  for (std::uint64_t k = 0; k < n; ++k) {
    Reader::split(data_line(r, "$Nodes", k, n, "nodes", header), tok);
    if (tok.size() != 4)
      r.fail("a node line needs 4 values (tag x y z), found " + std::to_string(tok.size()),
             "fix this line or re-export the mesh");
    const std::uint64_t tag = r.u64(tok[0], "a node tag");
    const Vec3 x{r.number(tok[1], "x coordinate"), r.number(tok[2], "y coordinate"), r.number(tok[3], "z coordinate")};
    add_node(r, d, tag, x, r.line_no());
  }
  expect_end(r, "$EndNodes", std::to_string(n) + " nodes", header);
}

void elements_v2(Reader& r, MshData& d) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $Elements"), tok);
  const long header = r.line_no();
  if (tok.size() != 1)
    r.fail("expected the number of elements on this line, found " + std::to_string(tok.size()) + " values",
           "write the element count alone on the line after $Elements");
  const std::uint64_t n = r.count(tok[0], "the number of elements");
  d.tets.reserve(r.reserve_for(n, 16));
  for (std::uint64_t k = 0; k < n; ++k) {
    Reader::split(data_line(r, "$Elements", k, n, "elements", header), tok);
    if (tok.size() < 3)
      r.fail("an element line needs at least: tag type number-of-tags, found " + std::to_string(tok.size()) + " values",
             "fix this line or re-export the mesh");
    const std::uint64_t tag = r.u64(tok[0], "an element tag");
    const std::uint64_t type = r.u64(tok[1], "an element type");
    const std::uint64_t ntags = r.u64(tok[2], "the number of element tags");
    if (ntags > tok.size() - 3)  // also keeps 3 + ntags + nn below from wrapping around
      r.fail("the element announces " + std::to_string(ntags) + " tags but has only " + std::to_string(tok.size() - 3) +
                 " value(s) after the number of tags",
             "fix the number of tags (the third value) or re-export the mesh");
    const int nn = nodes_of_type(type);
    const std::int64_t physical = ntags > 0 ? r.i64(tok[3], "the physical tag") : 0;
    if (type != 4) {
      other_element(r, d, tag, type);
      if (tok.size() != 3 + ntags + static_cast<std::uint64_t>(nn))
        r.fail("an element of type " + std::to_string(type) + " with " + std::to_string(ntags) + " tags needs " +
                   std::to_string(3 + ntags + nn) + " values, found " + std::to_string(tok.size()),
               "fix this line or re-export the mesh");
      if (type == 2 && physical != 0) d.faces.push_back(triangle(r, tok, 3 + ntags, tag, physical));
      continue;
    }
    if (tok.size() != 3 + ntags + 4)
      r.fail("a tetrahedron (type 4) with " + std::to_string(ntags) + " tags needs " + std::to_string(3 + ntags + 4) +
                 " values, found " + std::to_string(tok.size()),
             "fix this line or re-export the mesh");
    for (std::size_t i = 3; i < 3 + ntags; ++i) r.i64(tok[i], "an element tag value");
    RawTet t{};
    for (int i = 0; i < 4; ++i) t.node[i] = r.u64(tok[3 + ntags + i], "a node tag");
    t.tag = tag;
    t.entity = physical;
    t.line = r.line_no();
    d.tets.push_back(t);
  }
  expect_end(r, "$EndElements", std::to_string(n) + " elements", header);
}

void nodes_v4(Reader& r, MshData& d) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $Nodes"), tok);
  const long header = r.line_no();
  if (tok.size() != 4)
    r.fail("expected 4 values (numEntityBlocks numNodes minNodeTag maxNodeTag), found " + std::to_string(tok.size()),
           "fix this line or re-export the mesh as version 4.1");
  const std::uint64_t blocks = r.count(tok[0], "the number of node blocks");
  const std::uint64_t n = r.count(tok[1], "the number of nodes");
  r.u64(tok[2], "the smallest node tag");
  r.u64(tok[3], "the largest node tag");
  d.coords.reserve(r.reserve_for(n, 8));
  std::uint64_t total = 0;
  std::vector<std::uint64_t> tags;
  std::vector<long> lines;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    Reader::split(data_line(r, "$Nodes", b, blocks, "node blocks", header), tok);
    const long block_line = r.line_no();
    if (tok.size() != 4)
      r.fail("a node block header needs 4 values (entityDim entityTag parametric numNodesInBlock), found " +
                 std::to_string(tok.size()),
             "fix this line or re-export the mesh as version 4.1");
    const std::uint64_t dim = r.u64(tok[0], "the entity dimension");
    r.i64(tok[1], "the entity tag");
    const std::uint64_t param = r.u64(tok[2], "the parametric flag");
    const std::uint64_t m = r.count(tok[3], "the number of nodes in the block");
    if (dim > 3)
      r.fail("entity dimension " + std::to_string(dim) + " is not 0..3", "fix this line or re-export the mesh");
    if (param > 1)
      r.fail("the parametric flag must be 0 or 1, found " + std::to_string(param),
             "fix this line or re-export the mesh");
    total += m;
    if (total > n)
      r.fail("the node blocks hold more nodes than the " + std::to_string(n) + " announced on line " +
                 std::to_string(header),
             "the counts do not match; correct them or re-export the mesh");
    tags.clear();
    lines.clear();
    tags.reserve(r.reserve_for(m, 2));
    for (std::uint64_t k = 0; k < m; ++k) {
      Reader::split(data_line(r, "$Nodes", k, m, "node tags of the block", block_line), tok);
      if (tok.size() != 1)
        r.fail(
            "expected one node tag on this line, found " + std::to_string(tok.size()) + " values",
            "the node count on line " + std::to_string(block_line) + " may be wrong; correct it or re-export the mesh");
      tags.push_back(r.u64(tok[0], "a node tag"));
    }
    const std::size_t want = 3 + (param ? dim : 0);
    for (std::uint64_t k = 0; k < m; ++k) {
      Reader::split(data_line(r, "$Nodes", k, m, "node coordinates of the block", block_line), tok);
      if (tok.size() != want)
        r.fail(
            "a node coordinate line of this block needs " + std::to_string(want) + " values, found " +
                std::to_string(tok.size()),
            "the node count on line " + std::to_string(block_line) + " may be wrong; correct it or re-export the mesh");
      const Vec3 x{r.number(tok[0], "x coordinate"), r.number(tok[1], "y coordinate"),
                   r.number(tok[2], "z coordinate")};
      for (std::size_t i = 3; i < want; ++i) r.number(tok[i], "parametric coordinate");
      add_node(r, d, tags[k], x, r.line_no());
    }
  }
  if (total != n)
    r.fail_at(header, "announces " + std::to_string(n) + " nodes but its blocks hold " + std::to_string(total),
              "correct the count or re-export the mesh");
  expect_end(r, "$EndNodes", std::to_string(blocks) + " node blocks", header);
}

void elements_v4(Reader& r, MshData& d) {
  std::vector<std::string_view> tok;
  Reader::split(r.need("inside $Elements"), tok);
  const long header = r.line_no();
  if (tok.size() != 4)
    r.fail("expected 4 values (numEntityBlocks numElements minElementTag maxElementTag), found " +
               std::to_string(tok.size()),
           "fix this line or re-export the mesh as version 4.1");
  const std::uint64_t blocks = r.count(tok[0], "the number of element blocks");
  const std::uint64_t n = r.count(tok[1], "the number of elements");
  r.u64(tok[2], "the smallest element tag");
  r.u64(tok[3], "the largest element tag");
  std::uint64_t total = 0;
  for (std::uint64_t b = 0; b < blocks; ++b) {
    Reader::split(data_line(r, "$Elements", b, blocks, "element blocks", header), tok);
    const long block_line = r.line_no();
    if (tok.size() != 4)
      r.fail("an element block header needs 4 values (entityDim entityTag elementType numElementsInBlock), found " +
                 std::to_string(tok.size()),
             "fix this line or re-export the mesh as version 4.1");
    r.u64(tok[0], "the entity dimension");
    const std::int64_t entity = r.i64(tok[1], "the entity tag");
    const std::uint64_t type = r.u64(tok[2], "the element type");
    const std::uint64_t m = r.count(tok[3], "the number of elements in the block");
    total += m;
    if (total > n)
      r.fail("the element blocks hold more elements than the " + std::to_string(n) + " announced on line " +
                 std::to_string(header),
             "the counts do not match; correct them or re-export the mesh");
    const int nn = nodes_of_type(type);
    if (type == 4) d.tets.reserve(d.tets.size() + r.reserve_for(m, 10));
    for (std::uint64_t k = 0; k < m; ++k) {
      Reader::split(data_line(r, "$Elements", k, m, "elements of the block", block_line), tok);
      const std::size_t want = 1 + static_cast<std::size_t>(nn);
      if (nn > 0 && tok.size() != want)
        r.fail("an element of type " + std::to_string(type) + " needs " + std::to_string(want) + " values (tag and " +
                   std::to_string(nn) + " node tags), found " + std::to_string(tok.size()),
               "the element count on line " + std::to_string(block_line) +
                   " may be wrong; correct it or re-export the mesh");
      if (type != 4) {
        const std::uint64_t tag = r.u64(tok[0], "an element tag");
        other_element(r, d, tag, type);
        if (type == 2) d.faces.push_back(triangle(r, tok, 1, tag, entity));
        continue;
      }
      RawTet t{};
      t.tag = r.u64(tok[0], "an element tag");
      t.entity = entity;
      for (int i = 0; i < 4; ++i) t.node[i] = r.u64(tok[1 + i], "a node tag");
      t.line = r.line_no();
      d.tets.push_back(t);
    }
  }
  if (total != n)
    r.fail_at(header, "announces " + std::to_string(n) + " elements but its blocks hold " + std::to_string(total),
              "correct the count or re-export the mesh");
  expect_end(r, "$EndElements", std::to_string(blocks) + " element blocks", header);
}

void skip_section(Reader& r, std::string_view name) {
  const long start = r.line_no();
  const std::string end = "$End" + std::string(name.substr(1));
  std::string_view l;
  while (r.next(l))
    if (l == end) return;
  r.fail_at(start, "section " + quote(name) + " has no closing " + end,
            "the file is truncated or damaged; re-export the mesh");
}

std::string read_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto st = fs::status(path, ec);
  if (!fs::exists(st))
    throw InputError(path + ": mesh file does not exist; check the path (mesh.file is relative to the scene file)");
  if (fs::is_directory(st)) throw InputError(path + ": is a directory, not a mesh file; give the path of a .msh file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": mesh file cannot be opened for reading; check its permissions");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw InputError(path + ": error while reading the mesh file; check the file system");
  return s.str();
}

/// The $MeshFormat section: ASCII, version 2.x or 4.1. Returns the major version.
int read_format(Reader& r) {
  std::string_view l;
  if (!r.next(l)) throw InputError(r.path() + ": the mesh file is empty; " + kResave);
  if (l != "$MeshFormat")
    r.fail("expected $MeshFormat on the first line, found " + quote(l) + ": this is not a gmsh .msh file",
           std::string("give a gmsh mesh; if it is one, ") + kResave);
  std::vector<std::string_view> tok;
  const std::string_view format_line = r.need("inside $MeshFormat");
  Reader::split(format_line, tok);
  if (tok.size() != 3)
    r.fail("expected 'version file-type data-size' (e.g. '4.1 0 8'), found " + quote(format_line), kResave);
  const std::string_view version = tok[0];
  if (tok[1] != "0") {
    if (tok[1] == "1") r.fail("this is a binary .msh file; fdem reads ASCII .msh files only", kResave);
    r.fail("file-type must be 0 (ASCII), found " + quote(tok[1]), kResave);
  }
  int major = 0;
  if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2")
    major = 2;
  else if (version == "4.1")
    major = 4;
  else
    r.fail(".msh format version " + quote(version) + " is not supported (fdem reads versions 2.2 and 4.1)", kResave);
  r.u64(tok[2], "the data size");
  const std::string_view e = r.need("inside $MeshFormat");
  if (e != "$EndMeshFormat") r.fail("expected $EndMeshFormat, found " + quote(e), kResave);
  return major;
}

/// The sections after $MeshFormat: one $Nodes and one $Elements, the groups' $PhysicalNames and
/// $Entities; others skipped.
void read_sections(Reader& r, int major, MshData& d) {
  std::string_view l;
  bool have_nodes = false, have_elements = false;
  while (r.next(l)) {
    if (l[0] != '$')
      r.fail("unexpected text " + quote(l) + " outside any section", "remove it or re-export the mesh from gmsh");
    if (l == "$Nodes" || l == "$Elements") {
      bool& have = (l == "$Nodes") ? have_nodes : have_elements;
      if (have)
        r.fail("a second " + std::string(l) + " section", "a .msh file may contain only one; re-export the mesh");
      have = true;
      if (l == "$Nodes")
        major == 2 ? nodes_v2(r, d) : nodes_v4(r, d);
      else
        major == 2 ? elements_v2(r, d) : elements_v4(r, d);
    } else if (l == "$PhysicalNames") {
      mesh_detail::read_physical_names(r, d.groups);
    } else if (l == "$Entities" && major == 4) {
      mesh_detail::read_entities(r, d.groups);
    } else if (l.rfind("$End", 0) == 0) {
      r.fail("unexpected " + quote(l) + " without its opening section", "the file is damaged; re-export the mesh");
    } else {
      skip_section(r, l);
    }
  }
  if (!have_nodes) r.fail("the file has no $Nodes section", "export the mesh (not only the geometry) from gmsh");
  if (!have_elements) r.fail("the file has no $Elements section", "export the mesh (not only the geometry) from gmsh");
}

/// The volume is meshed with 4-node tets only: a volume element of another kind would be left
/// out, and the model with it part of the body.
void check_only_tets(Reader& r, const MshData& d) {
  if (d.other_volumes)
    r.fail_at(d.first_volume_line,
              "element tag " + std::to_string(d.first_volume_tag) + " is " + other_volume_name(d.first_volume_type) +
                  " (type " + std::to_string(d.first_volume_type) + "), one of " + std::to_string(d.other_volumes) +
                  " volume elements besides the " + std::to_string(d.tets.size()) +
                  " 4-node tetrahedra (type 4), the only kind fdem uses (the others would be left out of the model)",
              "mesh the volume with first-order tetrahedra only (Mesh.ElementOrder 1, no recombination into "
              "hexahedra or prisms) and export again");
  if (d.tets.empty()) {
    throw InputError(r.path() + ": the file contains no 4-node tetrahedra (element type 4)" +
                     (d.other_elements ? ", only " + std::to_string(d.other_elements) +
                                             " elements of other types (points, lines, triangles...)"
                                       : std::string()) +
                     "; mesh the volume in 3D (gmsh -3), not only its surface, and export again");
  }
}

/// The tets' node tags resolved; the nodes no tet uses dropped, the others numbered in file
/// order and scaled. Each vertex's and tet's tag and line are kept for messages.
struct ResolvedMesh {
  Mesh mesh;
  std::vector<std::uint64_t> vertex_tags, tet_tags;
  std::vector<long> tet_lines;
  std::vector<int> vertex_of_node;  // per node read: its mesh vertex, -1 for a node no tet uses
};
ResolvedMesh resolve_nodes(Reader& r, const MshData& d, real scale) {
  std::vector<int> vidx(d.coords.size(), -1);
  for (const RawTet& t : d.tets)
    for (int i = 0; i < 4; ++i) {
      const auto it = d.node_index.find(t.node[i]);
      if (it == d.node_index.end())
        r.fail_at(t.line,
                  "element " + std::to_string(t.tag) + " refers to node " + std::to_string(t.node[i]) +
                      ", which is not in $Nodes",
                  "add the node or fix the element's node list");
      vidx[it->second] = 0;
    }
  ResolvedMesh out;
  Mesh& mesh = out.mesh;
  mesh.source = r.path();
  for (std::size_t i = 0; i < d.coords.size(); ++i)
    if (vidx[i] == 0) {
      vidx[i] = static_cast<int>(mesh.vertices.size());
      const Vec3 x = scale * d.coords[i];
      // Beyond 1000 km (after mesh.scale) no rock model lies: a slip of units, and volumes,
      // edges and the time step would overflow.
      if (!(std::fabs(x.x) <= 1e6 && std::fabs(x.y) <= 1e6 && std::fabs(x.z) <= 1e6))
        throw InputError(r.path() + ":" + std::to_string(d.node_lines[i]) + ": node " + std::to_string(d.node_tags[i]) +
                         " lies at (" + fmt(x.x, 3) + ", " + fmt(x.y, 3) + ", " + fmt(x.z, 3) +
                         ") m after mesh.scale " + fmt(scale) +
                         ", more than 1000 km out. Fix: check the coordinates and mesh.scale (1e-3 for a mesh in mm)");
      mesh.vertices.push_back(x);
      out.vertex_tags.push_back(d.node_tags[i]);
    }
  mesh.tets.resize(d.tets.size());
  out.tet_tags.resize(d.tets.size());
  out.tet_lines.resize(d.tets.size());
  for (std::size_t t = 0; t < d.tets.size(); ++t) {
    for (int i = 0; i < 4; ++i) mesh.tets[t][i] = vidx[d.node_index.at(d.tets[t].node[i])];
    out.tet_tags[t] = d.tets[t].tag;
    out.tet_lines[t] = d.tets[t].line;
  }
  out.vertex_of_node = std::move(vidx);
  return out;
}

/// The mesh vertex of the node a surface triangle names.
int vertex_of(const Reader& r, const MshData& d, const ResolvedMesh& m, std::uint64_t node, long line) {
  const auto it = d.node_index.find(node);
  if (it == d.node_index.end())
    r.fail_at(line, "a triangle refers to node " + std::to_string(node) + ", which is not in $Nodes",
              "add the node or fix the element's node list");
  const int v = m.vertex_of_node[it->second];
  if (v < 0)
    r.fail_at(line,
              "a triangle of a surface group uses node " + std::to_string(node) +
                  ", which belongs to no tetrahedron: the surface is not part of the volume mesh",
              "embed the surface in the volume (gmsh: Surface{...} In Volume{...}) and mesh again");
  return v;
}

}  // namespace

Mesh read_msh(const std::string& path, real scale) {
  if (!(scale > 0) || !std::isfinite(scale))
    throw InputError(path + ": mesh scale must be a positive finite number, got " + fmt(scale) +
                     "; set mesh.scale to e.g. 1 (metres) or 1e-3 (millimetres)");
  const std::string text = read_file(path);
  Reader r(path, text);
  MshData d;
  const int major = read_format(r);
  d.groups.entity_is_physical = major == 2;
  read_sections(r, major, d);
  check_only_tets(r, d);
  const auto extra =
      major == 2 ? mesh_detail::merge_repeated_tets(d.tets) : std::vector<std::pair<std::size_t, std::int64_t>>{};
  ResolvedMesh resolved = resolve_nodes(r, d, scale);
  mesh_detail::Labels L;
  L.prefix = path;
  L.node_tags = &resolved.vertex_tags;
  L.tet_tags = &resolved.tet_tags;
  L.tet_lines = &resolved.tet_lines;
  mesh_detail::validate(resolved.mesh, L);
  resolved.mesh.groups = mesh_detail::assemble_groups(
      r, d.groups, d.tets, extra, d.faces,
      [&](std::uint64_t node, long line) { return vertex_of(r, d, resolved, node, line); }, resolved.mesh);
  return std::move(resolved.mesh);
}

}  // namespace fdem
