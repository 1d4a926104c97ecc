// Broad phase of contact: all overlapping pairs among a set of axis-aligned boxes, by
// binning into a uniform grid of 64-bit cell coordinates. Every step is a flat pass over
// boxes, entries or cells (reduction, count, exclusive scan, fill, sort, run detection,
// per-cell pair test), with no hashing containers and no recursion, so each pass maps
// one-to-one onto a GPU kernel or a library primitive (scan, radix sort).
#include "contact/broad_phase.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include "contact/grid.hpp"
#include "core/error.hpp"
#include "core/for_each.hpp"

namespace fdem {

namespace {

/// Pass 1 (reduction): the boxes' overall bounds and the sum of their largest extents.
struct BoxSpread {
  Vec3 lo, hi;
  real extent_sum = 0;
  real span() const { return std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, real(0)}); }
};
BoxSpread spread_of(const std::vector<Aabb>& boxes, const std::vector<int>& ids) {
  const std::size_t n = ids.size();
  const real inf = std::numeric_limits<real>::infinity();
  real x0 = inf, y0 = inf, z0 = inf, x1 = -inf, y1 = -inf, z1 = -inf, extent_sum = 0;
  long bad = 0;
#pragma omp parallel for schedule(static) reduction(min : x0, y0, z0) reduction(max : x1, y1, z1) \
    reduction(+ : extent_sum, bad)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) {
    const Aabb& b = boxes[ids[i]];
    for (int d = 0; d < 3; ++d) bad += (std::isfinite(b.lo[d]) && std::isfinite(b.hi[d])) ? 0 : 1;
    x0 = std::min(x0, b.lo.x), y0 = std::min(y0, b.lo.y), z0 = std::min(z0, b.lo.z);
    x1 = std::max(x1, b.hi.x), y1 = std::max(y1, b.hi.y), z1 = std::max(z1, b.hi.z);
    extent_sum += std::max({b.hi.x - b.lo.x, b.hi.y - b.lo.y, b.hi.z - b.lo.z, real(0)});
  }
  if (bad > 0) throw RunError("contact broad phase: a box has a non-finite coordinate (the run is unstable)");
  return {{x0, y0, z0}, {x1, y1, z1}, extent_sum};
}

/// Pass 2 (count, repeated while needed): cells per box, into offset[0..n). The cell grows
/// until all boxes together cover at most `budget` cells (memory stays bounded, while one
/// long box among small ones does not coarsen the grid for all the others, which would make
/// the pair test quadratic), and until the farthest coordinate is at most 2^50 cells away,
/// which keeps the int64 indices and the double quotient exact.
void count_cells(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real span, long budget, Grid& grid,
                 std::vector<long>& offset) {
  const std::size_t n = ids.size();
  const real max_index = std::ldexp(1.0, 50);
  for (;;) {
    while (span / grid.cell > max_index) grid.cell *= 2;
    long sum = 0;
    for_each(n, [&](std::size_t i) { offset[i] = grid.cells_of(boxes[ids[i]], budget); });
#pragma omp parallel for schedule(static) reduction(+ : sum)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) sum += offset[i];
    if (sum <= budget) break;
    grid.cell *= 2;
  }
}

/// Exclusive prefix sum in place; a.back() becomes the total (a device scan on a GPU).
long exclusive_scan(std::vector<long>& a) {
  long total = 0;
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    const long c = a[i];
    a[i] = total;
    total += c;
  }
  a.back() = total;
  return total;
}

/// Pass 5 (run detection, a stream compaction): flag the first entry of each cell, scan the
/// flags, scatter the starts. Cell c's run is cell_start[c] .. cell_start[c + 1].
std::vector<long> cell_starts(const std::vector<BinEntry>& entries) {
  const long total = static_cast<long>(entries.size());
  std::vector<long> head(static_cast<std::size_t>(total) + 1);
  for_each(static_cast<std::size_t>(total),
           [&](std::size_t k) { head[k] = (k == 0 || !same_cell(entries[k - 1], entries[k])) ? 1 : 0; });
  const long cells = exclusive_scan(head);
  std::vector<long> cell_start(static_cast<std::size_t>(cells) + 1);
  for_each(static_cast<std::size_t>(total), [&](std::size_t k) {
    if (k == 0 || !same_cell(entries[k - 1], entries[k])) cell_start[head[k]] = static_cast<long>(k);
  });
  cell_start[cells] = total;
  return cell_start;
}

