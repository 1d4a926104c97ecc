// Which tets each excavation stage removes (Model::tet_stage), marked once at the build so that
// every rank knows its own.
#include "core/error.hpp"
#include "core/format.hpp"
#include "model/model.hpp"

namespace fdem {

void mark_excavation_stages(const Mesh& mesh, const Scene& scene, Model& m) {
  m.tet_stage.clear();
  if (scene.excavation.empty()) return;
  std::vector<int> model_tet(mesh.tets.size(), -1);  // the input's tet -> the model's
  for (std::size_t t = 0; t < m.tet_input.size(); ++t) model_tet[m.tet_input[t]] = int(t);
  m.tet_stage.assign(m.tet_nodes.size(), 0);
  for (std::size_t k = 0; k < scene.excavation.size(); ++k) {
    const std::string key = scene.file + ": excavate[" + std::to_string(k) + "].group";
    const MeshGroup& g = named_group(mesh, scene.excavation[k].group, 3, key, "an excavation removes rock");
    for (int input : g.tets) {
      std::uint8_t& stage = m.tet_stage[model_tet[input]];
      if (stage != 0)
        throw InputError(key + ": tet " + std::to_string(input + 1) + " of '" + scene.excavation[k].group +
                         "' is also in '" + scene.excavation[stage - 1].group +
                         "', which an earlier stage removes. Fix: give the stages volume groups that do not overlap");
      stage = std::uint8_t(k + 1);
    }
  }
}

std::string describe_excavation(const Scene& scene, const Model& m, const std::string& suffix) {
  std::string out;
  for (std::size_t k = 0; k < scene.excavation.size(); ++k) {
    long tets = 0;
    for (std::uint8_t s : m.tet_stage) tets += s == k + 1;
    const ExcavationStage& e = scene.excavation[k];
    out += "  excavation stage " + std::to_string(k) + ": volume '" + e.group + "' (" + std::to_string(tets) + " tets" +
           suffix + ") removed at " + fmt(e.start) + " s, its forces relaxed " +
           (e.relax > 0 ? "over " + fmt(e.relax) + " s" : std::string("at once")) + "\n";
  }
  return out;
}

}  // namespace fdem
