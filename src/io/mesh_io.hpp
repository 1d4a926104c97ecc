#pragma once
// Tetrahedral meshes in (and out): gmsh .msh files (ASCII v2.2 and v4.1, hand-parsed) or meshes generated
// with the gmsh API (OpenCASCADE kernel). Every function throws fdem::InputError with a message
// that names the file (and line), says what is wrong and how to fix it.
#include <string>

#include "model/mesh.hpp"
#include "scene/scene.hpp"

namespace fdem {

/// Read a gmsh .msh file, ASCII format version 2.2 (2.0 and 2.1 too) or 4.1. Only 4-node
/// tetrahedra (element type 4) are kept; other element types (points, lines, triangles, ...)
/// are ignored. Node tags may be arbitrary; vertices not used by any tetrahedron are dropped
/// and the rest renumbered 0..n-1 in the order they appear in the file. Coordinates are
/// multiplied by `scale` (e.g. 1e-3 for a mesh drawn in millimetres). The result has passed
/// validate_mesh; mesh.source is `path`.
/// Physical groups of dimension 3 and 2 become mesh.groups: named by $PhysicalNames, their tets
/// and their triangles (element type 2), each of which must be a face of a tet. In v4.1 an
/// element's groups are its entity's ($Entities); in v2.2 its physical tag (the first tag),
/// and a tet written once per group is one tet.
Mesh read_msh(const std::string& path, real scale = 1);

/// Generate a tetrahedral mesh with gmsh (OpenCASCADE kernel, Delaunay, optimised, single
/// thread, so the same spec always gives the same mesh) with target edge length
/// spec.element_size (gmsh MeshSizeMax = element_size, MeshSizeMin = element_size / 2),
/// optimising the tets of quality below spec.optimize_threshold and then smoothing
/// spec.smoothing times.
/// Shapes (the loading axis is z):
///   "cylinder": axis z, radius diameter/2, base centred at the origin, z in [0, height];
///   "disc":     axis y, centre (0, 0, diameter/2), y in [-height/2, height/2], so z in
///               [0, diameter]; the lateral surface has mesh edges along the two lines
///               x = 0, z = 0 and x = 0, z = diameter where the platens touch it;
///   "box":      [0, size.x] x [0, size.y] x [0, size.z].
/// gmsh prints nothing unless the environment variable FDEM_GMSH_VERBOSE is set. gmsh is
/// initialised and finalised inside the call (left initialised if it already was).
/// Not thread-safe with other gmsh users; concurrent calls to generate_mesh are serialised.
Mesh generate_mesh(const MeshSpec& spec);

/// Write a mesh as a gmsh .msh file, ASCII version 2.2: the vertices as nodes 1..n (coordinates
/// in m, each in the shortest form that reads back to the same double) and the tets as elements
/// 1..m of type 4 in mesh order, so read_msh(path) gives the same mesh bit for bit where every
/// vertex is a tet's, as in every mesh load_mesh gives (read_msh drops the others). The groups
/// go with it: $PhysicalNames, each tet's first volume group as its physical tag (a copy for each
/// further one, as gmsh writes v2.2), and the surfaces' triangles. For running a generated mesh
/// where gmsh is missing (mesh.file). Written whole or not at all (write_file_atomically); throws
/// OutputError naming the file.
void write_msh(const Mesh& mesh, const std::string& path);

/// One line per group of the mesh, for fdem check: its label, dimension, tag, its tets and
/// volume or its triangles and area (m^3, m^2). "" for a mesh without groups.
std::string describe_groups(const Mesh& mesh);

/// Mesh the gmsh geometry script spec.file (built-in or OpenCASCADE kernel, as the file says)
/// in 3D, first order, with spec.element_size as the largest element where it is > 0 (the
/// smallest half of it). The physical groups of dimension 3 and 2 become mesh.groups.
/// Coordinates are multiplied by spec.scale. A file gmsh cannot mesh is an InputError with
/// gmsh's message. Needs gmsh (InputError without it, naming the fix).
Mesh mesh_geo_file(const MeshSpec& spec);

/// spec.file non-empty: mesh_geo_file for a .geo file, else read_msh(spec.file, spec.scale);
/// otherwise generate_mesh(spec).
Mesh load_mesh(const MeshSpec& spec);

/// Check a mesh; throws InputError naming mesh.source and the offending tet (1-based index
/// into mesh.tets) or vertices (1-based) on: no tets, vertex index out of range or repeated
/// in a tet, non-finite coordinate, |volume| <= 1e-12 (mean edge length of that tet)^3,
/// a face shared by more than two tets (non-manifold), two tets sharing a face and lying on
/// the same side of it (overlapping or duplicated tets). Tets with negative signed volume
/// (the other vertex order) are accepted.
void validate_mesh(const Mesh& mesh);

}  // namespace fdem
