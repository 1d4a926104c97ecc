#pragma once
// Joint sets on the mesh: the internal faces each joint's surface groups hold (model/joints.cpp),
// checked against the mesh at the model build.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "model/mesh.hpp"
#include "model/model.hpp"

namespace fdem {

/// A face a joint names: the joint (index into scene.joints), and whether the build found it
/// between two tets.
struct JointFace {
  int joint = 0;
  bool internal = false;
};
/// By the face's vertices, sorted.
using JointFaces = std::map<std::array<int, 3>, JointFace>;

/// The faces of every joint's surface groups. Throws InputError naming the key and the fix: a
/// group that does not exist (the surface groups listed), a volume group, a group without faces,
/// a face two joints claim.
JointFaces joint_faces(const Mesh& mesh, const Scene& scene);

/// Throws InputError where a joint's face is not between two tets (on the outer surface, or a
/// surface the mesh does not conform to), naming the joint, the face and the fix.
void check_joint_faces_internal(const Mesh& mesh, const Scene& scene, const JointFaces& faces);

/// Per tet of m, 0, or 1 + the joint one of its faces lies on (of two, the one of lower friction):
/// tet-tet contact between two tets of one joint takes its friction. Empty without joints.
std::vector<std::uint8_t> tets_on_joints(const Scene& scene, const Model& m);

/// One line per joint, with its CE6s: "  joint 'bedding' (surfaces bedding): 32 CE6s, frictional,
/// friction 0.6" (`where`: after the counts). Empty without joints.
std::string describe_joints(const Scene& scene, const Model& m, const std::string& where);

}  // namespace fdem
