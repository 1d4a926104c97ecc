#pragma once
// The time loop's build of the contact candidate list, on any Exec (core/forall.hpp): the
// passes of contact/broad_phase.cpp's find_box_pairs (bounds, count, scan, fill, sort, runs,
// pair test) on the active tets' boxes, with the candidate filters; then the friction springs
// carried over, the gather index that sums the pairs' forces per node, and the watch list that
// says when to build again. Only counts come back to the host. test_broad_phase holds the
// search to a brute-force one; test_reference holds the whole loop to a serial stepper.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "contact/bonded.hpp"
#include "contact/broad_phase.hpp"
#include "contact/grid.hpp"
#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "core/forall.hpp"
#include "core/vec.hpp"
#include "solver/contact_set.hpp"

namespace fdem {

/// What a build reads: the loop's arrays.
struct CandidateInputs {
  int tets = 0, nodes = 0;
  const Vec3* x = nullptr;                 // node positions now
  const int* tet_nodes = nullptr;          // 4 per tet
  const std::uint8_t* flags = nullptr;     // per tet, TetFlag bits: kCandidate where it is a candidate
  const long* tet_global = nullptr;        // per tet its global id; null: the local id (one rank)
  const std::uint8_t* own_node = nullptr;  // per node, 1 where this rank owns it; null: every node
  int vertices = 0;                        // mesh vertices held
  BondInputs bond;                         // the bonded-neighbour rule's inputs (contact/bonded.hpp)
  real buffer = 0;                         // m, the boxes' inflation
};

/// A (node, pair-force slot) record of the gather index.
struct NodeSlot {
  int node, slot;
};

/// A tet's global id where the ranks have them, else its local one: the pairs' order.
struct GlobalTetId {
  const long* global;
  FDEM_HD long operator()(int t) const { return global ? global[t] : long(t); }
};

template <class Exec>
class CandidateBuild {
 public:
  void set_backend(Backend b) {
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(flags_, offsets_, counts_, entry_offsets_, head_, head_offsets_, cell_start_, cell_counts_, cell_offsets_);
    set(vertex_flags_, vertex_offsets_, ids_, vertex_list_, welds_, boxes_, entries_, node_slots_);
  }

  /// The candidate pairs among the active tets, into `pairs`: tets a and b whose boxes, inflated
  /// by half the buffer each, overlap; a < b by global id, sorted by (a, b) global ids. Bonded
  /// neighbours are left out (contact/bonded.hpp); a pair a CE6 joins is kept, with that CE6
  /// (`joint`). On several ranks, so are pairs acting on no owned node.
  BroadPhaseStats find_pairs(const CandidateInputs& in, DeviceArray<ContactPair>& pairs) {
    BroadPhaseStats st;
    st.boxes = active_ids(in);
    inflate_boxes(in);
    const int na = int(st.boxes);
    if (na == 0) {
      pairs.resize(0);
      return st;
    }
    if (in.bond.flags) label_welds(in);  // (without welds a shared node alone bonds)
    const Grid grid = choose_grid(na, st.cell);
    st.entries = bin(na, grid);
    const long cells = cell_runs(st.entries);
    st.pairs = test_cells(in, grid, cells, pairs, st.tested);
    return st;
  }

  /// The histories of the new pairs: each pair's old history where it was a pair before
  /// (both lists in the same order), else that of a new pair.
  void carry_history(const CandidateInputs& in, const DeviceArray<ContactPair>& old_pairs,
                     const DeviceArray<PairHistory>& old_history, const DeviceArray<ContactPair>& pairs,
                     DeviceArray<PairHistory>& history) {
    const GlobalTetId gid{in.tet_global};
    const long npairs = long(pairs.size());
    history.resize(npairs);
    const ContactPair* oldp = old_pairs.data();
    const PairHistory* olds = old_history.data();
    const long nold = long(old_pairs.size());
    const ContactPair* np = pairs.data();
    PairHistory* ns = history.data();
    Exec::forall(int(npairs), [=] FDEM_LAMBDA(int i) {
      long lo = 0, hi = nold;
      while (lo < hi) {
        const long mid = (lo + hi) / 2;
        const bool less =
            gid(oldp[mid].a) != gid(np[i].a) ? gid(oldp[mid].a) < gid(np[i].a) : gid(oldp[mid].b) < gid(np[i].b);
        if (less)
          lo = mid + 1;
        else
          hi = mid;
      }
      ns[i] = lo < nold && oldp[lo].a == np[i].a && oldp[lo].b == np[i].b ? olds[lo] : new_pair_history();
    });
  }

