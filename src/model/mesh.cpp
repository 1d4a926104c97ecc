#include "model/mesh.hpp"

#include "core/error.hpp"

namespace fdem {

const MeshGroup& named_group(const Mesh& mesh, const std::string& want, int dim, const std::string& key,
                             const std::string& because) {
  const char* kind = dim == 3 ? "volume" : "surface";
  std::string list;
  for (const MeshGroup& g : mesh.groups) {
    if (g.name == want || (g.name.empty() && std::to_string(g.tag) == want)) {
      if (g.dim != dim)
        throw InputError(key + ": '" + want + "' is a " + (dim == 3 ? "surface" : "volume") + ", and " + because +
                         "; name a " + kind + " group");
      return g;
    }
    if (g.dim == dim) list += (list.empty() ? "" : ", ") + (g.name.empty() ? std::to_string(g.tag) : g.name);
  }
  throw InputError(key + ": the mesh (" + mesh.source + ") has no group '" + want + "'; its " + kind + " groups: " +
                   (list.empty() ? std::string("none (name ") + kind + "s with gmsh physical groups)" : list));
}

}  // namespace fdem
