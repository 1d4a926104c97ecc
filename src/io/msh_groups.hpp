#pragma once
// The physical groups of a .msh file: $PhysicalNames, $Entities (v4.1) and the elements' group
// tags, made into the mesh's named volumes and surfaces. Used by io/msh_reader.cpp; not part of
// the library's interface.
//
// v4.1 files give each element block an entity, and $Entities each entity its physical tags.
// v2.2 files give each element its physical tag (0: none) and write an element once for each
// group it belongs to. Both are read as "an element's entity": v2.2's entity is its physical tag.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "io/msh_text.hpp"
#include "model/mesh.hpp"

namespace fdem::mesh_detail {

/// A 4-node tetrahedron as read: node tags, element tag, entity and line.
struct RawTet {
  std::uint64_t node[4];
  std::uint64_t tag;
  std::int64_t entity;
  long line;
};
/// A 3-node triangle as read (only surfaces' triangles become part of the mesh, through groups).
struct RawFace {
  std::uint64_t node[3];
  std::uint64_t tag;
  std::int64_t entity;
  long line;
};

/// What a file says of its physical groups.
struct PhysicalGroups {
  std::map<std::pair<int, int>, std::string> names;       // (dim, tag) -> name, from $PhysicalNames
  std::map<std::int64_t, std::vector<int>> of_entity[4];  // per dim: entity tag -> physical tags
  bool entity_is_physical = false;                        // v2.2

  /// The physical tags of an element of dimension dim in entity e.
  std::vector<int> physicals(int dim, std::int64_t e) const;
};

/// The $PhysicalNames section (its header line read): "dim tag "name"" lines.
void read_physical_names(Reader& r, PhysicalGroups& g);
/// The $Entities section of v4.1 (its header line read): each entity's physical tags.
void read_entities(Reader& r, PhysicalGroups& g);

/// v2.2 writes a tet once for each volume group it is in: keep the first of each node set and
/// return the entities of the copies dropped, as (index of the kept tet, entity).
std::vector<std::pair<std::size_t, std::int64_t>> merge_repeated_tets(std::vector<RawTet>& tets);

/// The mesh's groups. tets are the mesh's tets as read (mesh order); extra, more entities of
/// them; vertex_of(node tag, line) is the mesh vertex of a node (it fails when there is none).
/// Each surface triangle must be a face of a tet of the mesh.
std::vector<MeshGroup> assemble_groups(const Reader& r, const PhysicalGroups& g, const std::vector<RawTet>& tets,
                                       const std::vector<std::pair<std::size_t, std::int64_t>>& extra,
                                       const std::vector<RawFace>& faces,
                                       const std::function<int(std::uint64_t, long)>& vertex_of, const Mesh& mesh);

}  // namespace fdem::mesh_detail