  /// The gather index of `pairs` (8 force slots each: a's 4 nodes, then b's): node node[k]
  /// receives slots slot[ptr[k] .. ptr[k+1]), nodes ascending, slots ascending within a node.
  void gather_index(const CandidateInputs& in, const DeviceArray<ContactPair>& pairs, DeviceArray<int>& node,
                    DeviceArray<int>& ptr, DeviceArray<int>& slot) {
    const long npairs = long(pairs.size()), nslots = 8 * npairs;
    node_slots_.resize(nslots);
    NodeSlot* rec = node_slots_.data();
    const ContactPair* pp = pairs.data();
    const int* tn = in.tet_nodes;
    Exec::forall(int(npairs), [=] FDEM_LAMBDA(int p) {
      for (int i = 0; i < 4; ++i) {
        rec[8 * p + i] = NodeSlot{tn[4 * pp[p].a + i], 8 * p + i};
        rec[8 * p + 4 + i] = NodeSlot{tn[4 * pp[p].b + i], 8 * p + 4 + i};
      }
    });
    Exec::sort(rec, nslots, [] FDEM_LAMBDA(const NodeSlot& a, const NodeSlot& b) {
      return a.node != b.node ? a.node < b.node : a.slot < b.slot;
    });
    head_.resize(nslots);
    head_offsets_.resize(nslots);
    long* hd = head_.data();
    long* ho = head_offsets_.data();
    Exec::forall(int(nslots), [=] FDEM_LAMBDA(int k) { hd[k] = k == 0 || rec[k - 1].node != rec[k].node; });
    const long ng = Exec::scan(nslots, hd, ho);
    node.resize(ng);
    ptr.resize(nslots > 0 ? ng + 1 : 1);
    slot.resize(nslots);
    int* gn = node.data();
    int* gp = ptr.data();
    int* gs = slot.data();
    Exec::forall(int(nslots), [=] FDEM_LAMBDA(int k) {
      if (hd[k]) gn[ho[k]] = rec[k].node, gp[ho[k]] = k;
      gs[k] = rec[k].slot;
    });
    Exec::forall(1, [=] FDEM_LAMBDA(int) { gp[ng] = int(nslots); });
  }

  /// The watch list of the last find_pairs: the nodes of its active tets (ascending) and their
  /// positions now.
  void watch_list(const CandidateInputs& in, DeviceArray<int>& nodes, DeviceArray<Vec3>& at) {
    const int nn = in.nodes, na = int(ids_.size());
    const int* tn = in.tet_nodes;
    const int* ids = ids_.data();
    const Vec3* x = in.x;
    long* fl = flags_.data();
    long* of = offsets_.data();
    Exec::forall(nn, [=] FDEM_LAMBDA(int n) { fl[n] = 0; });
    Exec::forall(na, [=] FDEM_LAMBDA(int k) {
      for (int i = 0; i < 4; ++i) raise_flag(fl + tn[4 * ids[k] + i]);  // (a node two active tets share)
    });
    const long nw = Exec::scan(nn, fl, of);
    nodes.resize(nw);
    at.resize(nw);
    int* wn = nodes.data();
    Vec3* wx = at.data();
    Exec::forall(nn, [=] FDEM_LAMBDA(int n) {
      if (fl[n]) wn[of[n]] = n, wx[of[n]] = x[n];
    });
  }

