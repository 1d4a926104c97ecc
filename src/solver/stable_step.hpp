#pragma once
// The stable time step of central differences on an assembled model: an upper bound of its
// highest frequency, node by node, with what limits it named.
#include <string>
#include <vector>

#include "core/vec.hpp"
#include "model/laws.hpp"
#include "model/model.hpp"
#include "scene/scene.hpp"
#include "solver/rank_layout.hpp"

namespace fdem {

struct StableStep {
  real dt = 0;                                                 // s, including the safety factor
  real dt_tet = 0, dt_ce6 = 0, dt_platen = 0, dt_contact = 0;  // s, without it
  std::string limit;                                           // which part limits, e.g. "CE6 #12 (P_overlap)"
};

/// The bound of model m (without solver.time_step_safety): TET4 with damping, the CE6 penalty
/// springs, the platen springs (`platen_k`, N/m per platen node) and, with contact, its penalty.
/// Several ranks: the smallest over the ranks, named by the rank that has it (every rank calls
/// it together).
StableStep stable_step_bound(const Model& m, const Scene& scene, const ElementLaws& laws,
                             const std::vector<real>& platen_k, const RankLayout& layout);

}  // namespace fdem
