#pragma once
// Which material each tet is made of (scene.materials on the mesh's volume groups), checked
// against the mesh at the model build.
#include <cstdint>
#include <string>
#include <vector>

#include "model/mesh.hpp"
#include "model/model.hpp"

namespace fdem {

/// Per tet of the mesh (its input order), the index of its material in scene.materials. Throws
/// InputError naming the scene's key and the fix: a group that does not exist (the volume groups
/// listed), a surface group, a tet that two materials claim, tets no material claims, and a
/// material with no tets.
std::vector<std::uint8_t> material_of_mesh_tets(const Mesh& mesh, const Scene& scene);

/// One line per material and interface law, with the tets and CE6s that have it: "  material
/// 'granite' (volume groups rock): 1200 tets, 2100 CE6s with its law" (`where`: after the counts). Empty for
/// the one-material shorthand, `material`, unless it is heterogeneous.
std::string describe_materials(const Scene& scene, const Model& m, const std::string& where);

}  // namespace fdem