  /// Gives the scratch memory back (the cpu backend, where it counts against the run's as
  /// host code's locals would; a GPU keeps it, since an allocation there waits for the device).
  void release_scratch() {
    auto release = [](auto&... a) { (a.release(), ...); };
    release(flags_, offsets_, counts_, entry_offsets_, head_, head_offsets_, cell_start_, cell_counts_, cell_offsets_,
            vertex_flags_, vertex_offsets_, ids_, vertex_list_, welds_, boxes_, entries_, node_slots_);
  }

  // The stages of find_pairs. (Public, as every function holding a pass: nvcc's extended lambdas
  // need their enclosing function public.)
  /// ids_: the active tets, ascending; returns their count. (flags_ and offsets_ are sized for
  /// the watch list too.)
  long active_ids(const CandidateInputs& in) {
    const int nt = in.tets;
    flags_.resize(std::max(nt, in.nodes));
    offsets_.resize(std::max(nt, in.nodes));
    long* fl = flags_.data();
    long* of = offsets_.data();
    const std::uint8_t* active = in.flags;
    Exec::forall(nt, [=] FDEM_LAMBDA(int t) { fl[t] = TetFlag::candidate(active[t]); });
    const long na = Exec::scan(nt, fl, of);
    ids_.resize(na);
    int* ids = ids_.data();
    Exec::forall(nt, [=] FDEM_LAMBDA(int t) {
      if (TetFlag::candidate(active[t])) ids[of[t]] = t;
    });
    return na;
  }

  /// welds_: per tet corner at a vertex of an active tet, its weld label there
  /// (BondInputs::label_star). Each such vertex is labelled once.
  void label_welds(const CandidateInputs& in) {
    const int na = int(ids_.size()), nv = in.vertices;
    vertex_flags_.resize(nv);
    vertex_offsets_.resize(nv);
    welds_.resize(4 * long(in.tets));
    long* vf = vertex_flags_.data();
    long* vo = vertex_offsets_.data();
    const int* ids = ids_.data();
    const BondInputs bond = in.bond;
    Exec::forall(nv, [=] FDEM_LAMBDA(int u) { vf[u] = 0; });
    Exec::forall(na, [=] FDEM_LAMBDA(int k) {
      for (int i = 0; i < 4; ++i) raise_flag(vf + bond.node_vertex[bond.tet_nodes[4 * ids[k] + i]]);
    });
    const long marked = Exec::scan(nv, vf, vo);
    vertex_list_.resize(marked);
    int* list = vertex_list_.data();
    Exec::forall(nv, [=] FDEM_LAMBDA(int u) {
      if (vf[u]) list[vo[u]] = u;
    });
    int* weld = welds_.data();
    Exec::forall(int(marked), [=] FDEM_LAMBDA(int k) { bond.label_star(list[k], weld); });
  }

  /// boxes_: each active tet's box, inflated by half the buffer.
  void inflate_boxes(const CandidateInputs& in) {
    const int na = int(ids_.size());
    boxes_.resize(na);
    Aabb* boxes = boxes_.data();
    const int* ids = ids_.data();
    const int* tn = in.tet_nodes;
    const Vec3* x = in.x;
    const real half = 0.5 * in.buffer;
    Exec::forall(na, [=] FDEM_LAMBDA(int k) {
      const int* q = tn + 4 * ids[k];
      Aabb b{x[q[0]], x[q[0]]};
      for (int i = 1; i < 4; ++i)
        for (int d = 0; d < 3; ++d) {
          b.lo[d] = x[q[i]][d] < b.lo[d] ? x[q[i]][d] : b.lo[d];
          b.hi[d] = x[q[i]][d] > b.hi[d] ? x[q[i]][d] : b.hi[d];
        }
      for (int d = 0; d < 3; ++d) b.lo[d] -= half, b.hi[d] += half;
      boxes[k] = b;
    });
  }

