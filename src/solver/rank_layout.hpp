#pragma once
// This rank's share of a model: what it owns, the halo that keeps its ghosts current, and which
// elements its passes compute. On one rank it owns everything and has no halo.
#include <mpi.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "core/vec.hpp"
#include "model/model.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"

namespace fdem {

struct RankLayout {
  RankLayout() = default;
  RankLayout(const RankLayout&) = delete;  // the halo refers to dd: set up in place, never moved
  RankLayout& operator=(const RankLayout&) = delete;

  Decomposition dd;
  MPI_Comm comm = MPI_COMM_SELF;
  std::unique_ptr<Halo> halo;  // several ranks only
  double halo_seconds = 0;     // wall time of the node halo exchanges so far
  /// Per local node / tet / CE6: 1 where this rank owns it (all 1 on one rank).
  std::vector<std::uint8_t> own_node, own_tet, own_ce6;
  // Per tet, bit i: its node i takes its first force from this tet (assigned, not added); the
  // nodes no TET4 of the colours reaches, zeroed apart. (Without gravity only.)
  std::vector<std::uint8_t> tet_assigns;
  std::vector<int> unreached_nodes;

  bool distributed() const { return dd.distributed(); }
  /// Sums values over the ranks in place (nothing on one rank).
  void sum(real* values, int n) const;
  /// The layout of model m on decomposition d (empty: one rank) among the ranks of comm, set up
  /// in place (the halo refers to dd). Several ranks: m's colourings keep only the elements this
  /// rank owns or that touch a node it owns (the others' forces are its ghosts', which their
  /// owners compute); the halo's node lists follow the active tets where `contact`. Throws
  /// InputError when d was made for another rank count. The halo's clock keeps running.
  void set_up(Model& m, Decomposition d, bool contact);
};

}  // namespace fdem
