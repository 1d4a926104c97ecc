#pragma once
// The discretised model the time loop runs on: plain arrays indexed by integers,
// built once on the host (model/build.cpp) and copied as they are to a backend.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.hpp"
#include "model/mesh.hpp"
#include "physics/cohesive6.hpp"
#include "scene/scene.hpp"

namespace fdem {

/// A set of element indices split into colours: no two elements of one colour share a
/// node, so a colour's elements can add into node forces in parallel without atomics
/// and the sum does not depend on the thread count.
struct Colouring {
  std::vector<int> order;    // element indices, colour by colour
  std::vector<int> offsets;  // colour c is order[offsets[c] .. offsets[c+1])
  int colours() const { return offsets.empty() ? 0 : int(offsets.size()) - 1; }
};

struct Model {
  // Nodes. Inside fracture regions every tet owns its four nodes (discontinuous).
  std::vector<Vec3> X;           // reference positions, m
  std::vector<real> mass;        // lumped mass (includes mass scaling), kg
  std::vector<int> node_vertex;  // mesh vertex each node came from

  // TET4
  std::vector<std::array<int, 4>> tet_nodes;  // positively oriented (V0 > 0), in Morton order
  std::vector<int> tet_input;                 // index of each tet in the input mesh
  std::vector<Mat3> tet_Xinv;                 // inverse reference edge matrix
  std::vector<real> tet_V0;                   // reference volume, m^3
  std::vector<real> tet_eta;                  // viscous damping coefficient, Pa s
  std::vector<std::uint8_t> tet_material;     // index into scene.materials (ElementLaws::tet4)
  std::vector<real> tet_stiffness;            // factor on its E (heterogeneous rock); empty: all 1
  std::vector<int> tet_group;                 // gmsh tag of its volume group (first listed); empty: none
  std::vector<std::uint8_t> tet_joint;        // 0, or 1 + the joint a face lies on (contact friction); empty: no joints
  std::vector<std::uint8_t> tet_stage;        // 0, or 1 + the excavation stage that removes it; empty: none
  Colouring tet_colours;

  /// What tet t takes from its material, its draw and the joints: the partition's records carry it.
  struct TetProperties {
    std::uint8_t material = 0;
    real stiffness = 1;
    std::uint8_t joint = 0;
    std::uint32_t history = 0;  // Model::tet_history
    int group = 0;              // Model::tet_group
    std::uint8_t stage = 0;     // Model::tet_stage
  };
  TetProperties tet_properties(std::size_t t) const {
    return {tet_material[t],
            tet_stiffness.empty() ? real(1) : tet_stiffness[t],
            tet_joint.empty() ? std::uint8_t(0) : tet_joint[t],
            tet_history.empty() ? 0u : tet_history[t],
            tet_group.empty() ? 0 : tet_group[t],
            tet_stage.empty() ? std::uint8_t(0) : tet_stage[t]};
  }
  std::uint32_t node_history_of(std::size_t n) const { return node_history.empty() ? 0 : node_history[n]; }

  // CE6: nodes 0-2 on tet A's face, 3-5 the paired nodes of tet B (same vertices, same
  // order); the face normal (0->1->2, right hand) points from A into B. On the border of a
  // fracture region a pair can be one node (both tets joined to the continuous part there):
  // that pair cannot open, which pins the crack's edge to the region.
  std::vector<std::array<int, 6>> ce6_nodes;
  std::vector<std::array<int, 2>> ce6_tets;
  std::vector<real> ce6_h;            // characteristic size (reference mean edge length), m
  std::vector<std::uint8_t> ce6_law;  // index into ElementLaws::ce6 (model/laws.hpp)
  std::vector<real> ce6_strength;     // factor on its strengths (heterogeneous rock); empty: all 1
  Colouring ce6_colours;

  // The in-situ stress (scene initial_stress), set on each rank from the scene by
  // place_initial_stress (model/initial_stress.hpp), not carried in rank files. Empty: none.
  std::vector<Sym3> tet_initial_stress;     // per tet, Pa, at its reference centroid
  std::vector<Ce6Prestress> ce6_prestress;  // per CE6, the opening offsets that carry it
  const Sym3* initial_stress_of(std::size_t t) const {
    return tet_initial_stress.empty() ? nullptr : &tet_initial_stress[t];
  }

  // Boundary: faces on the outer surface (node ids, normal outward) and node groups.
  std::vector<std::array<int, 3>> surface_faces;
  std::vector<int> surface_tet;
  std::vector<int> platen_nodes;       // surface nodes that can touch a platen
  std::vector<real> platen_node_area;  // tributary reference area of each, m^2
  std::vector<real> platen_node_h;     // size of the element under each, m
  std::vector<int> top_nodes, bottom_nodes, lateral_nodes;
  // Per surface face, bit c: the scene's boundary condition c acts on it (empty: none given).
  std::vector<std::uint32_t> surface_conditions;
  std::uint32_t conditions_of(std::size_t face) const {
    return surface_conditions.empty() ? 0 : surface_conditions[face];
  }
  // Per node, bit c: kinematic condition c holds it. Every node at a vertex of the condition's
  // faces is held, so that nodes split by CE6s there move together (empty: none held).
  std::vector<std::uint32_t> node_conditions;
  std::uint32_t node_conditions_of(std::size_t node) const {
    return node_conditions.empty() ? 0 : node_conditions[node];
  }
  // Per node and per tet, bit i: it belongs to the group that history entry i follows (empty: no
  // entry follows a group).
  std::vector<std::uint32_t> node_history, tet_history;
  // Per scene condition: a roller's axis (0, 1, 2: its faces' normal), else -1.
  std::vector<std::int8_t> condition_axis;

  // Geometry of the specimen in the reference configuration.
  Vec3 box_min{0, 0, 0}, box_max{0, 0, 0};
  Vec3 axis_point{0, 0, 0};  // the loading axis passes through here along z
  real height0 = 0;          // m, along z
  real area0 = 0;            // m^2, loaded cross-section (mean of top and bottom surface areas)
  bool line_loaded = false;  // no flat ends (a disc): area0 is the diametral plane, height x y-extent

  // Statistics for the build report.
  real min_altitude = 0;      // m
  int min_altitude_tet = -1;  // the input's index of the tet with it (a sliver sets the time step)
  real mean_edge = 0;         // m
  std::string source;
};

/// Build the model from a mesh: node splitting, CE6 insertion inside the fracture regions,
/// surfaces, node groups, masses (with mass scaling), damping and colourings.
/// Throws InputError for inverted or degenerate tets and non-manifold faces.
Model build_model(const Mesh& mesh, const Scene& scene);

/// Marks the nodes and tets of the groups that history entries follow (model/history_groups.cpp).
/// Throws InputError for a group the mesh does not have, naming the entry and listing its groups.
void mark_history_groups(const Mesh& mesh, const Scene& scene, Model& m);

/// Per tet of m, 0 or 1 + the excavation stage whose volume group holds it (Model::tet_stage;
/// empty without `excavate`). Throws InputError for a group that is no volume of the mesh, or
/// two stages that share a tet.
void mark_excavation_stages(const Mesh& mesh, const Scene& scene, Model& m);
/// fdem check's lines for the excavation stages: each one's group, tets (`suffix` after the
/// count, e.g. " (this rank)"), start and relaxation.
std::string describe_excavation(const Scene& scene, const Model& m, const std::string& suffix);

/// Mesh vertex -> the tets touching it (CSR): tets ptr[v] .. ptr[v+1]-1 of `tets`.
struct VertexTets {
  std::vector<int> ptr, tets;
  explicit VertexTets(const Model& m);
};

}  // namespace fdem