  /// The grid of the na boxes: its origin their low corner, its cell twice their mean extent,
  /// doubled until they cover at most 64 cells each on average and the farthest box is at most
  /// 2^50 cells away (counts_: each box's cells). Throws RunError for a box not finite.
  Grid choose_grid(int na, real& cell) {
    const Aabb* boxes = boxes_.data();
    const auto mx = Exec::template max<6>(na, [=] FDEM_LAMBDA(int k, real* acc) {
      const Aabb& b = boxes[k];
      for (int d = 0; d < 3; ++d) {
        acc[d] = -b.lo[d] > acc[d] ? -b.lo[d] : acc[d];
        acc[3 + d] = b.hi[d] > acc[3 + d] ? b.hi[d] : acc[3 + d];
      }
    });
    const auto ex = Exec::template sum<2>(na, [=] FDEM_LAMBDA(int k, real* acc) {
      const Aabb& b = boxes[k];
      const real dx = b.hi.x - b.lo.x, dy = b.hi.y - b.lo.y, dz = b.hi.z - b.lo.z;
      const real e = dx > dy ? (dx > dz ? dx : dz) : (dy > dz ? dy : dz);
      acc[0] += e > 0 ? e : 0;
      for (int d = 0; d < 3; ++d) acc[1] += !(finite_value(b.lo[d]) && finite_value(b.hi[d]));
    });
    if (ex[1] > 0) throw RunError("contact broad phase: a box has a non-finite coordinate (the run is unstable)");
    Grid grid{{-mx[0], -mx[1], -mx[2]}, 0};
    const real span = std::max({mx[3] + mx[0], mx[4] + mx[1], mx[5] + mx[2], real(0)});
    grid.cell = 2 * ex[0] / na;
    if (!(grid.cell > 0)) grid.cell = span > 0 ? 1e-6 * span : 1;
    const long budget = 64L * na;
    counts_.resize(na);
    long* counts = counts_.data();
    for (;;) {
      while (span / grid.cell > std::ldexp(1.0, 50)) grid.cell *= 2;
      const Grid g = grid;
      const real total = Exec::template sum<1>(na, [=] FDEM_LAMBDA(int k, real* acc) {
        counts[k] = g.cells_of(boxes[k], budget);
        acc[0] += real(counts[k]);
      })[0];
      if (total <= real(budget)) break;
      grid.cell *= 2;
    }
    cell = grid.cell;
    return grid;
  }

  /// entries_: one entry per (cell, box) a box covers, sorted by cell then box; their count.
  long bin(int na, const Grid& g) {
    entry_offsets_.resize(na);
    long* eo = entry_offsets_.data();
    const long entries = Exec::scan(na, counts_.data(), eo);
    entries_.resize(entries);
    BinEntry* en = entries_.data();
    const Aabb* boxes = boxes_.data();
    Exec::forall(na, [=] FDEM_LAMBDA(int k) { g.bin(boxes[k], k, en + eo[k]); });
    Exec::sort(en, entries, [] FDEM_LAMBDA(const BinEntry& a, const BinEntry& b) { return bin_entry_less(a, b); });
    return entries;
  }

  /// cell_start_: where each cell's run of entries starts (one past the last at the end); the
  /// number of cells.
  long cell_runs(long entries) {
    head_.resize(entries);
    head_offsets_.resize(entries);
    long* hd = head_.data();
    long* ho = head_offsets_.data();
    const BinEntry* en = entries_.data();
    Exec::forall(int(entries), [=] FDEM_LAMBDA(int k) { hd[k] = k == 0 || !same_cell(en[k - 1], en[k]); });
    const long cells = Exec::scan(entries, hd, ho);
    cell_start_.resize(cells + 1);
    long* cst = cell_start_.data();
    Exec::forall(int(entries), [=] FDEM_LAMBDA(int k) {
      if (hd[k]) cst[ho[k]] = k;
      if (k == 0) cst[cells] = entries;
    });
    return cells;
  }

