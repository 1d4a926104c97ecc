#pragma once
// What mesh input's two sources share: the .msh reader (io/msh_reader.cpp) and the rest
// (io/mesh_io.cpp: validation, generation, writing). Not part of the library's interface.
#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "io/mesh_io.hpp"

namespace fdem::mesh_detail {

/// A piece of file text safe to quote in a message: at most 40 characters, printable ASCII.
std::string quote(std::string_view t);

/// The fix for a .msh file fdem cannot read: how to re-save it from gmsh.
extern const char* const kResave;

/// Labels for messages: file meshes name element tags, node tags and lines.
struct Labels {
  std::string prefix;                                     // "file" or "source"
  const std::vector<std::uint64_t>* node_tags = nullptr;  // per vertex
  const std::vector<std::uint64_t>* tet_tags = nullptr;   // per tet
  const std::vector<long>* tet_lines = nullptr;           // per tet

  std::string tet(std::size_t t) const {
    if (tet_tags)
      return prefix + ":" + std::to_string((*tet_lines)[t]) + ": tetrahedron (element tag " +
             std::to_string((*tet_tags)[t]) + ")";
    return prefix + ": tet " + std::to_string(t + 1) + " (1-based index in the mesh)";
  }
  std::string tet_name(std::size_t t) const {
    if (tet_tags)
      return "element " + std::to_string((*tet_tags)[t]) + " (line " + std::to_string((*tet_lines)[t]) + ")";
    return "tet " + std::to_string(t + 1);
  }
  std::string vertex(int v) const {
    if (node_tags) return "node " + std::to_string((*node_tags)[v]);
    return "vertex " + std::to_string(v + 1);
  }
  std::string vertices(int a, int b, int c) const {
    if (node_tags)
      return "nodes " + std::to_string((*node_tags)[a]) + ", " + std::to_string((*node_tags)[b]) + ", " +
             std::to_string((*node_tags)[c]);
    return "vertices " + std::to_string(a + 1) + ", " + std::to_string(b + 1) + ", " + std::to_string(c + 1) +
           " (1-based)";
  }
};

/// validate_mesh with the labels of a file mesh (element tags, node tags, lines).
void validate(const Mesh& m, const Labels& L);

/// Six times the signed volume of the tet (a, b, c, d).
double orient(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d);

/// A face of a tet: its vertices sorted (the key) and as the tet orders them.
struct TetFace {
  std::array<int, 3> key, face;
  bool operator<(const TetFace& o) const { return key < o.key; }
};
/// Every face of every tet, sorted by key: a face two tets share appears twice, in a row.
std::vector<TetFace> sorted_tet_faces(const Mesh& m);

/// Two groups of one dimension with one name could not be told apart by a scene: an
/// InputError naming `source` and the fix.
void check_group_names(const std::string& source, const std::vector<MeshGroup>& groups);

}  // namespace fdem::mesh_detail
