#pragma once
// Reading the scene's rock: `material` (one), or `materials` on volume groups with the
// `interfaces` between them, and the `joints` (scene/materials.cpp).
#include "scene/reader.hpp"
#include "scene/scene.hpp"

namespace fdem::scene_reading {

/// Every key of a material (its name and groups aside).
std::vector<std::string> material_keys();

/// The keys of one material under path p into m (its name and groups aside).
void read_material_keys(YamlReader& r, const YAML::Node& n, const std::string& p, Material& m);

/// The list under `materials` into s.materials, each problem reported to r.
void read_materials(YamlReader& r, const YAML::Node& n, Scene& s);

/// The list under `interfaces` into s.interfaces (after the materials it names).
void read_interfaces(YamlReader& r, const YAML::Node& n, Scene& s);

/// The list under `joints` into s.joints (after the materials, whose first gives the keys not given).
void read_joints(YamlReader& r, const YAML::Node& n, Scene& s);

/// Cross-checks of the materials and interfaces read: the contact values every material must
/// share, and, on a generated mesh, each CE6 law's fracture energies against its element size.
void check_materials(YamlReader& r, const Scene& s);

}  // namespace fdem::scene_reading
