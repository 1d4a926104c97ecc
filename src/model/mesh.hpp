#pragma once
// A tetrahedral mesh as read or generated: shared vertices, 4-node tets. SI units (m).
#include <array>
#include <string>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

struct Mesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<int, 4>> tets;  // vertex indices, any orientation
  std::string source;                    // file name or generator description, for messages
};

}  // namespace fdem
