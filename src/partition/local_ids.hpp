#pragma once
// Global id -> local id on a rank, for a gathering of contact ghosts (partition/grow.hpp), which
// must cost what it adds, not the rank model.
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace fdem {

/// Global id -> local id of a rank model's nodes, tets or CE6s, without a map of the whole
/// model. A rank model numbers them in global order, and each growth appends its ghosts in
/// global order too: the ids are a few ascending runs, each searched by bisection. (Past
/// kMostRuns runs, one list of every id in global order, merged from the runs, is searched.)
class LocalIds {
 public:
  explicit LocalIds(const std::vector<long>& global) : global_(&global) { extend(); }
  /// Takes in the ids appended to `global` since.
  void extend() {
    const std::vector<long>& g = *global_;
    for (int i = int(scanned_); i < int(g.size()); ++i)
      if (i > 0 && !runs_.empty() && g[i] > g[i - 1])
        runs_.back().end = i + 1;
      else
        runs_.push_back({i, i + 1});
    scanned_ = g.size();
    if (runs_.size() > kMostRuns) merge_new_ids();
  }
  /// The local id of global id id, or -1 where the rank does not hold it.
  int find(long id) const {
    const std::vector<long>& g = *global_;
    if (runs_.size() > kMostRuns) {
      auto it = std::lower_bound(by_global_.begin(), by_global_.end(), id, [&](int a, long v) { return g[a] < v; });
      return it != by_global_.end() && g[*it] == id ? *it : -1;
    }
    for (const Run& r : runs_) {
      if (id < g[r.begin] || id > g[r.end - 1]) continue;
      auto it = std::lower_bound(g.begin() + r.begin, g.begin() + r.end, id);
      if (it != g.begin() + r.end && *it == id) return int(it - g.begin());
    }
    return -1;
  }
  /// The local id of a global id the rank must hold; RunError naming `what` where it does not.
  int at(long id, const char* what) const {
    const int i = find(id);
    if (i < 0) throw RunError(std::string("contact ghosts: ") + what + " " + std::to_string(id) + " is not held here");
    return i;
  }

 private:
  static constexpr std::size_t kMostRuns = 64;
  struct Run {
    int begin, end;
  };
  /// Takes the ids not yet in by_global_ into it, in global order: each run is in order, so
  /// neighbouring runs are merged in pairs until one is left, then merged with the list.
  void merge_new_ids() {
    const std::vector<long>& g = *global_;
    auto less = [&](int a, int b) { return g[a] < g[b]; };
    const std::size_t sorted = by_global_.size();
    std::vector<std::size_t> edges{sorted};  // where the runs not yet merged end
    for (const Run& r : runs_)
      if (std::size_t(r.end) > sorted) edges.push_back(std::size_t(r.end));
    for (std::size_t i = sorted; i < g.size(); ++i) by_global_.push_back(int(i));
    const auto b = by_global_.begin();
    while (edges.size() > 2) {
      std::vector<std::size_t> left;
      std::size_t i = 0;
      for (; i + 2 < edges.size(); i += 2) {
        std::inplace_merge(b + edges[i], b + edges[i + 1], b + edges[i + 2], less);
        left.push_back(edges[i]);
      }
      left.insert(left.end(), edges.begin() + i, edges.end());
      edges.swap(left);
    }
    std::inplace_merge(b, b + sorted, by_global_.end(), less);
  }
  const std::vector<long>* global_;
  std::vector<Run> runs_;
  std::vector<int> by_global_;  // where the runs are many
  std::size_t scanned_ = 0;
};

}  // namespace fdem
