#pragma once
// Broad phase of tet-tet contact: all pairs of overlapping axis-aligned boxes among a set
// of active tets. Binning by a sort over cell keys, written as flat passes (count, prefix
// sum, fill, sort, scan of cell ranges) so the same algorithm maps onto a GPU.
#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/vec.hpp"

namespace fdem {

struct Aabb {
  Vec3 lo, hi;
};

/// Statistics of one build, for monitors and benchmarks.
struct BroadPhaseStats {
  long boxes = 0;    // boxes binned
  long entries = 0;  // (cell, box) entries after multi-insertion
  long tested = 0;   // box pairs tested within shared cells
  long pairs = 0;    // overlapping pairs found
  real cell = 0;     // cell edge used, m
};

/// Every unordered pair {a, b} of boxes in `ids` whose closed boxes overlap (touching counts),
/// each once, as (min, max) of the two box indices, sorted lexicographically. `boxes` is
/// indexed by the values in `ids`. Each box is inserted into every cell of edge `cell` it
/// overlaps; a pair is reported only by the cell holding the low corner of the two boxes'
/// intersection, so no pair is found twice. Cell coordinates are 64-bit, so a fragment
/// far from the rest costs no memory. `cell <= 0` picks twice the mean box extent.
/// `max_cells_per_box` caps the multi-insertion on average: when all boxes together would
/// cover more than that many cells per box, the cell edge is enlarged (and reported in
/// stats.cell), so memory stays bounded; one long box alone does not coarsen the grid.
/// `groups` (indexed like `boxes`), where given: only pairs of boxes in different groups, such
/// as two ranks' tets, are tested and reported (stats count those only).
void find_box_pairs(const std::vector<Aabb>& boxes, const std::vector<int>& ids, real cell,
                    std::vector<std::array<int, 2>>& pairs, BroadPhaseStats* stats = nullptr,
                    long max_cells_per_box = 64, const std::vector<int>* groups = nullptr);

/// The pairs find_box_pairs finds (default cell), not stored: `visit(thread, a, b)` is called
/// for each, from several OpenMP threads at once (thread: omp_get_thread_num()), in no fixed
/// order. For a search whose pairs would not fit in memory (the partition's contact ghosts).
void for_each_box_pair(const std::vector<Aabb>& boxes, const std::vector<int>& ids, const std::vector<int>* groups,
                       const std::function<void(int, int, int)>& visit);

}  // namespace fdem