  /// The pair test per cell, twice: count, then write at the scanned offsets. A pair is kept by
  /// the cell of the low corner of its boxes' intersection, once. Returns the pairs' count and
  /// the box pairs tested into `tested`.
  long test_cells(const CandidateInputs& in, const Grid& g, long cells, DeviceArray<ContactPair>& pairs, long& tested) {
    const BinEntry* en = entries_.data();
    const long* cst = cell_start_.data();
    const Aabb* boxes = boxes_.data();
    const int* ids = ids_.data();
    const BondInputs bond = in.bond;
    const int* weld = welds_.data();
    const std::uint8_t* own_n = in.own_node;
    const GlobalTetId gid{in.tet_global};
    auto test = [=] FDEM_LAMBDA(long c, ContactPair* out, long* tested_out) -> long {
      const long b0 = cst[c], e0 = cst[c + 1];
      const BinEntry key = en[b0];
      long kept = 0, seen = 0;
      for (long j = b0; j < e0; ++j) {
        const Aabb& ba = boxes[en[j].box];
        for (long k = j + 1; k < e0; ++k) {
          const Aabb& bb = boxes[en[k].box];
          ++seen;
          if (!boxes_overlap(ba, bb) || !g.reports(ba, bb, key)) continue;
          int ta = ids[en[j].box], tb = ids[en[k].box];
          if (gid(ta) > gid(tb)) {
            const int t = ta;
            ta = tb, tb = t;
          }
          const int joint = candidate_joint(bond, weld, own_n, ta, tb);
          if (joint == kNotACandidate) continue;
          if (out) out[kept] = ContactPair{ta, tb, joint};
          ++kept;
        }
      }
      if (tested_out) *tested_out = seen;
      return kept;
    };
    cell_counts_.resize(cells);
    cell_offsets_.resize(cells);
    long* cc = cell_counts_.data();
    long* co = cell_offsets_.data();
    tested = long(Exec::template sum<1>(int(cells), [=] FDEM_LAMBDA(int c, real* acc) {
      long seen = 0;
      cc[c] = test(c, nullptr, &seen);
      acc[0] += real(seen);
    })[0]);
    const long npairs = Exec::scan(cells, cc, co);
    pairs.resize(npairs);
    ContactPair* np = pairs.data();
    Exec::forall(int(cells), [=] FDEM_LAMBDA(int c) { test(c, np + co[c], nullptr); });
    Exec::sort(np, npairs, [=] FDEM_LAMBDA(const ContactPair& a, const ContactPair& b) {
      return gid(a.a) != gid(b.a) ? gid(a.a) < gid(b.a) : gid(a.b) < gid(b.b);
    });
    return npairs;
  }

  static constexpr int kNotACandidate = -2;
  /// The filters of a box pair (ta, tb): the CE6 that joins them, -1 where none does, or
  /// kNotACandidate where they are bonded neighbours (`weld`: label_welds), or (own_n: several
  /// ranks) where they act on no node this rank owns.
  static FDEM_HD int candidate_joint(const BondInputs& bond, const int* weld, const std::uint8_t* own_n, int ta,
                                     int tb) {
    const int* tn = bond.tet_nodes;
    int joint = -1;
    for (int i = 0; i < 4; ++i) {
      const int ce = bond.face_ce6[4 * ta + i];
      if (ce >= 0 && (bond.ce6_tets[2 * ce] == tb || bond.ce6_tets[2 * ce + 1] == tb)) joint = ce;
    }
    if (joint < 0 && bond.bonded(weld, ta, tb)) return kNotACandidate;
    if (own_n) {  // a pair acting on no owned node does not matter on this rank
      bool any = false;
      for (int i = 0; i < 4; ++i) any = any || own_n[tn[4 * ta + i]] || own_n[tn[4 * tb + i]];
      if (!any) return kNotACandidate;
    }
    return joint;
  }

 private:
  // Scratch, kept between builds on a GPU (allocated once).
  DeviceArray<long> flags_, offsets_, counts_, entry_offsets_, head_, head_offsets_, cell_start_, cell_counts_,
      cell_offsets_, vertex_flags_, vertex_offsets_;
  DeviceArray<int> ids_, vertex_list_, welds_;  // welds_: label_welds
  DeviceArray<Aabb> boxes_;
  DeviceArray<BinEntry> entries_;
  DeviceArray<NodeSlot> node_slots_;
};

}  // namespace fdem
