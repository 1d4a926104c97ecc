#pragma once
// The CE6 state of a model as the time loop reads it: each CE6's damage in one array and its
// friction anchors in another, indexed by CE6 id. A CE6 pass reads every CE6's damage but the
// anchors only where a CE6 is damaged, so most CE6s cost the loop 32 bytes, not 104. On one rank
// the cpu backend's loop works on these arrays in place (CE6 ids are colour order,
// model/build.cpp).
#include <cstddef>
#include <vector>

#include "physics/cohesive6.hpp"

namespace fdem {

struct Ce6States {
  std::vector<Ce6Damage> damage;
  std::vector<Ce6Anchors> anchors;

  std::size_t size() const { return damage.size(); }
  /// n CE6s, intact, their anchors zero.
  void assign_intact(std::size_t n) {
    damage.assign(n, Ce6Damage{});
    anchors.assign(n, Ce6Anchors{});
  }
  /// CE6 c's state as one value (outputs, tests).
  Ce6State operator[](std::size_t c) const { return ce6_state_of(damage[c], anchors[c]); }
  /// The states `more` after those held.
  void append(const std::vector<Ce6State>& more) {
    damage.reserve(damage.size() + more.size()), anchors.reserve(anchors.size() + more.size());
    for (const Ce6State& s : more) {
      damage.push_back(s);
      Ce6Anchors a;
      for (int j = 0; j < 3; ++j) a.a[j] = s.slip[j];
      anchors.push_back(a);
    }
  }
};

}  // namespace fdem
