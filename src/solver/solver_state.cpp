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
  out.put(ce6.states());
  out.put(ce6_broke);
}

void SolverState::load(CheckpointIn& in, const GhostState* appended) {
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
  if (appended) {
    x.insert(x.end(), appended->x.begin(), appended->x.end());
    v.insert(v.end(), appended->v.begin(), appended->v.end());
    f.resize(nn, Vec3{0, 0, 0});
    ce6.append(appended->ce6);
    ce6_broke.resize(nc, 0);
  }
  if (x.size() != nn || v.size() != nn || f.size() != nn || ce6.size() != nc || ce6_broke.size() != nc)
    in.mismatch("node or CE6 counts differ");
}

}  // namespace fdem
