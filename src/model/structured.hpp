#pragma once
// A structured tet mesh of a box, for tests and benchmarks that must not depend on gmsh.
#include "model/mesh.hpp"

namespace fdem {

/// Box [0,size] split into nx*ny*nz cells, each cut into 6 tets sharing the cell's main
/// diagonal (Kuhn split), so neighbouring cells match face to face.
Mesh structured_box_mesh(Vec3 size, int nx, int ny, int nz);

}  // namespace fdem
