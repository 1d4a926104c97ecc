#pragma once
// Which surface faces carry which boundary conditions (scene.conditions), checked against the
// mesh's groups at the model build.
#include "model/model.hpp"

namespace fdem {

/// m.surface_conditions from the scene's conditions and the mesh's surface groups. Throws
/// InputError naming the scene's key and the fix: a group that does not exist (the existing ones
/// listed), a volume group, a face not on the outer surface, a roller not normal to x, y or z, and
/// two conditions prescribing different velocities to one component of a node.
void mark_condition_faces(const Mesh& mesh, const Scene& scene, Model& m);

/// The axis (0, 1, 2) the reference normal of surface face q of m lies along (the largest
/// component), and whether it lies along it to within 1e-6 of its length.
struct FaceAxis {
  int axis = 0;
  bool aligned = false;
};
FaceAxis face_axis(const Model& m, const std::array<int, 3>& q);

/// One line per scene condition: "  boundary condition bc0 roller on surface 'xmin': 32 faces"
/// (`where`: said after the count, e.g. " (this rank)").
std::string describe_conditions(const Scene& scene, const Model& m, const std::string& where);

/// The velocity components (bit d: component d) condition c prescribes on its nodes, with `axis`
/// a roller's (Model::condition_axis); none for a face load.
int prescribed_components(const BoundaryCondition& c, int axis);

}  // namespace fdem
