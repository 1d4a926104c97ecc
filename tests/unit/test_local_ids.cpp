// LocalIds (partition/local_ids.hpp): global -> local ids by bisection over ascending runs, as
// a gathering of contact ghosts finds them, against a map of every id.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "partition/local_ids.hpp"

namespace fdem {
namespace {

/// Every id of `global` and some it lacks, looked up, against a map of all of them.
void expect_same_as_a_map(const LocalIds& ids, const std::vector<long>& global, long largest) {
  std::map<long, int> local;
  for (std::size_t i = 0; i < global.size(); ++i) local[global[i]] = int(i);
  for (long g = -2; g <= largest + 2; ++g) {
    auto it = local.find(g);
    ASSERT_EQ(ids.find(g), it == local.end() ? -1 : it->second) << "global id " << g;
  }
}

/// A rank model's ids: `runs` ascending runs of distinct ids drawn from [0, 4 n), as the
/// partition numbers a rank's own and ghost tets and each growth appends its ghosts.
std::vector<long> ids_in_runs(int runs, int n, std::mt19937& rng) {
  std::vector<long> all(4 * n);
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = long(i);
  std::shuffle(all.begin(), all.end(), rng);
  all.resize(n);
  std::vector<long> global;
  for (int r = 0; r < runs; ++r) {
    std::vector<long> run(all.begin() + std::size_t(r) * n / runs, all.begin() + std::size_t(r + 1) * n / runs);
    std::sort(run.begin(), run.end());
    global.insert(global.end(), run.begin(), run.end());
  }
  return global;
}

TEST(LocalIds, FindsEveryHeldIdAndNoOtherInAFewRunsAndInManyRuns) {
  std::mt19937 rng(7);
  for (int runs : {1, 3, 64, 65, 300}) {  // (past 64 runs, one merged list is searched)
    const int n = 3000;
    const std::vector<long> global = ids_in_runs(runs, n, rng);
    expect_same_as_a_map(LocalIds(global), global, 4L * n);
  }
}

TEST(LocalIds, TakesInTheIdsAppendedSince) {
  // Growths append ascending runs after the ids already taken in; a few, then past 64 runs.
  std::mt19937 rng(11);
  const int n = 4000;
  const std::vector<long> all = ids_in_runs(120, n, rng);
  std::vector<long> global(all.begin(), all.begin() + n / 2);
  LocalIds ids(global);
  expect_same_as_a_map(ids, global, 4L * n);
  for (int k = 1; global.size() < all.size(); ++k) {
    const std::size_t at = global.size(), more = std::min<std::size_t>(all.size() - at, 97);
    global.insert(global.end(), all.begin() + at, all.begin() + at + more);
    ids.extend();
    if (k % 5 == 0 || global.size() == all.size()) expect_same_as_a_map(ids, global, 4L * n);
  }
  EXPECT_THROW(ids.at(-1, "tet"), RunError);
  EXPECT_EQ(ids.at(global.back(), "tet"), int(global.size()) - 1);
}

}  // namespace
}  // namespace fdem
