// bench_l2: the memory traffic of one step of the device loop, simulated through a GPU's
// last-level cache, for the loop's schedules of its element passes (colour by colour, fused,
// and fused with the step): design questions for the GPU.
//
// Why: DeviceLoop::bytes_per_step (bench_device's floor) counts node data once per element
// corner, as if the cache kept nothing between two reads of a node; the compulsory traffic
// (each array once) is the other bound. What a GPU moves lies between and depends on what its
// L2 (50 MB on an H100, 60 MB on an H200) keeps. This program replays the addresses that the
// passes touch, in launch order (elements in index order within a launch, launches one after
// the other), through a fully associative LRU cache of 32-byte sectors, write-back, where a
// write miss does not fetch (the L2 keeps byte masks). It counts the sectors read from memory
// and written back to it in the third step (two steps warm the cache). A GPU runs thousands of
// threads at once, in roughly index order, and its L2 is not fully associative: read the
// result as an estimate, to compare schedules, not as a measurement.
//
// The model: structured boxes of the paper's cylinder proportions (as bench_device), CE6 on
// every internal face, one rank, no gravity, before fracture (no CE6 damaged, so the friction
// anchors are not touched). Replayed, per step:
//  colour (the device loop, solver/device_loop_impl.hpp): TET4 in colour order (colour-order
//    entry, node ids, X0^-1, V0, eta, assign mask; x and v of its 4 nodes read, f written, and
//    read where the corner adds); CE6 colour by colour over slots in colour order (damage,
//    node ids, h, own flag; x and v of its 6 nodes read, f read and written); integration (x,
//    v, f, own flag, m read, 1/m divided; x, v written). Activation reads the break flags only
//    on the evaluations where a CE6 broke: none here.
//  fused (FDEM_DEVICE_SCHEDULE=fused): one pass over the tets in index order: the TET4's arrays
//    and its 4 nodes' x and v, then each CE6 on its faces in colour order (the tet's CE6 list;
//    flags (own, damaged), node ids and h at the CE6's slot, the arrays being in colour order as
//    above, the damage only where the flags say damaged: none here; the 6 nodes' x and v),
//    every CE6 evaluated by both of its tets, each adding only to its own nodes; f written
//    once, never read; then integration as above. (The second copy of the damage and anchors
//    is written only for damaged CE6s: none here.)
//  fused+step (the device loop's default on one rank where every node is one tet's,
//    DeviceLoop::integrates): the fused pass, each tet also reading its flag of forces held for
//    it (contact, platens, pressure: none read here) and then moving its own 4 nodes (m from
//    the tet's V0, not read; x and v written to the second copies, as the other tets still
//    read the first ones, by turns from step to step): no force array, no integration pass.
// Not replayed (small before fracture): contact pairs, platens, the broad phase's watch list,
// the reductions' sums. Cache size 0 counts every access as a miss: the per-reference count
// at sector granularity, comparable with DeviceLoop::bytes_per_step.
//
// Usage: bench_l2 [--tets 100000,700000] [--cache-mb 0,50,60] [--bandwidth 4.3]
// (--bandwidth in TB/s: the time column is traffic / bandwidth; 4.3 TB/s is the H200's
// device-to-device copy measured by the workplace, /work/.library/device/KINDS.md.)
// Prints Markdown on stdout. A benchmark, not a test: it checks nothing.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "model/model.hpp"
#include "model/structured.hpp"
#include "scene/scene.hpp"

