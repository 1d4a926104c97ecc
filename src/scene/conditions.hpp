#pragma once
// Reading the scene's boundary_conditions and history points (scene/conditions.cpp) and its
// in-situ stress (scene/initial_stress.cpp).
#include "scene/reader.hpp"
#include "scene/scene.hpp"

namespace fdem::scene_reading {

/// The list under `boundary_conditions` into out, each problem reported to r.
void read_boundary_conditions(YamlReader& r, const YAML::Node& n, std::vector<BoundaryCondition>& out);

/// The list under `history` into out: each entry's name (letters, digits, '_', '-': it names
/// columns) and its point (at, m) or mesh group (group).
void read_history(YamlReader& r, const YAML::Node& n, std::vector<HistoryPoint>& out);

/// The list under `excavate` into out: each stage's volume group, start and relaxation time, in
/// time order, each relaxed before the next starts.
void read_excavation(YamlReader& r, const YAML::Node& n, std::vector<ExcavationStage>& out);

/// `initial_stress` into s.initial_stress, checked against gravity and the materials' weight
/// (read after them and solver.mass_scaling).
void read_initial_stress(YamlReader& r, const YAML::Node& n, Scene& s);

}  // namespace fdem::scene_reading
