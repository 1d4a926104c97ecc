#pragma once
// A tetrahedral mesh as read or generated: shared vertices, 4-node tets. SI units (m).
#include <array>
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

/// A named part of a mesh, from a gmsh physical group or a generated shape: a volume (its tets)
/// or a surface (its triangles). Scenes name it to give it a material, a joint or a condition.
struct MeshGroup {
  std::string name;                       // "" when the file does not name it (scenes use the tag)
  int dim = 3;                            // 3: a volume, 2: a surface
  int tag = 0;                            // gmsh's physical tag (generated shapes number from 1)
  std::vector<int> tets;                  // dim 3: indices into Mesh::tets, ascending
  std::vector<std::array<int, 3>> faces;  // dim 2: triangles as vertex indices

  /// "volume 'rock'", "surface 'top'", or "surface 7" when unnamed: for listings and messages.
  std::string label() const {
    return std::string(dim == 3 ? "volume " : "surface ") + (name.empty() ? std::to_string(tag) : "'" + name + "'");
  }
};

struct Mesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 4>> tets;  // vertex indices, any orientation
  std::string source;                    // file name or generator description, for messages
  std::vector<MeshGroup> groups;         // volumes first, then surfaces, each by tag
};

/// The group of dimension `dim` a scene key names, by name or (unnamed) by tag. Throws InputError
/// starting with `key`: for a group of the other dimension ("'top' is a surface, and
/// <because>; name a volume group") or none (the mesh's groups of that dimension listed).
const MeshGroup& named_group(const Mesh& mesh, const std::string& want, int dim, const std::string& key,
                             const std::string& because);

}  // namespace fdem