namespace {

using namespace fdem;

std::vector<double> parse_list(const std::string& s) {
  std::vector<double> out;
  std::stringstream ss(s);
  std::string item;
  while (std::getline(ss, item, ',')) out.push_back(std::atof(item.c_str()));
  return out;
}

constexpr std::uint64_t kSector = 32;

/// Fully associative LRU cache of 32-byte sectors over an address space of `space` bytes;
/// write-back, no fetch on a write miss. Capacity 0: every access goes to memory.
class SectorCache {
 public:
  SectorCache(std::uint64_t cache_bytes, std::uint64_t space)
      : cap_(std::int32_t(cache_bytes / kSector)),
        slot_of_(space / kSector + 1, -1),
        read_once_(space / kSector + 1, 0),
        written_once_(space / kSector + 1, 0) {
    sector_.resize(cap_);
    prev_.resize(cap_);
    next_.resize(cap_);
    dirty_.resize(cap_);
  }
  void access(std::uint64_t addr, std::uint32_t bytes, bool write) {
    for (std::uint64_t s = addr / kSector; s <= (addr + bytes - 1) / kSector; ++s) touch(std::int32_t(s), write);
  }
  /// Starts counting afresh (the sectors each step touches too).
  void reset_counts() {
    reads_ = writes_ = 0;
    std::fill(read_once_.begin(), read_once_.end(), 0);
    std::fill(written_once_.begin(), written_once_.end(), 0);
  }
  double read_bytes() const { return double(reads_) * kSector; }
  double written_bytes() const { return double(writes_) * kSector; }
  /// Each sector read once and each written once since reset_counts(): the compulsory traffic.
  double compulsory_bytes() const {
    double n = 0;
    for (std::size_t s = 0; s < read_once_.size(); ++s) n += read_once_[s] + written_once_[s];
    return n * kSector;
  }

