// Contact broad phase (find_box_pairs): exact pair sets against a brute-force all-pairs
// search on random tet clouds, far-apart fragments, boxes spanning many cells (with the
// cell enlargement), active subsets, touching versus separated boxes, and the empty cases.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <random>
#include <vector>

#include "contact/broad_phase.hpp"

using namespace fdem;

namespace {

using Pairs = std::vector<std::array<int, 2>>;

/// AABB of a tet: 4 random points within `size` of a random centre in [0, side)^3 + shift,
/// inflated by `buffer` on every side.
Aabb random_tet_box(std::mt19937& rng, real side, real size, real buffer, Vec3 shift = {0, 0, 0}) {
  std::uniform_real_distribution<real> centre(0, side), offset(-size, size);
  const Vec3 c = Vec3{centre(rng), centre(rng), centre(rng)} + shift;
  Aabb b{c, c};
  for (int p = 0; p < 4; ++p) {
    const Vec3 x = c + Vec3{offset(rng), offset(rng), offset(rng)};
    for (int d = 0; d < 3; ++d) {
      b.lo[d] = std::min(b.lo[d], x[d]);
      b.hi[d] = std::max(b.hi[d], x[d]);
    }
  }
  b.lo -= Vec3{buffer, buffer, buffer};
  b.hi += Vec3{buffer, buffer, buffer};
  return b;
}

std::vector<Aabb> random_cloud(unsigned seed, int n, real side, real size, real buffer) {
  std::mt19937 rng(seed);
  std::vector<Aabb> boxes;
  for (int i = 0; i < n; ++i) boxes.push_back(random_tet_box(rng, side, size, buffer));
  return boxes;
}

std::vector<int> all_ids(const std::vector<Aabb>& boxes) {
  std::vector<int> ids(boxes.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = static_cast<int>(i);
  return ids;
}

/// The reference: every pair of ids tested directly, closed boxes.
Pairs brute_force(const std::vector<Aabb>& boxes, const std::vector<int>& ids) {
  Pairs out;
  for (std::size_t i = 0; i < ids.size(); ++i)
    for (std::size_t j = i + 1; j < ids.size(); ++j) {
      const Aabb &a = boxes[ids[i]], &b = boxes[ids[j]];
      bool hit = true;
      for (int d = 0; d < 3; ++d) hit = hit && a.lo[d] <= b.hi[d] && b.lo[d] <= a.hi[d];
      if (hit) out.push_back({std::min(ids[i], ids[j]), std::max(ids[i], ids[j])});
    }
  std::sort(out.begin(), out.end());
  return out;
}

/// Runs the broad phase, checks it against brute force and the stats for consistency.
BroadPhaseStats check_against_brute_force(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real cell,
                                          long max_cells_per_box = 64) {
  Pairs pairs{{-1, -1}};  // stale content must be cleared
  BroadPhaseStats stats;
  find_box_pairs(boxes, ids, cell, pairs, &stats, max_cells_per_box);
  const Pairs expected = brute_force(boxes, ids);
  EXPECT_EQ(pairs.size(), expected.size()) << "cell " << cell << ", " << ids.size() << " boxes";
  EXPECT_TRUE(pairs == expected) << "pair sets differ, cell " << cell << ", " << ids.size() << " boxes";
  EXPECT_EQ(stats.boxes, static_cast<long>(ids.size()));
  EXPECT_GE(stats.entries, stats.boxes);
  EXPECT_EQ(stats.pairs, static_cast<long>(pairs.size()));
  EXPECT_GE(stats.tested, stats.pairs);
  if (!ids.empty()) {
    EXPECT_GT(stats.cell, 0);
    if (cell > 0) {
      EXPECT_GE(stats.cell, cell);
    }
  }
  return stats;
}

}  // namespace

TEST(BroadPhase, RandomTetCloudsMatchBruteForce) {
  for (int n : {50, 500, 3000}) {
    for (unsigned seed : {1u, 2u}) {
      // Tets of size ~0.2 m at a density that gives a few neighbours each.
      const real side = 0.2 * std::cbrt(static_cast<real>(n));
      const auto boxes = random_cloud(seed * 1000 + n, n, side, 0.1, 0.01);
      const auto ids = all_ids(boxes);
      EXPECT_GT(brute_force(boxes, ids).size(), static_cast<std::size_t>(n) / 2) << "cloud of " << n << " too sparse";
      for (real cell : {0.0, 0.05, 0.2, 1.0}) check_against_brute_force(boxes, ids, cell);
      // A cell so large that everything shares one cell.
      const auto one = check_against_brute_force(boxes, ids, 10 * side);
      EXPECT_LE(one.entries, 8 * one.boxes);
    }
  }
}

TEST(BroadPhase, GroupsKeepOnlyThePairsAcrossGroups) {
  // Boxes in three groups (ranks of a partition): exactly the brute-force pairs whose boxes lie
  // in two groups, and fewer pairs tested than without groups.
  const auto boxes = random_cloud(11, 3000, 0.2 * std::cbrt(3000.0), 0.1, 0.01);
  const auto ids = all_ids(boxes);
  std::vector<int> groups(boxes.size());
  for (std::size_t i = 0; i < groups.size(); ++i) groups[i] = boxes[i].lo.x < 1.0 ? 0 : (i % 5 == 0 ? 1 : 2);
  Pairs expected;
  for (const auto& p : brute_force(boxes, ids))
    if (groups[p[0]] != groups[p[1]]) expected.push_back(p);
  for (real cell : {0.0, 0.05, 1.0}) {
    Pairs pairs, all;
    BroadPhaseStats with, without;
    find_box_pairs(boxes, ids, cell, pairs, &with, 64, &groups);
    find_box_pairs(boxes, ids, cell, all, &without);
    EXPECT_GT(expected.size(), 100u);
    EXPECT_LT(expected.size(), all.size() / 2) << "most pairs lie within a group";
    EXPECT_TRUE(pairs == expected) << "cell " << cell;
    EXPECT_LT(with.tested, without.tested) << "cell " << cell;
  }
}

TEST(BroadPhase, ResultDoesNotDependOnTheThreadCount) {
  const auto boxes = random_cloud(7, 2000, 3.0, 0.1, 0.01);
  const auto ids = all_ids(boxes);
  Pairs serial, parallel;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  find_box_pairs(boxes, ids, 0.05, serial);
  omp_set_num_threads(std::max(threads, 4));
  find_box_pairs(boxes, ids, 0.05, parallel);
  omp_set_num_threads(threads);
  EXPECT_FALSE(serial.empty());
  EXPECT_TRUE(serial == parallel);
}

TEST(BroadPhase, FarApartFragmentsAndBoxesSpanningManyCells) {
  std::mt19937 rng(42);
  std::vector<Aabb> boxes;
  for (int i = 0; i < 300; ++i) boxes.push_back(random_tet_box(rng, 1.0, 0.05, 0.005));
  for (int i = 0; i < 300; ++i) boxes.push_back(random_tet_box(rng, 1.0, 0.05, 0.005, {1e3, 0, 0}));
  // Every 30th box 20 times larger: it spans many cells.
  for (std::size_t i = 0; i < boxes.size(); i += 30) {
    const Vec3 c = 0.5 * (boxes[i].lo + boxes[i].hi), h = 10.0 * (boxes[i].hi - boxes[i].lo);
    boxes[i] = {c - h, c + h};
  }
  // A lone fragment 1e6 m away, made of two touching boxes.
  boxes.push_back({{1e6, 1e6, -1e6}, {1e6 + 0.1, 1e6 + 0.1, -1e6 + 0.1}});
  boxes.push_back({{1e6 + 0.1, 1e6, -1e6}, {1e6 + 0.2, 1e6 + 0.1, -1e6 + 0.1}});
  const auto ids = all_ids(boxes);
  const Pairs expected = brute_force(boxes, ids);
  ASSERT_GT(expected.size(), boxes.size());
  EXPECT_TRUE(
      std::binary_search(expected.begin(), expected.end(),
                         std::array<int, 2>{static_cast<int>(boxes.size()) - 2, static_cast<int>(boxes.size()) - 1}));

  // A small cell with a high cap: heavy multi-insertion at the cell asked for (a large box
  // is at most 2.2 m wide, 23^3 < 2^14 cells).
  const real cell = 0.1;
  const auto many = check_against_brute_force(boxes, ids, cell, 1L << 14);
  EXPECT_EQ(many.cell, cell);
  EXPECT_GT(many.entries, 10 * many.boxes);

  // The same cell with the default cap (64 cells per box on average): the large boxes would
  // exceed it, so the cell grows.
  const auto capped = check_against_brute_force(boxes, ids, cell);
  EXPECT_GT(capped.cell, cell);
  EXPECT_LE(capped.entries, 64 * capped.boxes);
  EXPECT_GT(capped.entries, capped.boxes);  // still multi-inserted

  // A tiny cell (1e-7 m): the 1e6 m offsets are ~1e13 cells, still exact in int64.
  check_against_brute_force(boxes, ids, 1e-7);
  check_against_brute_force(boxes, ids, 0.0);
}

TEST(BroadPhase, OnlyActiveBoxesArePaired) {
  const auto boxes = random_cloud(11, 1500, 2.5, 0.1, 0.01);
  std::vector<int> ids = all_ids(boxes);
  std::mt19937 rng(5);
  std::shuffle(ids.begin(), ids.end(), rng);
  ids.resize(ids.size() / 3);  // a random subset, in random order
  std::vector<bool> active(boxes.size(), false);
  for (int id : ids) active[id] = true;

  for (real cell : {0.0, 0.07}) check_against_brute_force(boxes, ids, cell);
  Pairs pairs;
  find_box_pairs(boxes, ids, 0, pairs);
  EXPECT_FALSE(pairs.empty());
  for (const auto& p : pairs) {
    EXPECT_TRUE(active[p[0]] && active[p[1]]);
    EXPECT_LT(p[0], p[1]);
  }
  EXPECT_LT(pairs.size(), brute_force(boxes, all_ids(boxes)).size());
}

TEST(BroadPhase, TouchingBoxesOverlapSeparatedBoxesDoNot) {
  const real gap = 1e-9;
  const std::vector<Aabb> boxes = {
      {{0, 0, 0}, {1, 1, 1}},        // 0
      {{1, 0, 0}, {2, 1, 1}},        // 1: shares the face x = 1 with 0
      {{0, 0, 1 + gap}, {1, 1, 2}},  // 2: just above 0, a tiny gap
      {{2, 1, 1}, {3, 2, 2}},        // 3: touches 1 at one corner point
      {{3 + gap, 1, 1}, {4, 2, 2}},  // 4: just beside 3, a tiny gap
      {{0, 1, 0}, {1, 2, 1}},        // 5: shares the face y = 1 with 0, an edge with 1
  };
  const Pairs expected = {{0, 1}, {0, 5}, {1, 3}, {1, 5}};
  const auto ids = all_ids(boxes);
  ASSERT_EQ(brute_force(boxes, ids), expected);
  // Cell edges on the shared faces (0.5, 1), off them (0.3, 0.7), and one cell for all (10).
  for (real cell : {0.0, 0.3, 0.5, 0.7, 1.0, 10.0}) {
    Pairs pairs;
    find_box_pairs(boxes, ids, cell, pairs);
    EXPECT_EQ(pairs, expected) << "cell " << cell;
  }
}

TEST(BroadPhase, PointBoxesStillGetACell) {
  // Zero-extent boxes: the default cell would be zero; coincident points do overlap.
  std::vector<Aabb> boxes(4, Aabb{{1, 2, 3}, {1, 2, 3}});
  boxes.push_back({{5, 2, 3}, {5, 2, 3}});
  const auto stats = check_against_brute_force(boxes, all_ids(boxes), 0);
  EXPECT_EQ(stats.pairs, 6);
  std::vector<Aabb> same(3, Aabb{{1, 2, 3}, {1, 2, 3}});
  EXPECT_EQ(check_against_brute_force(same, all_ids(same), 0).pairs, 3);
}

TEST(BroadPhase, EmptyAndSingleBoxGiveNoPairs) {
  const std::vector<Aabb> boxes = {{{0, 0, 0}, {1, 1, 1}}, {{0.5, 0.5, 0.5}, {2, 2, 2}}};
  Pairs pairs{{0, 1}};
  BroadPhaseStats stats;
  stats.entries = 99;
  find_box_pairs(boxes, {}, 0, pairs, &stats);
  EXPECT_TRUE(pairs.empty());
  EXPECT_EQ(stats.boxes, 0);
  EXPECT_EQ(stats.entries, 0);
  EXPECT_EQ(stats.pairs, 0);

  for (int id : {0, 1}) {
    pairs = {{0, 1}};
    find_box_pairs(boxes, {id}, 0.1, pairs, &stats);
    EXPECT_TRUE(pairs.empty());
    EXPECT_EQ(stats.boxes, 1);
    EXPECT_GE(stats.entries, stats.boxes);
    EXPECT_EQ(stats.tested, 0);
  }
  // The two together do overlap: the single-box results above were not vacuous.
  find_box_pairs(boxes, {1, 0}, 0.1, pairs, &stats);
  EXPECT_EQ(pairs, (Pairs{{0, 1}}));
}

TEST(BroadPhase, OneLongBoxDoesNotCoarsenTheGrid) {
  // 2000 small boxes and one box 50 times longer than the cloud: the grid keeps the cell
  // it would have without the long box, so the work stays near linear.
  std::mt19937 rng(3);
  std::vector<Aabb> boxes;
  for (int i = 0; i < 2000; ++i) boxes.push_back(random_tet_box(rng, 1.0, 0.05, 0.005));
  const auto ids_small = all_ids(boxes);
  std::vector<std::array<int, 2>> pairs;
  BroadPhaseStats alone;
  find_box_pairs(boxes, ids_small, 0, pairs, &alone);
  boxes.push_back({{-25, 0.5, 0.5}, {25, 0.52, 0.52}});
  const auto ids = all_ids(boxes);
  const auto with_long = check_against_brute_force(boxes, ids, alone.cell);
  EXPECT_EQ(with_long.cell, alone.cell);
  EXPECT_LT(with_long.tested, 3 * alone.tested + 2000);
}
