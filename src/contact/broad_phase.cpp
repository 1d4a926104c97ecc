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

// Preconditions: every value in `ids` indexes `boxes`, ids holds no duplicates (a duplicate
// would be paired with itself and its pairs reported twice), and every box is finite with
// lo <= hi per axis (an inverted box is binned nowhere and never reported). A non-finite
// coordinate throws RunError.
void find_box_pairs(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real cell,
                    std::vector<std::array<int, 2>>& pairs, BroadPhaseStats* stats, long max_cells_per_box) {
  pairs.clear();
  const std::size_t n = ids.size();
  const long cap = std::clamp(max_cells_per_box, 1L, 1L << 20);
  if (n == 0) {
    if (stats) *stats = BroadPhaseStats{0, 0, 0, 0, cell > 0 ? cell : 0};
    return;
  }

  // Pass 1 (reduction): overall bounding box and the sum of the largest box extents.
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
  const real span = std::max({x1 - x0, y1 - y0, z1 - z0, real(0)});

  // Cell edge: twice the mean extent by default; never zero (all boxes points).
  if (!(cell > 0)) cell = 2 * extent_sum / static_cast<real>(n);
  if (!(cell > 0)) cell = span > 0 ? 1e-6 * span : 1;
  Grid grid{{x0, y0, z0}, cell};

  // Pass 2 (count, repeated while needed): cells per box. Enlarge the cell until all boxes
  // together cover at most `cap` cells per box on average (memory stays bounded, while one
  // long box among small ones does not coarsen the grid for all the others, which would make
  // the pair test quadratic), and until the farthest coordinate is at most 2^50 cells away,
  // which keeps the int64 indices and the double quotient exact.
  std::vector<long> offset(n + 1);
  const real max_index = std::ldexp(1.0, 50);
  const long budget = cap * static_cast<long>(n);
  for (;;) {
    while (span / grid.cell > max_index) grid.cell *= 2;
    long sum = 0;
    for_each(n, [&](std::size_t i) { offset[i] = grid.cells_of(boxes[ids[i]], budget); });
#pragma omp parallel for schedule(static) reduction(+ : sum)
    for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(n); ++i) sum += offset[i];
    if (sum <= budget) break;
    grid.cell *= 2;
  }

  // Exclusive prefix sum of the counts: where each box writes its entries (a device scan on a GPU).
  long total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const long c = offset[i];
    offset[i] = total;
    total += c;
  }
  offset[n] = total;

  // Pass 3 (fill): each box writes one entry per covered cell into its own slice.
  std::vector<BinEntry> entries(static_cast<std::size_t>(total));
  for_each(n, [&](std::size_t i) { grid.bin(boxes[ids[i]], ids[i], entries.data() + offset[i]); });

  // Pass 4 (sort) by (ix, iy, iz, box). A GPU would radix-sort on a 64-bit hash of the
  // triple and break ties (hash collisions) on the triple itself, so runs stay exact.
  std::sort(entries.begin(), entries.end(), bin_entry_less);

  // Pass 5 (run detection, a stream compaction): flag the first entry of each cell, scan
  // the flags, scatter the starts. cell_start[c] .. cell_start[c + 1] is cell c's run.
  std::vector<long> head(static_cast<std::size_t>(total) + 1);
  for_each(static_cast<std::size_t>(total),
           [&](std::size_t k) { head[k] = (k == 0 || !same_cell(entries[k - 1], entries[k])) ? 1 : 0; });
  long cells = 0;
  for (long k = 0; k < total; ++k) {
    const long f = head[k];
    head[k] = cells;
    cells += f;
  }
  std::vector<long> cell_start(static_cast<std::size_t>(cells) + 1);
  for_each(static_cast<std::size_t>(total), [&](std::size_t k) {
    if (k == 0 || !same_cell(entries[k - 1], entries[k])) cell_start[head[k]] = static_cast<long>(k);
  });
  cell_start[cells] = total;

  // Pass 6 (pair test per cell): all pairs within a run; a pair is kept only by the cell
  // holding the low corner of the two boxes' intersection, so it is found exactly once.
  // Per-thread lists here; a GPU would count per cell, scan, then write (or append atomically).
  std::vector<std::vector<std::array<int, 2>>> found(static_cast<std::size_t>(omp_get_max_threads()));
  long tested = 0;
#pragma omp parallel reduction(+ : tested)
  {
    std::vector<std::array<int, 2>>& mine = found[static_cast<std::size_t>(omp_get_thread_num())];
#pragma omp for schedule(dynamic, 64)
    for (long c = 0; c < cells; ++c) {
      const long s = cell_start[c], e = cell_start[c + 1];
      const BinEntry& key = entries[s];
      for (long j = s; j < e; ++j) {
        const int a = entries[j].box;
        const Aabb& ba = boxes[a];
        for (long k = j + 1; k < e; ++k) {
          const int b = entries[k].box;
          const Aabb& bb = boxes[b];
          ++tested;
          if (!boxes_overlap(ba, bb) || !grid.reports(ba, bb, key)) continue;
          mine.push_back({std::min(a, b), std::max(a, b)});
        }
      }
    }
  }

  // Concatenate and sort: the result does not depend on the thread count.
  std::size_t count = 0;
  for (const auto& f : found) count += f.size();
  pairs.reserve(count);
  for (const auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
  std::sort(pairs.begin(), pairs.end());

  if (stats) {
    stats->boxes = static_cast<long>(n);
    stats->entries = total;
    stats->tested = tested;
    stats->pairs = static_cast<long>(pairs.size());
    stats->cell = grid.cell;
  }
}

}  // namespace fdem
