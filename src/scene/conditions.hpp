#pragma once
// Reading the scene's boundary_conditions (scene/conditions.cpp).
#include "scene/reader.hpp"
#include "scene/scene.hpp"

namespace fdem::scene_reading {

/// The list under `boundary_conditions` into out, each problem reported to r.
void read_boundary_conditions(YamlReader& r, const YAML::Node& n, std::vector<BoundaryCondition>& out);

}  // namespace fdem::scene_reading