 private:
  void touch(std::int32_t s, bool write) {
    (write ? written_once_ : read_once_)[s] = 1;
    if (cap_ == 0) {
      ++(write ? writes_ : reads_);
      return;
    }
    std::int32_t k = slot_of_[s];
    if (k >= 0) {
      unlink(k);
    } else {
      if (!write) ++reads_;
      if (used_ < cap_) {
        k = used_++;
      } else {
        k = tail_;
        unlink(k);
        if (dirty_[k]) ++writes_;
        slot_of_[sector_[k]] = -1;
      }
      sector_[k] = s;
      slot_of_[s] = k;
      dirty_[k] = 0;
    }
    dirty_[k] |= write;
    push_front(k);
  }
  void unlink(std::int32_t k) {
    if (prev_[k] >= 0)
      next_[prev_[k]] = next_[k];
    else
      head_ = next_[k];
    if (next_[k] >= 0)
      prev_[next_[k]] = prev_[k];
    else
      tail_ = prev_[k];
  }
  void push_front(std::int32_t k) {
    prev_[k] = -1;
    next_[k] = head_;
    if (head_ >= 0) prev_[head_] = k;
    head_ = k;
    if (tail_ < 0) tail_ = k;
  }
  std::int32_t cap_, used_ = 0, head_ = -1, tail_ = -1;
  std::vector<std::int32_t> slot_of_, sector_, prev_, next_;
  std::vector<std::uint8_t> dirty_, read_once_, written_once_;
  long long reads_ = 0, writes_ = 0;
};

/// An array of n elements of `size` bytes at `base` in the simulated address space.
struct Array {
  std::uint64_t base = 0, size = 0;
  std::uint64_t at(long i) const { return base + std::uint64_t(i) * size; }
};

/// The device loop's arrays, laid out one after the other (256-byte aligned).
struct Layout {
  Array x, v, f, mass, own_n, x2, v2;               // nodes (x2, v2: the second copies)
  Array torder, tet_nodes, Xinv, V0, eta, assigns;  // tets
  Array ce6_nodes, h, dmg, own_c, broke, tet_ce6;   // CE6 (and the fused pass's list)
  Array ext;                                        // per tet: forces held for the pass
  std::uint64_t end = 0;
  void place(Array& a, long n, std::uint64_t size) {
    a.base = end;
    a.size = size;
    end += (std::uint64_t(n) * size + 255) / 256 * 256;
  }
};

enum class Schedule { colour, fused, integrated };

/// One step's accesses in launch order.
void replay(const Model& m, const Layout& L, Schedule sched, const std::vector<std::array<int, 4>>& tet_ce6,
            const std::vector<int>& slot, int step, SectorCache& c) {
  const long nt = long(m.tet_nodes.size()), nc = long(m.ce6_nodes.size()), nn = long(m.X.size());
  const std::uint32_t vec = 24;
  // The rows with two copies of the node state read one and write the other, by turns.
  const bool odd = step % 2;
  const Array &xr = odd ? L.x2 : L.x, &vr = odd ? L.v2 : L.v;
  const Array &xw = odd ? L.x : L.x2, &vw = odd ? L.v : L.v2;
  auto ce6_arrays = [&](long i) {  // i: the CE6's index in the arrays' order
    c.access(L.dmg.at(i), 32, false);
    c.access(L.ce6_nodes.at(i), 24, false);
    c.access(L.h.at(i), 8, false);
  };
  if (sched == Schedule::colour) {
    std::vector<char> reached(nn, 0);
    for (long k = 0; k < nt; ++k) {
      const int t = m.tet_colours.order[k];
      c.access(L.torder.at(k), 4, false);
      c.access(L.tet_nodes.at(t), 16, false);
      c.access(L.Xinv.at(t), 72, false);
      c.access(L.V0.at(t), 8, false);
      c.access(L.eta.at(t), 8, false);
      c.access(L.assigns.at(t), 1, false);
      for (int n : m.tet_nodes[t]) {
        c.access(L.x.at(n), vec, false);
        c.access(L.v.at(n), vec, false);
        if (reached[n]) c.access(L.f.at(n), vec, false);
        reached[n] = 1;
        c.access(L.f.at(n), vec, true);
      }
    }
    for (long i = 0; i < nc; ++i) {  // slots: colour order
      const int e = m.ce6_colours.order[i];
      ce6_arrays(i);
      for (int n : m.ce6_nodes[e]) {
        c.access(L.x.at(n), vec, false);
        c.access(L.v.at(n), vec, false);
        c.access(L.f.at(n), vec, false);
        c.access(L.f.at(n), vec, true);
      }
      c.access(L.own_c.at(i), 1, false);
    }
  } else {  // fused, or fused with the step
    const bool integrated = sched == Schedule::integrated;
    const Array &xs = integrated ? xr : L.x, &vs = integrated ? vr : L.v;
    for (long t = 0; t < nt; ++t) {
      c.access(L.tet_nodes.at(t), 16, false);
      if (integrated) c.access(L.ext.at(t), 1, false);
      c.access(L.Xinv.at(t), 72, false);
      c.access(L.V0.at(t), 8, false);
      c.access(L.eta.at(t), 8, false);
      for (int n : m.tet_nodes[t]) {
        c.access(xs.at(n), vec, false);
        c.access(vs.at(n), vec, false);
      }
      c.access(L.tet_ce6.at(t), 16, false);
      for (int e : tet_ce6[t]) {
        if (e < 0) continue;
        c.access(L.own_c.at(slot[e]), 1, false);  // the flags (own, damaged): intact, no damage read
        c.access(L.ce6_nodes.at(slot[e]), 24, false);
        c.access(L.h.at(slot[e]), 8, false);
        for (int n : m.ce6_nodes[e]) {  // the own side's 3 again (from L1 on a GPU)
          c.access(xs.at(n), vec, false);
          c.access(vs.at(n), vec, false);
        }
      }
      for (int n : m.tet_nodes[t]) {
        if (!integrated) {
          c.access(L.f.at(n), vec, true);
          continue;
        }
        c.access(xs.at(n), vec, false);  // read again (the pass keeps fewer registers)
        c.access(vs.at(n), vec, false);  // (the node's mass: rho V0 / 4, from the tet's V0)
        c.access(xw.at(n), vec, true);   // the node's new x and v into the other copy
        c.access(vw.at(n), vec, true);
      }
    }
    if (integrated) return;
  }
  for (long n = 0; n < nn; ++n) {  // integration
    c.access(L.x.at(n), vec, false);
    c.access(L.v.at(n), vec, false);
    c.access(L.f.at(n), vec, false);
    c.access(L.own_n.at(n), 1, false);
    c.access(L.mass.at(n), 8, false);
    c.access(L.x.at(n), vec, true);
    c.access(L.v.at(n), vec, true);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<double> tets{100000, 700000}, cache_mb{0, 50, 60};
  double bandwidth = 4.3;  // TB/s
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--tets" && i + 1 < argc) {
      tets = parse_list(argv[++i]);
    } else if (a == "--cache-mb" && i + 1 < argc) {
      cache_mb = parse_list(argv[++i]);
    } else if (a == "--bandwidth" && i + 1 < argc) {
      bandwidth = std::atof(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: bench_l2 [--tets 100000,700000] [--cache-mb 0,50,60] [--bandwidth TB/s, default 4.3]\n");
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }
  std::printf("# bench_l2: one step's memory traffic through a simulated L2 (LRU, 32-byte sectors)\n\n");
  std::printf(
      "Structured boxes (57 x 57 x 129 mm), CE6 on every internal face, one rank, before fracture; "
      "the third step counted; time = traffic / %.2f TB/s.\n\n",
      bandwidth);
  std::printf(
      "| tets | CE6 | nodes | schedule | L2, MB | read, MB | written, MB | traffic, MB | compulsory, MB | "
      "traffic / compulsory | us at %.1f TB/s |\n",
      bandwidth);
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const double target : tets) {
    const int n = std::max(2, int(std::lround(std::cbrt(target / (6 * 2.263)))));
    const int nz = std::max(2, int(std::lround(2.263 * n)));
    Scene s;
    s.name = "bench_l2";
    s.file = "(bench_l2)";
    const Model m = build_model(structured_box_mesh({0.057, 0.057, 0.129}, n, n, nz), s);
    const long nt = long(m.tet_nodes.size()), nc = long(m.ce6_nodes.size()), nn = long(m.X.size());
    // Each tet's CE6s, ordered by colour (the order the colour passes add them to a node).
    std::vector<int> colour(nc), slot(nc);
    for (int c = 0; c < m.ce6_colours.colours(); ++c)
      for (int k = m.ce6_colours.offsets[c]; k < m.ce6_colours.offsets[c + 1]; ++k) {
        colour[m.ce6_colours.order[k]] = c;
        slot[m.ce6_colours.order[k]] = k;
      }
    std::vector<std::array<int, 4>> tet_ce6(nt, {-1, -1, -1, -1});
    std::vector<int> fill(nt, 0);
    for (long e = 0; e < nc; ++e)
      for (int t : m.ce6_tets[e]) tet_ce6[t][fill[t]++] = int(e);
    for (auto& l : tet_ce6)
      std::sort(l.begin(), l.begin() + std::count_if(l.begin(), l.end(), [](int e) { return e >= 0; }),
                [&](int a, int b) { return colour[a] < colour[b]; });
    Layout L;
    for (Array* a : {&L.x, &L.v, &L.f, &L.x2, &L.v2}) L.place(*a, nn, 24);
    L.place(L.mass, nn, 8);
    L.place(L.own_n, nn, 1);
    L.place(L.torder, nt, 4);
    L.place(L.tet_nodes, nt, 16);
    L.place(L.Xinv, nt, 72);
    L.place(L.V0, nt, 8);
    L.place(L.eta, nt, 8);
    L.place(L.assigns, nt, 1);
    L.place(L.ce6_nodes, nc, 24);
    L.place(L.h, nc, 8);
    L.place(L.dmg, nc, 32);
    L.place(L.own_c, nc, 1);
    L.place(L.broke, nc, 1);
    L.place(L.tet_ce6, nt, 16);
    L.place(L.ext, nt, 1);
    for (const Schedule sched : {Schedule::colour, Schedule::fused, Schedule::integrated})
      for (const double mb : cache_mb) {
        SectorCache c(std::uint64_t(mb * 1e6), L.end);
        for (int step = 0; step < 3; ++step) {
          if (step == 2) c.reset_counts();
          replay(m, L, sched, tet_ce6, slot, step, c);
        }
        const double r = c.read_bytes(), w = c.written_bytes(), all = r + w, once = c.compulsory_bytes();
        std::printf("| %ld | %ld | %ld | %s | %g | %.1f | %.1f | %.1f | %.1f | %.2f | %.0f |\n", nt, nc, nn,
                    sched == Schedule::colour  ? "colour"
                    : sched == Schedule::fused ? "fused"
                                               : "fused+step",
                    mb, r / 1e6, w / 1e6, all / 1e6, once / 1e6, all / once, all / (bandwidth * 1e12) * 1e6);
        std::fflush(stdout);
      }
  }
  return 0;
}
