#include "solver/rank_layout.hpp"

#include <string>

#include "core/error.hpp"

namespace fdem {

void RankLayout::sum(real* values, int n) const {
  if (dd.distributed()) sum_over_ranks(comm, values, n);
}

namespace {

/// Keeps in colouring c the elements owned (`own`) or with a node owned (`own_node`).
template <class NodesOf>
void keep_touching_owned(Colouring& c, const std::vector<std::uint8_t>& own, const std::vector<std::uint8_t>& own_node,
                         NodesOf&& nodes_of) {
  Colouring kept;
  kept.offsets.push_back(0);
  for (int k = 0; k < c.colours(); ++k) {
    for (int j = c.offsets[k]; j < c.offsets[k + 1]; ++j) {
      bool any = own[c.order[j]];
      for (int n : nodes_of(c.order[j])) any = any || own_node[n];
      if (any) kept.order.push_back(c.order[j]);
    }
    kept.offsets.push_back(int(kept.order.size()));
  }
  c = std::move(kept);
}

/// The forces start at zero without a pass of their own: the first TET4 (in colour order) to
/// reach a node assigns to it, the rest add; nodes no TET4 reaches (ghosts of other ranks'
/// elements) are zeroed apart.
void plan_first_touch(const Model& m, RankLayout& l) {
  const std::size_t nn = m.X.size();
  l.tet_assigns.assign(m.tet_nodes.size(), 0);
  std::vector<char> reached(nn, 0);
  for (int t : m.tet_colours.order)
    for (int i = 0; i < 4; ++i)
      if (!reached[m.tet_nodes[t][i]]) reached[m.tet_nodes[t][i]] = 1, l.tet_assigns[t] |= 1 << i;
  l.unreached_nodes.clear();
  for (std::size_t n = 0; n < nn; ++n)
    if (!reached[n]) l.unreached_nodes.push_back(int(n));
}

}  // namespace

void RankLayout::set_up(Model& m, Decomposition d, bool contact) {
  halo.reset();
  dd = std::move(d);
  const std::size_t nn = m.X.size();
  if (dd.distributed()) {
    const int size = size_of(comm);
    if (size != dd.size || dd.node_owned.size() != nn || dd.tet_owned.size() != m.tet_nodes.size() ||
        dd.ce6_owned.size() != m.ce6_nodes.size())
      throw InputError("the model is partitioned for " + std::to_string(dd.size) + " ranks but runs on " +
                       std::to_string(size) + " (or its decomposition does not match it). Fix: run with mpiexec -n " +
                       std::to_string(dd.size) + ", or partition again for " + std::to_string(size) + " ranks");
    own_node = dd.node_owned;
    own_tet = dd.tet_owned;
    own_ce6 = dd.ce6_owned;
    // With contact the node lists follow the active tets (partition/halo.hpp).
    halo = std::make_unique<Halo>(comm, dd, contact ? &m.tet_nodes : nullptr);
    // Forces are needed on owned nodes only: the passes skip elements that are not this rank's
    // and have no owned node (ghosts' nodes take their owners' values after each step). With
    // CE6 everywhere that is every ghost TET4 and every CE6 off the partition boundary.
    keep_touching_owned(m.tet_colours, own_tet, own_node, [&](int t) { return m.tet_nodes[t]; });
    keep_touching_owned(m.ce6_colours, own_ce6, own_node, [&](int c) { return m.ce6_nodes[c]; });
  } else {
    own_node.assign(nn, 1);
    own_tet.assign(m.tet_nodes.size(), 1);
    own_ce6.assign(m.ce6_nodes.size(), 1);
  }
  plan_first_touch(m, *this);
}

}  // namespace fdem
