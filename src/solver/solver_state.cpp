#include "solver/solver_state.hpp"

#include "io/checkpoint.hpp"
#include "partition/grow.hpp"

namespace fdem {

void SolverState::start(const std::vector<Vec3>& X, std::size_t nc) {
  step = 0;
  time = 0;
  x = X;
  v.assign(X.size(), {0, 0, 0});
  f.assign(X.size(), {0, 0, 0});
  ce6.assign_intact(nc);
  ce6_broke.assign(nc, 0);
}

void SolverState::save(CheckpointOut& out) const {
  out.put(step);
  out.put(time);
  out.put(x);
  out.put(v);
  out.put(f);
  // Each CE6's state as one value (Ce6State), one at a time: no copy of all of them beside the payload.
  out.put(std::uint64_t(ce6.size()));
  for (std::size_t c = 0; c < ce6.size(); ++c) out.put(ce6[c]);
  out.put(ce6_broke);
}

void SolverState::load(CheckpointIn& in) {
  const std::size_t nn = x.size(), nc = ce6.size();
  in.get(step);
  in.get(time);
  in.get(x);
  in.get(v);
  in.get(f);
  std::vector<Ce6State> ce6_saved;
  in.get(ce6_saved);
  ce6 = Ce6States{};
  ce6.append(ce6_saved);
  in.get(ce6_broke);
  if (x.size() != nn || v.size() != nn || f.size() != nn || ce6.size() != nc || ce6_broke.size() != nc)
    in.mismatch("node or CE6 counts differ");
}

void SolverState::append(const GhostState& added) {
  x.insert(x.end(), added.x.begin(), added.x.end());
  v.insert(v.end(), added.v.begin(), added.v.end());
  f.resize(x.size(), Vec3{0, 0, 0});
  ce6.append(added.ce6);
  ce6_broke.resize(ce6.size(), 0);
}

}  // namespace fdem
