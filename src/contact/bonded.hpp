#pragma once
// The bonded-neighbour rule of the contact candidate filter (docs/physics.md, "Bonded
// neighbours"). Two tets that share a mesh vertex and are held together there by intact CE6s
// meet only through those CE6s, which hold the interface until they break (as they hold their
// own two faces). So they are no contact pair until a CE6 on the path between them breaks.
//
// At a mesh vertex u the tets around it (its star) hold one or more nodes at u: a node is a set
// of tets joined across faces without a CE6 (model/build.cpp splits nodes that way). An
// intact CE6 on a face containing u welds the nodes of its two tets at u. Two tets are welded
// at u when their nodes there are joined by a chain of such welds. They are bonded when they
// share at least one vertex, no CE6 joins them, and they are welded at every vertex they share.
#include <cstdint>

#include "core/config.hpp"

namespace fdem {

/// A tet's contact flags (ContactSet::tet_flags), one byte: whether it is a contact candidate,
/// and which of its faces' CE6s weld no more. Flags only rise.
struct TetFlag {
  static constexpr std::uint8_t kCandidate = 1;
  /// Removed by an excavation: never a candidate again, whatever else is raised.
  static constexpr std::uint8_t kExcavated = 0x80;
  static FDEM_HD constexpr bool candidate(std::uint8_t f) { return (f & (kCandidate | kExcavated)) == kCandidate; }
  /// The CE6 on face i (the face opposite corner i) has broken.
  static FDEM_HD constexpr std::uint8_t face_released(int i) { return std::uint8_t(2u << i); }
};

/// What the rule reads: the vertex stars and the CE6s on the tets' faces.
struct BondInputs {
  const int* tet_nodes = nullptr;       // 4 per tet
  const int* node_vertex = nullptr;     // per node, its mesh vertex
  const int* star_ptr = nullptr;        // per vertex u, its tets star_tets[star_ptr[u] .. star_ptr[u+1])
  const int* star_tets = nullptr;       //
  const int* face_ce6 = nullptr;        // 4 per tet: the CE6 on face i, -1 none
  const int* ce6_tets = nullptr;        // 2 per CE6
  const std::uint8_t* flags = nullptr;  // per tet, TetFlag bits; null: no welds (one shared node bonds)

  /// Stars larger than this keep each node apart (conservative: more pairs, never fewer).
  static constexpr int kMaxStar = 64;

  FDEM_HD int corner_at(int t, int u) const {
    for (int i = 0; i < 4; ++i)
      if (node_vertex[tet_nodes[4 * t + i]] == u) return i;
    return -1;
  }

  /// Labels the corners at vertex u: weld[4 t + i] for each tet t of its star (corner i at u) is
  /// the smallest node id welded to t's node at u. Equal labels: welded at u.
  /// On several ranks a star may lack tets; the labels there are read only for pairs that act
  /// on no node the rank owns, which it drops anyway (every node private: an owned node's tet is
  /// owned, and the ghost layer holds the whole star of each of its vertices).
  FDEM_HD void label_star(int u, int* weld) const {
    const int first = star_ptr[u], n = star_ptr[u + 1] - first;
    if (!flags || n > kMaxStar) {  // no welds: each node its own label
      for (int k = 0; k < n; ++k) {
        const int t = star_tets[first + k], c = corner_at(t, u);
        weld[4 * t + c] = tet_nodes[4 * t + c];
      }
      return;
    }
    int group[kMaxStar], node[kMaxStar], corner[kMaxStar];  // union-find over the star's entries
    for (int k = 0; k < n; ++k) {
      const int t = star_tets[first + k];
      group[k] = k, corner[k] = corner_at(t, u), node[k] = tet_nodes[4 * t + corner[k]];
    }
    auto root = [&](int k) {
      while (group[k] != k) k = group[k] = group[group[k]];
      return k;
    };
    for (int k = 0; k < n; ++k) {
      for (int j = 0; j < k; ++j)  // one node: one group
        if (node[j] == node[k]) group[root(j)] = root(k);
      const int t = star_tets[first + k], cu = corner[k];
      for (int i = 0; i < 4; ++i) {
        const int c = face_ce6[4 * t + i];
        if (i == cu || c < 0 || (flags[t] & TetFlag::face_released(i))) continue;
        const int other = ce6_tets[2 * c] == t ? ce6_tets[2 * c + 1] : ce6_tets[2 * c];
        for (int j = 0; j < n; ++j)
          if (star_tets[first + j] == other) group[root(j)] = root(k);
      }
    }
    for (int k = 0; k < n; ++k) {  // the smallest node of its group
      int label = node[k];
      for (int j = 0; j < n; ++j)
        if (root(j) == root(k) && node[j] < label) label = node[j];
      weld[4 * star_tets[first + k] + corner[k]] = label;
    }
  }

  /// ta and tb share a vertex and are welded at each they share (`weld` from label_star).
  /// Without welds (flags null) one shared node bonds them, as tets of one continuous body.
  FDEM_HD bool bonded(const int* weld, int ta, int tb) const {
    bool shares = false, welded = true, one_node = false;
    for (int i = 0; i < 4; ++i) {
      const int j = corner_at(tb, node_vertex[tet_nodes[4 * ta + i]]);
      if (j < 0) continue;
      shares = true;
      welded = welded && flags && weld[4 * ta + i] == weld[4 * tb + j];  // (weld: read with welds only)
      one_node = one_node || tet_nodes[4 * ta + i] == tet_nodes[4 * tb + j];
    }
    return flags ? shares && welded : one_node;
  }
};

}  // namespace fdem
