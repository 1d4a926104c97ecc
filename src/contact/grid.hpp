#pragma once
// The broad phase's uniform grid, one definition for the host search (contact/broad_phase.cpp)
// and the time loop's build of the candidate list (solver/candidate_build.hpp). Cell coordinates
// are 64-bit and relative to the boxes' low corner, so a fragment far from the rest costs no
// memory.
#include <cmath>
#include <cstdint>

#include "contact/broad_phase.hpp"
#include "core/vec.hpp"

namespace fdem {

/// One (cell, box) entry of the multi-insertion: the cell's integer triple and the box.
struct BinEntry {
  std::int64_t ix, iy, iz;
  int box;
};

FDEM_HD bool same_cell(const BinEntry& a, const BinEntry& b) {
  return a.ix == b.ix && a.iy == b.iy && a.iz == b.iz;
}

/// The entries' order: by cell, then by box.
FDEM_HD bool bin_entry_less(const BinEntry& a, const BinEntry& b) {
  if (a.ix != b.ix) return a.ix < b.ix;
  if (a.iy != b.iy) return a.iy < b.iy;
  if (a.iz != b.iz) return a.iz < b.iz;
  return a.box < b.box;
}

/// Closed boxes: touching counts as overlapping.
FDEM_HD bool boxes_overlap(const Aabb& a, const Aabb& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

struct Grid {
  Vec3 origin;  // m, the low corner of all boxes
  real cell;    // m, the cells' edge

  /// The cell index of coordinate x along `axis`. One monotone function bins the boxes and
  /// places the intersection corner, so a point inside a box falls in one of the box's cells.
  FDEM_HD std::int64_t index(real x, int axis) const {
    return static_cast<std::int64_t>(floor((x - origin[axis]) / cell));
  }
  /// Cells covered by box b, saturated at cap + 1 (a tiny cell cannot overflow the count); 0 for
  /// an inverted box, which is binned nowhere.
  FDEM_HD long cells_of(const Aabb& b, long cap) const {
    long count = 1;
    for (int d = 0; d < 3; ++d) {
      const std::int64_t r = index(b.hi[d], d) - index(b.lo[d], d) + 1;
      if (r <= 0) return 0;
      if (r > cap / count) return cap + 1;
      count *= static_cast<long>(r);
    }
    return count;
  }
  /// Writes one entry per cell that box b covers (cells_of of them), for box number `box`, to
  /// out: cells in (x, y, z) order.
  FDEM_HD void bin(const Aabb& b, int box, BinEntry* out) const {
    const std::int64_t lx = index(b.lo.x, 0), ly = index(b.lo.y, 1), lz = index(b.lo.z, 2);
    const std::int64_t hx = index(b.hi.x, 0), hy = index(b.hi.y, 1), hz = index(b.hi.z, 2);
    for (std::int64_t ix = lx; ix <= hx; ++ix)
      for (std::int64_t iy = ly; iy <= hy; ++iy)
        for (std::int64_t iz = lz; iz <= hz; ++iz) *out++ = BinEntry{ix, iy, iz, box};
  }
  /// True where cell `key` holds the low corner of the intersection of overlapping boxes a and
  /// b: the one cell that reports the pair, so no pair is found twice.
  FDEM_HD bool reports(const Aabb& a, const Aabb& b, const BinEntry& key) const {
    return index(a.lo.x > b.lo.x ? a.lo.x : b.lo.x, 0) == key.ix &&
           index(a.lo.y > b.lo.y ? a.lo.y : b.lo.y, 1) == key.iy &&
           index(a.lo.z > b.lo.z ? a.lo.z : b.lo.z, 2) == key.iz;
  }
};

}  // namespace fdem
