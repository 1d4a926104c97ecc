#pragma once
// Reading the scene's boundary_conditions and history points (scene/conditions.cpp).
#include "scene/reader.hpp"
#include "scene/scene.hpp"

namespace fdem::scene_reading {

/// The list under `boundary_conditions` into out, each problem reported to r.
void read_boundary_conditions(YamlReader& r, const YAML::Node& n, std::vector<BoundaryCondition>& out);

/// The list under `history` into out: each entry's name (letters, digits, '_', '-': it names
/// columns) and its point (at, m) or mesh group (group).
void read_history(YamlReader& r, const YAML::Node& n, std::vector<HistoryPoint>& out);

}  // namespace fdem::scene_reading
