#pragma once
// tests/gpu/cuda_flags.cu: raise_flag on the GPU, many iterations a flag.
#include <cstdint>
#include <vector>

#include "core/config.hpp"

namespace fdem::test {

/// The flags the iterations raise: those whose index is not a multiple of 3 (so that every
/// raised byte has a neighbour in its word that must stay as it was).
FDEM_HD bool raised_by_rule(int j) {
  return j % 3 != 0;
}

/// Iteration i (of `iterations`) raises flag (7 i) mod n where raised_by_rule allows, on the GPU;
/// returns how many raise_flag calls found their flag at 0. `flags` in and out.
long raise_flags_on_cuda(std::vector<std::uint8_t>& flags, int iterations);
/// The same with flags held in longs (no count).
void raise_long_flags_on_cuda(std::vector<long>& flags, int iterations);

}  // namespace fdem::test
