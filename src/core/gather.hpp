#pragma once
// An element gather on the host: the values of an element's nodes from a node array (outputs
// and diagnostics).
#include <array>
#include <cstddef>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

template <std::size_t K>
void gather(const std::vector<Vec3>& a, const std::array<int, K>& ids, Vec3 (&out)[K]) {
  for (std::size_t i = 0; i < K; ++i) out[i] = a[ids[i]];
}

}  // namespace fdem