/// Pass 6 (pair test per cell): all pairs within a run; a pair is kept only by the cell
/// holding the low corner of the two boxes' intersection, so it is found exactly once.
/// `visit(thread, a, b)` gets each overlapping pair (of two groups, where groups are given).
/// Returns the pairs tested.
template <class Visit>
long visit_pairs_in_cells(const std::vector<Aabb>& boxes, const Grid& grid, const std::vector<BinEntry>& entries,
                          const std::vector<long>& cell_start, const std::vector<int>* groups, Visit&& visit) {
  const long cells = static_cast<long>(cell_start.size()) - 1;
  long tested = 0;
#pragma omp parallel reduction(+ : tested)
  {
    const int thread = omp_get_thread_num();
#pragma omp for schedule(dynamic, 64)
    for (long c = 0; c < cells; ++c) {
      const long s = cell_start[c], e = cell_start[c + 1];
      const BinEntry& key = entries[s];
      for (long j = s; j < e; ++j) {
        const int a = entries[j].box;
        const Aabb& ba = boxes[a];
        for (long k = j + 1; k < e; ++k) {
          const int b = entries[k].box;
          if (groups && (*groups)[a] == (*groups)[b]) continue;
          const Aabb& bb = boxes[b];
          ++tested;
          if (boxes_overlap(ba, bb) && grid.reports(ba, bb, key)) visit(thread, a, b);
        }
      }
    }
  }
  return tested;
}

/// The grid of the boxes in `ids` (passes 1-5): its cell, the sorted entries and where each
/// cell's run starts.
struct BinnedBoxes {
  Grid grid;
  std::vector<BinEntry> entries;
  std::vector<long> cell_start;
};

BinnedBoxes bin_boxes(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real cell, long max_cells_per_box) {
  const std::size_t n = ids.size();
  const long cap = std::clamp(max_cells_per_box, 1L, 1L << 20);
  const BoxSpread spread = spread_of(boxes, ids);
  const real span = spread.span();
  // Cell edge: twice the mean extent by default; never zero (all boxes points).
  if (!(cell > 0)) cell = 2 * spread.extent_sum / static_cast<real>(n);
  if (!(cell > 0)) cell = span > 0 ? 1e-6 * span : 1;
  BinnedBoxes b{Grid{spread.lo, cell}, {}, {}};
  std::vector<long> offset(n + 1);
  count_cells(boxes, ids, span, cap * static_cast<long>(n), b.grid, offset);
  const long total = exclusive_scan(offset);  // where each box writes its entries

  // Pass 3 (fill): each box writes one entry per covered cell into its own slice.
  b.entries.resize(static_cast<std::size_t>(total));
  for_each(n, [&](std::size_t i) { b.grid.bin(boxes[ids[i]], ids[i], b.entries.data() + offset[i]); });
  // Pass 4 (sort) by (ix, iy, iz, box). A GPU would radix-sort on a 64-bit hash of the
  // triple and break ties (hash collisions) on the triple itself, so runs stay exact.
  std::sort(b.entries.begin(), b.entries.end(), bin_entry_less);
  b.cell_start = cell_starts(b.entries);
  return b;
}

}  // namespace

// Preconditions: every value in `ids` indexes `boxes`, ids holds no duplicates (a duplicate
// would be paired with itself and its pairs reported twice), and every box is finite with
// lo <= hi per axis (an inverted box is binned nowhere and never reported). A non-finite
// coordinate throws RunError.
void find_box_pairs(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real cell,
                    std::vector<std::array<int, 2>>& pairs, BroadPhaseStats* stats, long max_cells_per_box,
                    const std::vector<int>* groups) {
  pairs.clear();
  if (ids.empty()) {
    if (stats) *stats = BroadPhaseStats{0, 0, 0, 0, cell > 0 ? cell : 0};
    return;
  }
  const BinnedBoxes b = bin_boxes(boxes, ids, cell, max_cells_per_box);
  // Per-thread lists, concatenated and sorted, so the result does not depend on the thread
  // count (a GPU would count per cell, scan, then write).
  std::vector<std::vector<std::array<int, 2>>> found(static_cast<std::size_t>(omp_get_max_threads()));
  const long tested =
      visit_pairs_in_cells(boxes, b.grid, b.entries, b.cell_start, groups, [&](int thread, int a, int c) {
        found[static_cast<std::size_t>(thread)].push_back({std::min(a, c), std::max(a, c)});
      });
  std::size_t count = 0;
  for (const auto& f : found) count += f.size();
  pairs.reserve(count);
  for (const auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
  std::sort(pairs.begin(), pairs.end());
  if (stats) {
    stats->boxes = static_cast<long>(ids.size());
    stats->entries = static_cast<long>(b.entries.size());
    stats->tested = tested;
    stats->pairs = static_cast<long>(pairs.size());
    stats->cell = b.grid.cell;
  }
}

void for_each_box_pair(const std::vector<Aabb>& boxes, const std::vector<int>& ids, const std::vector<int>* groups,
                       const std::function<void(int, int, int)>& visit) {
  if (ids.empty()) return;
  const BinnedBoxes b = bin_boxes(boxes, ids, 0, 64);
  visit_pairs_in_cells(boxes, b.grid, b.entries, b.cell_start, groups, visit);
}

}  // namespace fdem
