// The scene's excavate: stages, each a volume group removed at a time, its forces on the rock
// relaxed to zero over a period. Which groups exist is known only with the mesh:
// model/excavation.cpp checks the names.
#include "core/format.hpp"
#include "scene/conditions.hpp"

namespace fdem::scene_reading {

void read_excavation(YamlReader& r, const YAML::Node& n, std::vector<ExcavationStage>& out) {
  const std::string form = "write e.g. excavate: [{group: tunnel, start: 1e-3, relax: 2e-3}] (times in s)";
  if (!n.IsSequence() || n.size() == 0) {
    r.error("excavate", "expected a list of stages, got " + describe(n), form);
    return;
  }
  if (n.size() > ExcavationStage::kMax) {
    r.error("excavate", std::to_string(n.size()) + " stages", "give at most " + std::to_string(ExcavationStage::kMax));
    return;
  }
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string p = "excavate[" + std::to_string(i) + "]";
    if (!r.check_map(n[i], p, {"group", "start", "relax"})) continue;
    ExcavationStage e;
    if (!n[i]["group"]) r.error(p + ".group", "missing", "name the volume group this stage removes");
    r.text(n[i], p, "group", e.group, "name a volume group of the mesh");
    r.number(n[i], p, "start", at_least(0), e.start);
    r.number(n[i], p, "relax", at_least(0), e.relax);
    if (!out.empty()) {
      const ExcavationStage& b = out.back();
      if (e.start < b.start + b.relax)
        r.error(
            p + ".start",
            fmt(e.start) + " s, before the stage before it has relaxed (" + fmt(b.start) + " + " + fmt(b.relax) + " s)",
            "start each stage at or after the end of the last one's relaxation");
    }
    for (const ExcavationStage& o : out)
      if (o.group == e.group) r.error(p + ".group", "'" + e.group + "' is removed twice", "name each group once");
    out.push_back(e);
  }
}

}  // namespace fdem::scene_reading
