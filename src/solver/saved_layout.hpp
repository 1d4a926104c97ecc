#pragma once
// Where a checkpoint's per-rank arrays sit in the whole model, so that a run on another rank
// count can read it (docs/restart.md, "Another rank count"). Each rank's file starts with it.
#include <array>
#include <cstdint>
#include <vector>

namespace fdem {

class CheckpointOut;
class CheckpointIn;

struct SavedLayout {
  int rank = 0, size = 1;
  long nodes = 0, tets = 0, ce6s = 0;  // this rank's
  // The global id of each local node, tet and CE6, and whether this rank owns it. Empty on one
  // rank: the local id is the global one, and the rank owns everything.
  std::vector<long> node, tet, ce6;
  std::vector<std::uint8_t> node_owned, tet_owned, ce6_owned;
  std::vector<int> platen_node;          // the local node of each platen entry (Model::platen_nodes)
  std::vector<int> prescribed_node;      // the local node of each prescribed-velocity entry
  std::vector<std::array<int, 3>> face;  // the local nodes of each loaded face (SurfaceLoads::faces)
  std::vector<int> face_condition;       // and its condition, -1 the confinement's (empty: all -1)
  std::uint64_t faces_kept = 0;          // the faces with a power and work (SurfaceLoads::face_power)
  std::uint64_t model = 0;               // the whole model's fingerprint, the same on every rank count

  long global_node(int n) const { return node.empty() ? n : node[n]; }
  long global_tet(int t) const { return tet.empty() ? t : tet[t]; }
  long global_ce6(int c) const { return ce6.empty() ? c : ce6[c]; }
  bool owns_node(int n) const { return node_owned.empty() || node_owned[n]; }
  bool owns_tet(int t) const { return tet_owned.empty() || tet_owned[t]; }
  bool owns_ce6(int c) const { return ce6_owned.empty() || ce6_owned[c]; }

  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
};

/// Per local id of a saved rank, the local id on this rank, or -1 where the saved rank does not
/// own it or this rank does not hold it. Each entity held here has one owner among the saved
/// ranks, so each is set once.
struct EntityMap {
  std::vector<int> node, tet, ce6;
};

/// into[to[i]] = from[i] for every mapped i (from may be shorter than to: arrays kept before
/// contact ghosts were gathered); returns how many were set.
template <class T, class U>
long scatter_saved(const std::vector<T>& from, const std::vector<int>& to, std::vector<U>& into) {
  long set = 0;
  for (std::size_t i = 0; i < from.size() && i < to.size(); ++i)
    if (to[i] >= 0) into[std::size_t(to[i])] = from[i], ++set;
  return set;
}

}  // namespace fdem
