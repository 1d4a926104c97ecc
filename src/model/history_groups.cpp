// The mesh groups that history entries follow: which nodes and tets of the model belong to each
// (Model::node_history, Model::tet_history), marked once at the build so that every rank knows
// its own part of a group.
#include <algorithm>
#include <set>

#include "core/error.hpp"
#include "model/model.hpp"

namespace fdem {

namespace {

using Face = std::array<int, 3>;

Face sorted_face(Face f) {
  std::sort(f.begin(), f.end());
  return f;
}

/// The group named by history entry i (a volume or a surface, by name or by the tag of an
/// unnamed one).
const MeshGroup& history_group(const Mesh& mesh, const Scene& scene, std::size_t i) {
  const std::string& want = scene.history[i].group;
  std::string list;
  for (const MeshGroup& g : mesh.groups) {
    if (g.name == want || (g.name.empty() && std::to_string(g.tag) == want)) return g;
    list += (list.empty() ? "" : ", ") + (g.name.empty() ? std::to_string(g.tag) : g.name);
  }
  throw InputError(scene.file + ": history[" + std::to_string(i) + "] ('" + scene.history[i].name +
                   "').group: the mesh (" + mesh.source + ") has no group '" + want +
                   "'; its groups: " + (list.empty() ? "none (name them with gmsh physical groups)" : list));
}

}  // namespace

void mark_history_groups(const Mesh& mesh, const Scene& scene, Model& m) {
  m.node_history.clear(), m.tet_history.clear();
  const bool any =
      std::any_of(scene.history.begin(), scene.history.end(), [](const HistoryPoint& h) { return !h.group.empty(); });
  if (!any) return;
  m.node_history.assign(m.X.size(), 0);
  m.tet_history.assign(m.tet_nodes.size(), 0);
  std::vector<int> model_tet(mesh.tets.size(), -1);  // the input's tet -> the model's
  for (std::size_t t = 0; t < m.tet_input.size(); ++t) model_tet[m.tet_input[t]] = int(t);
  for (std::size_t i = 0; i < scene.history.size(); ++i) {
    if (scene.history[i].group.empty()) continue;
    const std::uint32_t bit = std::uint32_t(1) << i;
    const MeshGroup& g = history_group(mesh, scene, i);
    if (g.dim == 3) {  // its tets and all their nodes
      for (int k : g.tets) {
        const int t = model_tet[k];
        m.tet_history[t] |= bit;
        for (int n : m.tet_nodes[t]) m.node_history[n] |= bit;
      }
      continue;
    }
    // A surface: each tet with a face on it, and that face's nodes (of that tet: a face inside
    // the rock marks both sides).
    std::set<Face> faces;
    for (const Face& f : g.faces) faces.insert(sorted_face(f));
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t)
      for (int skip = 0; skip < 4; ++skip) {
        Face f{}, nodes{};
        for (int k = 0, j = 0; k < 4; ++k)
          if (k != skip) nodes[j] = m.tet_nodes[t][k], f[j++] = m.node_vertex[m.tet_nodes[t][k]];
        if (!faces.count(sorted_face(f))) continue;
        m.tet_history[t] |= bit;
        for (int n : nodes) m.node_history[n] |= bit;
      }
  }
}

}  // namespace fdem
