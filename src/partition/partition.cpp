#include "partition/partition.hpp"

#include <metis.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "contact/broad_phase.hpp"
#include "core/error.hpp"
#include "io/checkpoint.hpp"

namespace fdem {
namespace {

template <class T>
std::vector<T> pick(const std::vector<T>& all, const std::vector<int>& ids) {
  std::vector<T> out(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) out[i] = all[ids[i]];
  return out;
}

/// The tets whose box lies in a cell (of a grid with the largest box's edge) that also holds a
/// box of another rank's tet: every pair of overlapping boxes of two ranks is among them.
std::vector<int> boundary_tets(const std::vector<Aabb>& boxes, const std::vector<int>& part) {
  const int n = int(boxes.size());
  std::vector<int> all(n);
  std::iota(all.begin(), all.end(), 0);
  if (n == 0) return all;
  Vec3 lo = boxes[0].lo;
  real edge = 0;
  for (const Aabb& b : boxes)
    for (int d = 0; d < 3; ++d) lo[d] = std::min(lo[d], b.lo[d]), edge = std::max(edge, b.hi[d] - b.lo[d]);
  if (!(edge > 0)) return all;
  // Cells as 21 bits per axis; a model wider than 2^21 of its largest boxes is not filtered.
  auto cell = [&](real x, int d) { return std::int64_t(std::floor((x - lo[d]) / edge)); };
  constexpr std::int64_t kAxis = 1 << 21;
  for (const Aabb& b : boxes)
    for (int d = 0; d < 3; ++d)
      if (!(cell(b.hi[d], d) < kAxis)) return all;
  std::unordered_map<std::int64_t, int> rank_of;  // cell -> the rank of its boxes, -1 for two or more
  auto each_cell = [&](const Aabb& b, auto&& f) {
    for (std::int64_t x = cell(b.lo.x, 0); x <= cell(b.hi.x, 0); ++x)
      for (std::int64_t y = cell(b.lo.y, 1); y <= cell(b.hi.y, 1); ++y)
        for (std::int64_t z = cell(b.lo.z, 2); z <= cell(b.hi.z, 2); ++z) f((x * kAxis + y) * kAxis + z);
  };
  rank_of.reserve(std::size_t(n));
  for (int t = 0; t < n; ++t)
    each_cell(boxes[t], [&](std::int64_t c) {
      auto it = rank_of.emplace(c, part[t]).first;
      if (it->second != part[t]) it->second = -1;
    });
  std::vector<int> out;
  for (int t = 0; t < n; ++t) {
    bool mixed = false;
    each_cell(boxes[t], [&](std::int64_t c) { mixed = mixed || rank_of[c] < 0; });
    if (mixed) out.push_back(t);
  }
  return out;
}

}  // namespace

std::vector<int> tet_cost_weights(const Model& m) {
  std::vector<int> w(m.tet_nodes.size(), 4);
  for (const auto& ab : m.ce6_tets) w[ab[0]] += 3, w[ab[1]] += 3;
  return w;
}

namespace {

/// METIS k-way on the dual graph into `parts` (2 or more); a part may come out empty.
std::vector<int> metis_parts(const Model& m, int parts, PartitionWeights weights) {
  idx_t ne = idx_t(m.tet_nodes.size());
  std::vector<int> part(ne, 0);
  // Mesh vertices (not split nodes): tets sharing a face are neighbours even across a CE6.
  std::vector<idx_t> eptr(ne + 1), eind(4 * std::size_t(ne));
  idx_t nv = 0;
  for (idx_t t = 0; t < ne; ++t) {
    eptr[t] = 4 * t;
    for (int i = 0; i < 4; ++i) {
      eind[4 * t + i] = m.node_vertex[m.tet_nodes[t][i]];
      nv = std::max(nv, eind[4 * t + i] + 1);
    }
  }
  eptr[ne] = 4 * ne;
  idx_t ncommon = 3, nparts = parts, objval = 0;
  idx_t options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 1;
  options[METIS_OPTION_NUMBERING] = 0;
  options[METIS_OPTION_CONTIG] = 1;
  std::vector<idx_t> epart(ne), npart(nv), vwgt;
  if (weights == PartitionWeights::cost) {
    const std::vector<int> w = tet_cost_weights(m);
    vwgt.assign(w.begin(), w.end());
  }
  idx_t* wp = vwgt.empty() ? nullptr : vwgt.data();
  int rc = METIS_PartMeshDual(&ne, &nv, eptr.data(), eind.data(), wp, nullptr, &ncommon, &nparts, nullptr, options,
                              &objval, epart.data(), npart.data());
  if (rc != METIS_OK) {  // contiguous parts are impossible for a mesh in pieces: try without
    options[METIS_OPTION_CONTIG] = 0;
    rc = METIS_PartMeshDual(&ne, &nv, eptr.data(), eind.data(), wp, nullptr, &ncommon, &nparts, nullptr, options,
                            &objval, epart.data(), npart.data());
  }
  if (rc != METIS_OK)
    throw InputError("partition: METIS failed (code " + std::to_string(rc) + ") for " + std::to_string(parts) +
                     " parts of " + std::to_string(ne) + " tets");
  for (idx_t t = 0; t < ne; ++t) part[t] = int(epart[t]);
  return part;
}

/// The first rank of `parts` with no tet in `part`, or -1.
int empty_rank(const std::vector<int>& part, int parts) {
  std::vector<char> used(parts, 0);
  for (int p : part) used[p] = 1;
  const auto it = std::find(used.begin(), used.end(), 0);
  return it == used.end() ? -1 : int(it - used.begin());
}

/// The most ranks, below `parts`, whose every rank METIS gives tets (0 if a few tries find none:
/// only small models meet this, so the tries are quick).
int most_filled(const Model& m, int parts, PartitionWeights weights) {
  const int top = int(std::min<long>(parts - 1, long(m.tet_nodes.size())));
  for (int q = top; q >= std::max(1, top - 31); --q)
    if (q == 1 || empty_rank(metis_parts(m, q, weights), q) < 0) return q;
  return 0;
}

}  // namespace

std::vector<int> partition_tets(const Model& m, int parts, PartitionWeights weights) {
  const long ne = long(m.tet_nodes.size());
  if (parts < 1) throw InputError("partition: " + std::to_string(parts) + " ranks. Fix: run with 1 rank or more");
  std::vector<int> part;
  int empty = 0;
  if (parts == 1) return std::vector<int>(ne, 0);
  if (parts <= ne) {
    part = metis_parts(m, parts, weights);
    empty = empty_rank(part, parts);
    if (empty < 0) return part;
  }
  const int usable = most_filled(m, parts, weights);
  const std::string fix = "Fix: run with " +
                          (usable > 0 ? "at most " + std::to_string(usable) + " ranks, the most that each receive tets"
                                      : std::string("fewer ranks")) +
                          " (a few thousand tets per rank or more is sensible)";
  if (parts > ne)
    throw InputError("partition: " + std::to_string(parts) + " ranks for a model of " + std::to_string(ne) +
                     " tets: every rank needs tets. " + fix);
  throw InputError("partition: rank " + std::to_string(empty) + " of " + std::to_string(parts) +
                   " received no tets (the model has " + std::to_string(ne) + "). " + fix);
}

void append_tet(Model& m, const std::array<int, 4>& nodes, int input, const Mat3& Xinv, real V0, real eta,
                const Model::TetProperties& props) {
  m.tet_nodes.push_back(nodes);
  m.tet_input.push_back(input);
  m.tet_Xinv.push_back(Xinv);
  m.tet_V0.push_back(V0);
  m.tet_eta.push_back(eta);
  m.tet_material.push_back(props.material);
  // (Factors other than 1, and joints, keep a list; before the first, every tet had 1 and none.)
  if (!m.tet_stiffness.empty() || props.stiffness != 1) {
    m.tet_stiffness.resize(m.tet_nodes.size() - 1, 1);
    m.tet_stiffness.push_back(props.stiffness);
  }
  if (!m.tet_joint.empty() || props.joint != 0) {
    m.tet_joint.resize(m.tet_nodes.size() - 1, 0);
    m.tet_joint.push_back(props.joint);
  }
  if (!m.tet_group.empty() || props.group != 0) {
    m.tet_group.resize(m.tet_nodes.size() - 1, 0);
    m.tet_group.push_back(props.group);
  }
  if (!m.tet_history.empty() || props.history != 0) {
    m.tet_history.resize(m.tet_nodes.size() - 1, 0);
    m.tet_history.push_back(props.history);
  }
  if (!m.tet_stage.empty() || props.stage != 0) {
    m.tet_stage.resize(m.tet_nodes.size() - 1, 0);
    m.tet_stage.push_back(props.stage);
  }
}

real default_reach(const Model& m, const Scene& s) {
  if (!s.contact.enabled()) return 0;
  // The platen travel by the end (axial strain x height, or velocity x time, whichever ends the
  // run first): the specimen's loaded end moves that far, and the ranks gather their contact
  // ghosts again each time a node has moved a quarter of the reach.
  real travel = 0;
  const EndCondition& end = s.solver.end;
  if (end.axial_strain > 0) travel = end.axial_strain * m.height0;
  if (s.platens.enabled && end.time > 0) {
    const real by_time = s.platens.velocity * end.time;
    travel = travel > 0 ? std::min(travel, by_time) : by_time;
  }
  return std::max(2 * m.mean_edge, 2.5 * travel);
}

namespace {

/// Contact ghosts: adds to held[t] each other rank with a tet whose reference box comes within
/// `reach` of tet t's (ranks sorted).
void add_contact_ghosts(const Model& g, const std::vector<int>& part, int size, real reach,
                        std::vector<std::vector<int>>& held) {
  const int nt = int(g.tet_nodes.size());
  std::vector<Aabb> boxes(nt);
  for (int t = 0; t < nt; ++t) {
    Aabb b{g.X[g.tet_nodes[t][0]], g.X[g.tet_nodes[t][0]]};
    for (int n : g.tet_nodes[t])
      for (int d = 0; d < 3; ++d) b.lo[d] = std::min(b.lo[d], g.X[n][d]), b.hi[d] = std::max(b.hi[d], g.X[n][d]);
    for (int d = 0; d < 3; ++d) b.lo[d] -= 0.5 * reach, b.hi[d] += 0.5 * reach;
    boxes[t] = b;
  }
  // Only tets near another rank's tets can have a partner there: two overlapping boxes
  // share a cell of a grid whose edge is the largest box, so the pair search needs only
  // the tets in a cell that holds tets of two ranks (a shell around each interface). All
  // pairs within the reach took most of rank 0's start time and memory (docs/cluster.md).
  const std::vector<int> ids = boundary_tets(boxes, part);
  // Only pairs of two ranks' tets are looked for, and they are not kept: what a tet needs is
  // the ranks within its reach, a few, where its pairs are hundreds (210 million pairs, 3.4
  // GB, at 64 ranks of 10,000 tets: bench_ranks --weak). Each thread keeps (tet, rank)
  // keys, made unique whenever they pile up.
  const std::size_t threads = std::size_t(omp_get_max_threads());
  std::vector<std::vector<std::int64_t>> keys(threads);
  std::vector<std::size_t> limit(threads, std::size_t(1) << 22);  // keys before the next unique()
  auto unique = [](std::vector<std::int64_t>& k) {
    std::sort(k.begin(), k.end());
    k.erase(std::unique(k.begin(), k.end()), k.end());
  };
  for_each_box_pair(boxes, ids, &part, [&](int thread, int a, int b) {
    auto& k = keys[std::size_t(thread)];
    k.push_back(std::int64_t(a) * size + part[b]), k.push_back(std::int64_t(b) * size + part[a]);
    if (k.size() >= limit[std::size_t(thread)])
      unique(k), limit[std::size_t(thread)] = std::max(limit[std::size_t(thread)], 2 * k.size());
  });
  std::vector<std::int64_t> all;
  for (auto& k : keys) all.insert(all.end(), k.begin(), k.end()), std::vector<std::int64_t>().swap(k);
  unique(all);
  for (std::int64_t key : all) {
    auto& h = held[std::size_t(key / size)];
    const int r = int(key % size);
    if (std::find(h.begin(), h.end(), r) == h.end()) h.push_back(r);
  }
  for (auto& h : held) std::sort(h.begin(), h.end());  // by rank, as the lists below assume
}

}  // namespace

PartitionPlan plan_partition(const Model& g, const std::vector<int>& part, real reach) {
  const int nt = int(g.tet_nodes.size()), nn = int(g.X.size());
  PartitionPlan plan;
  plan.reach = reach;
  plan.part = part;
  int size = 0;
  for (int p : part) size = std::max(size, p + 1);
  plan.size = size;
  if (int(part.size()) != nt || size < 1)
    throw InputError("partition: the partition does not match the model (" + std::to_string(part.size()) +
                     " entries for " + std::to_string(nt) + " tets)");
  const VertexTets vt(g);

  // Node owner: the rank of the lowest-numbered tet holding the node.
  plan.node_owner.assign(nn, -1);
  for (int t = 0; t < nt; ++t)
    for (int n : g.tet_nodes[t])
      if (plan.node_owner[n] < 0) plan.node_owner[n] = part[t];

  // Tets each rank holds: its own (bucketed once) and the tets sharing a mesh vertex with them.
  // A tet is held by few ranks.
  auto& held = plan.held;
  held.assign(nt, {});
  {
    std::vector<int> start(size + 1, 0), by_rank(nt);
    for (int p : part) ++start[p + 1];
    for (int r = 0; r < size; ++r) start[r + 1] += start[r];
    std::vector<int> fill(start.begin(), start.end() - 1);
    for (int t = 0; t < nt; ++t) by_rank[fill[part[t]]++] = t;
    std::vector<char> in(nt, 0);
    std::vector<int> touched;
    for (int r = 0; r < size; ++r) {
      touched.assign(by_rank.begin() + start[r], by_rank.begin() + start[r + 1]);
      for (int t : touched) in[t] = 1;
      for (int k = start[r]; k < start[r + 1]; ++k)
        for (int n : g.tet_nodes[by_rank[k]]) {
          const int vtx = g.node_vertex[n];
          for (int j = vt.ptr[vtx]; j < vt.ptr[vtx + 1]; ++j)
            if (!in[vt.tets[j]]) in[vt.tets[j]] = 1, touched.push_back(vt.tets[j]);
        }
      for (int t : touched) held[t].push_back(r), in[t] = 0;
    }
  }
  if (reach > 0) add_contact_ghosts(g, part, size, reach, held);

  // Ranks that need each node's position and velocity every step: those where an element they
  // compute uses it, i.e. a tet or CE6 they own or with a node they own (the other ghosts'
  // nodes are not read). Contact reads the nodes of a held tet while it is active: the halo
  // adds those as tets activate (partition/halo.hpp).
  plan.node_ranks.assign(nn, {});
  auto need = [&](int n, int r) {
    auto& rs = plan.node_ranks[n];
    if (std::find(rs.begin(), rs.end(), r) == rs.end()) rs.push_back(r);
  };
  for (int t = 0; t < nt; ++t)
    for (int r : held[t]) {
      bool used = part[t] == r;
      for (int n : g.tet_nodes[t]) used = used || plan.node_owner[n] == r;
      if (used)
        for (int n : g.tet_nodes[t]) need(n, r);
    }
  for (std::size_t c = 0; c < g.ce6_nodes.size(); ++c) {
    const auto& ab = g.ce6_tets[c];
    for (int r : held[ab[0]]) {
      if (std::find(held[ab[1]].begin(), held[ab[1]].end(), r) == held[ab[1]].end()) continue;
      bool used = part[std::min(ab[0], ab[1])] == r;
      for (int n : g.ce6_nodes[c]) used = used || plan.node_owner[n] == r;
      if (used)
        for (int n : g.ce6_nodes[c]) need(n, r);
    }
  }
  for (auto& rs : plan.node_ranks) std::sort(rs.begin(), rs.end());
  return plan;
}

RankModel extract_rank(const Model& g, const std::vector<int>& part, int rank, real reach) {
  return extract_rank(g, plan_partition(g, part, reach), rank);
}

RankModel extract_rank(const Model& g, const PartitionPlan& plan, int rank) {
  return extract_rank(g, plan, rank, PieceIds{});
}

namespace {

/// What a rank holds, by global index in ascending order, and the local id of each global one
/// (-1 where not held).
struct HeldParts {
  std::vector<int> tets, tet_local;
  std::vector<int> nodes, node_local;
  std::vector<int> ce6s, ce6_local;
};

/// The tets the plan gives the rank, their nodes, and the CE6s whose two tets it holds.
HeldParts select_held(const Model& g, const PartitionPlan& plan, int rank) {
  const int nt = int(g.tet_nodes.size()), nn = int(g.X.size()), nc = int(g.ce6_nodes.size());
  const auto& held = plan.held;
  HeldParts h;
  h.tet_local.assign(nt, -1);
  for (int t = 0; t < nt; ++t)
    if (std::binary_search(held[t].begin(), held[t].end(), rank)) {
      h.tet_local[t] = int(h.tets.size());
      h.tets.push_back(t);
    }
  std::vector<char> node_in(nn, 0);
  for (int t : h.tets)
    for (int n : g.tet_nodes[t]) node_in[n] = 1;
  h.node_local.assign(nn, -1);
  for (int n = 0; n < nn; ++n)
    if (node_in[n]) h.node_local[n] = int(h.nodes.size()), h.nodes.push_back(n);
  for (int c = 0; c < nc; ++c)
    if (h.tet_local[g.ce6_tets[c][0]] >= 0 && h.tet_local[g.ce6_tets[c][1]] >= 0) h.ce6s.push_back(c);
  h.ce6_local.assign(nc, -1);
  for (std::size_t i = 0; i < h.ce6s.size(); ++i) h.ce6_local[h.ce6s[i]] = int(i);
  return h;
}

/// The held nodes, tets, CE6s and surface faces, renumbered locally.
void cut_elements(const Model& g, const HeldParts& h, Model& m) {
  const std::vector<int>& nodes = h.nodes;
  const std::vector<int>& tets = h.tets;
  const std::vector<int>& ce6s = h.ce6s;
  m.X = pick(g.X, nodes);
  m.mass = pick(g.mass, nodes);
  if (!g.node_conditions.empty()) m.node_conditions = pick(g.node_conditions, nodes);
  if (!g.node_history.empty()) m.node_history = pick(g.node_history, nodes);
  // Mesh vertices renumbered densely (the contact vicinity indexes by vertex).
  {
    std::unordered_map<int, int> vmap;
    m.node_vertex.resize(nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      const int v = g.node_vertex[nodes[i]];
      auto it = vmap.emplace(v, int(vmap.size())).first;
      m.node_vertex[i] = it->second;
    }
  }
  m.tet_nodes.resize(tets.size());
  for (std::size_t i = 0; i < tets.size(); ++i)
    for (int k = 0; k < 4; ++k) m.tet_nodes[i][k] = h.node_local[g.tet_nodes[tets[i]][k]];
  m.tet_input = pick(g.tet_input, tets);
  m.tet_Xinv = pick(g.tet_Xinv, tets);
  m.tet_V0 = pick(g.tet_V0, tets);
  m.tet_eta = pick(g.tet_eta, tets);
  m.tet_material = pick(g.tet_material, tets);
  if (!g.tet_stiffness.empty()) m.tet_stiffness = pick(g.tet_stiffness, tets);
  if (!g.tet_joint.empty()) m.tet_joint = pick(g.tet_joint, tets);
  if (!g.tet_history.empty()) m.tet_history = pick(g.tet_history, tets);
  if (!g.tet_group.empty()) m.tet_group = pick(g.tet_group, tets);
  if (!g.tet_stage.empty()) m.tet_stage = pick(g.tet_stage, tets);
  if (std::all_of(m.tet_stage.begin(), m.tet_stage.end(), [](std::uint8_t k) { return k == 0; })) m.tet_stage.clear();
  if (std::all_of(m.tet_group.begin(), m.tet_group.end(), [](int t) { return t == 0; })) m.tet_group.clear();
  // (None of its tets beside a joint: no list, as the DMPlex records build it, append_tet.)
  if (std::all_of(m.tet_joint.begin(), m.tet_joint.end(), [](std::uint8_t j) { return j == 0; })) m.tet_joint.clear();
  m.ce6_nodes.resize(ce6s.size());
  m.ce6_tets.resize(ce6s.size());
  for (std::size_t i = 0; i < ce6s.size(); ++i) {
    for (int k = 0; k < 6; ++k) m.ce6_nodes[i][k] = h.node_local[g.ce6_nodes[ce6s[i]][k]];
    for (int k = 0; k < 2; ++k) m.ce6_tets[i][k] = h.tet_local[g.ce6_tets[ce6s[i]][k]];
  }
  m.ce6_h = pick(g.ce6_h, ce6s);
  m.ce6_law = pick(g.ce6_law, ce6s);
  if (!g.ce6_strength.empty()) m.ce6_strength = pick(g.ce6_strength, ce6s);
  for (std::size_t i = 0; i < g.surface_faces.size(); ++i)
    if (h.tet_local[g.surface_tet[i]] >= 0) {
      const auto& q = g.surface_faces[i];
      m.surface_faces.push_back({h.node_local[q[0]], h.node_local[q[1]], h.node_local[q[2]]});
      m.surface_tet.push_back(h.tet_local[g.surface_tet[i]]);
      if (!g.surface_conditions.empty()) m.surface_conditions.push_back(g.surface_conditions[i]);
    }
}

/// The platen nodes the rank owns, and the held nodes of the top, bottom and lateral groups.
void cut_node_groups(const Model& g, const std::vector<int>& node_owner, int rank, const HeldParts& h, Model& m) {
  for (std::size_t i = 0; i < g.platen_nodes.size(); ++i) {
    const int n = g.platen_nodes[i];
    if (node_owner[n] != rank) continue;  // a platen acts on one node: its owner computes it
    m.platen_nodes.push_back(h.node_local[n]);
    m.platen_node_area.push_back(g.platen_node_area[i]);
    m.platen_node_h.push_back(g.platen_node_h[i]);
  }
  auto group = [&](const std::vector<int>& all, std::vector<int>& mine) {
    for (int n : all)
      if (h.node_local[n] >= 0) mine.push_back(h.node_local[n]);
  };
  group(g.top_nodes, m.top_nodes);
  group(g.bottom_nodes, m.bottom_nodes);
  group(g.lateral_nodes, m.lateral_nodes);
}

/// The model-wide values, with the source naming the rank.
void copy_model_scalars(const Model& g, int rank, int size, Model& m) {
  m.box_min = g.box_min;
  m.condition_axis = g.condition_axis;
  m.box_max = g.box_max;
  m.axis_point = g.axis_point;
  m.height0 = g.height0;
  m.area0 = g.area0;
  m.line_loaded = g.line_loaded;
  m.min_altitude = g.min_altitude;
  m.mean_edge = g.mean_edge;
  m.source = g.source + " (rank " + std::to_string(rank) + " of " + std::to_string(size) + ")";
}

/// A global colouring restricted to the held elements, in local ids.
Colouring restrict_colouring(const Colouring& c, const std::vector<int>& local) {
  Colouring out;
  out.offsets.push_back(0);
  for (int k = 0; k < c.colours(); ++k) {
    for (int j = c.offsets[k]; j < c.offsets[k + 1]; ++j)
      if (local[c.order[j]] >= 0) out.order.push_back(local[c.order[j]]);
    out.offsets.push_back(int(out.order.size()));
  }
  return out;
}

/// The global ids of held elements: their index in g, or through `of` where g is a piece.
std::vector<long> global_ids(const std::vector<int>& local, const std::vector<long>& of, bool piece) {
  std::vector<long> out(local.begin(), local.end());
  if (piece)
    for (long& i : out) i = of[i];
  return out;
}

/// The global ids of the held elements, and which of them the rank owns.
void set_ownership(const Model& g, const PartitionPlan& plan, const HeldParts& h, const PieceIds& ids, bool piece,
                   Decomposition& dd) {
  const int rank = dd.rank;
  dd.node_global = global_ids(h.nodes, ids.node, piece);
  dd.tet_global = global_ids(h.tets, ids.tet, piece);
  dd.ce6_global = global_ids(h.ce6s, ids.ce6, piece);
  dd.node_owned.resize(h.nodes.size());
  for (std::size_t i = 0; i < h.nodes.size(); ++i) dd.node_owned[i] = plan.node_owner[h.nodes[i]] == rank;
  dd.tet_owned.resize(h.tets.size());
  for (std::size_t i = 0; i < h.tets.size(); ++i) dd.tet_owned[i] = plan.part[h.tets[i]] == rank;
  dd.ce6_owned.resize(h.ce6s.size());
  for (std::size_t i = 0; i < h.ce6s.size(); ++i) {
    const auto& ab = g.ce6_tets[h.ce6s[i]];
    dd.ce6_owned[i] = plan.part[std::min(ab[0], ab[1])] == rank;
  }
}

/// The halo plan: the nodes sent to and received from each rank, and the tets shared with it.
std::vector<Neighbour> halo_neighbours(const PartitionPlan& plan, int rank, const HeldParts& h) {
  const int size = plan.size;
  const std::vector<int>& node_owner = plan.node_owner;
  const auto& node_ranks = plan.node_ranks;
  std::vector<Neighbour> nb(size);
  for (int r = 0; r < size; ++r) nb[r].rank = r;
  for (std::size_t i = 0; i < h.nodes.size(); ++i) {
    const int n = h.nodes[i];
    if (node_owner[n] == rank) {
      for (int r : node_ranks[n])
        if (r != rank) nb[r].send_nodes.push_back(int(i));
    } else if (std::binary_search(node_ranks[n].begin(), node_ranks[n].end(), rank)) {
      nb[node_owner[n]].recv_nodes.push_back(int(i));
    }
  }
  for (std::size_t i = 0; i < h.tets.size(); ++i)
    for (int r : plan.held[h.tets[i]])
      if (r != rank) nb[r].shared_tets.push_back(int(i));
  std::vector<Neighbour> out;
  for (int r = 0; r < size; ++r)
    if (r != rank && (!nb[r].send_nodes.empty() || !nb[r].recv_nodes.empty() || !nb[r].shared_tets.empty()))
      out.push_back(std::move(nb[r]));
  return out;
}

}  // namespace

RankModel extract_rank(const Model& g, const PartitionPlan& plan, int rank, const PieceIds& ids) {
  const int nt = int(g.tet_nodes.size()), nn = int(g.X.size()), nc = int(g.ce6_nodes.size());
  const bool piece = ids.tets > 0;
  if (piece &&
      (ids.tet.size() != std::size_t(nt) || ids.node.size() != std::size_t(nn) || ids.ce6.size() != std::size_t(nc)))
    throw RunError("partition: a model piece whose global ids do not match its arrays");
  const int size = plan.size;
  if (rank < 0 || rank >= size || int(plan.part.size()) != nt)
    throw InputError("partition: rank " + std::to_string(rank) + " of a partition into " + std::to_string(size) +
                     " parts, or a plan of another model");
  RankModel out;
  Decomposition& dd = out.dd;
  dd.rank = rank;
  dd.size = size;
  dd.reach = plan.reach;
  dd.global_nodes = piece ? ids.nodes : nn;
  dd.global_tets = piece ? ids.tets : nt;
  dd.global_ce6 = piece ? ids.ce6s : nc;

  const HeldParts h = select_held(g, plan, rank);
  Model& m = out.model;
  cut_elements(g, h, m);
  cut_node_groups(g, plan.node_owner, rank, h, m);
  copy_model_scalars(g, rank, size, m);
  // The global colourings, restricted: each node then receives its element forces in the same
  // order as on one rank, so the sums agree bit for bit.
  m.tet_colours = restrict_colouring(g.tet_colours, h.tet_local);
  m.ce6_colours = restrict_colouring(g.ce6_colours, h.ce6_local);

  set_ownership(g, plan, h, ids, piece, dd);
  dd.neighbours = halo_neighbours(plan, rank, h);
  return out;
}

namespace {

/// Every field of a decomposition and of a model, in file order, for one visitor: f(value)
/// writes or reads it (so the writer and the reader cannot disagree on the layout).
template <class F, class D>
void decomposition_fields(F&& f, D& d) {
  f(d.rank), f(d.size), f(d.reach), f(d.global_nodes), f(d.global_tets), f(d.global_ce6);
  f(d.node_global), f(d.tet_global), f(d.ce6_global), f(d.node_owned), f(d.tet_owned), f(d.ce6_owned);
}
template <class F, class M>
void model_fields(F&& f, M& m) {
  f(m.X), f(m.mass), f(m.node_vertex), f(m.tet_nodes), f(m.tet_input), f(m.tet_Xinv), f(m.tet_V0), f(m.tet_eta);
  f(m.tet_colours.order), f(m.tet_colours.offsets);
  f(m.ce6_nodes), f(m.ce6_tets), f(m.ce6_h), f(m.ce6_colours.order), f(m.ce6_colours.offsets);
  f(m.surface_faces), f(m.surface_tet), f(m.platen_nodes), f(m.platen_node_area), f(m.platen_node_h);
  f(m.top_nodes), f(m.bottom_nodes), f(m.lateral_nodes);
  f(m.box_min), f(m.box_max), f(m.axis_point), f(m.height0), f(m.area0), f(m.line_loaded), f(m.min_altitude);
  f(m.mean_edge), f(m.source), f(m.surface_conditions), f(m.node_conditions), f(m.condition_axis);
  f(m.tet_material), f(m.ce6_law), f(m.ce6_strength), f(m.tet_stiffness), f(m.tet_joint);
  f(m.node_history), f(m.tet_history), f(m.tet_group), f(m.tet_stage);
}

constexpr std::uint64_t kRankFileMagic = 0x4644454d52414e4bull;  // "FDEMRANK"

}  // namespace

void Decomposition::save(CheckpointOut& o) const {
  decomposition_fields([&](const auto& v) { o.put(v); }, *this);
  o.put(std::uint64_t(neighbours.size()));
  for (const Neighbour& n : neighbours) {
    o.put(n.rank);
    o.put(n.send_nodes);
    o.put(n.recv_nodes);
    o.put(n.shared_tets);
  }
}

void Decomposition::load(CheckpointIn& in) {
  decomposition_fields([&](auto& v) { in.get(v); }, *this);
  std::uint64_t k = 0;
  in.get(k);
  if (k > std::uint64_t(size)) in.mismatch("more neighbours than ranks");
  neighbours.resize(k);
  for (Neighbour& n : neighbours) {
    in.get(n.rank);
    in.get(n.send_nodes);
    in.get(n.recv_nodes);
    in.get(n.shared_tets);
  }
}

std::uint64_t model_key(const Scene& s) {
  const MeshSpec& g = s.mesh;
  const Material& a = s.material();
  const real v[] = {g.diameter,
                    g.height,
                    g.size.x,
                    g.size.y,
                    g.size.z,
                    g.element_size,
                    g.min_element_size,
                    g.scale,
                    a.density,
                    a.youngs_modulus,
                    a.poisson_ratio,
                    s.solver.mass_scaling,
                    s.solver.damping_scale,
                    real(s.fracture.everywhere)};
  std::uint64_t h = fnv1a64(v, sizeof v);
  for (const auto& b : s.fracture.boxes) {
    const real c[] = {b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z};
    h = fnv1a64(c, sizeof c, h);
  }
  // Each tet's material sets its mass and damping; each CE6's law is a material's or an interface's.
  if (s.materials.size() > 1 || !s.interfaces.empty()) {
    for (const Material& m : s.materials) {
      const real c[] = {m.density, m.youngs_modulus, m.poisson_ratio, m.tensile_strength};
      h = fnv1a64(c, sizeof c, h);
      std::string w = m.name;
      for (const std::string& g : m.groups) w += "|" + g;
      h = fnv1a64(w.data(), w.size() + 1, h);
    }
    for (const MaterialInterface& f : s.interfaces) {
      const std::string w = f.between[0] + "|" + f.between[1];
      h = fnv1a64(w.data(), w.size() + 1, h);
    }
  }
  // Excavation stages mark their tets.
  for (const ExcavationStage& e : s.excavation) h = fnv1a64(e.group.data(), e.group.size() + 1, h);
  // Joints add CE6s on their surfaces, and mark the tets beside them.
  for (const Joint& j : s.joints) {
    std::string w = j.name;
    for (const std::string& g : j.surfaces) w += "|" + g;
    h = fnv1a64(w.data(), w.size() + 1, h);
    h = fnv1a64(&j.law.friction_rock, sizeof(real), h);
  }
  // A heterogeneous material's draws are part of the model.
  for (const Material& m : s.materials)
    if (m.heterogeneity.on()) {
      const real c[] = {real(m.heterogeneity.distribution), m.heterogeneity.modulus, m.heterogeneity.deviation,
                        real(m.heterogeneity.seed), real(m.heterogeneity.youngs_modulus)};
      h = fnv1a64(c, sizeof c, h);
    }
  // The conditions mark faces and nodes, and whether a velocity is zero decides their conflicts
  // (model/conditions.cpp); their values are read at the run.
  for (const BoundaryCondition& c : s.conditions) {
    const int moving = (c.velocity.x != 0) | (c.velocity.y != 0) << 1 | (c.velocity.z != 0) << 2;
    const std::string w =
        c.surface + "|" + name_of(c.type) + "|" + std::to_string(c.components) + "|" + std::to_string(moving);
    h = fnv1a64(w.data(), w.size(), h);
  }
  // (A mesh read from a file has the empty word, as it had when the shape was a string.)
  const std::string words = std::string(g.generated() ? name_of(g.shape) : "") + "|" + g.file;
  return fnv1a64(words.data(), words.size(), h);
}

void put_rank_model(CheckpointOut& o, const RankModel& rm, std::uint64_t key) {
  o.put(kRankFileMagic);
  o.put(key);
  model_fields([&](const auto& v) { o.put(v); }, rm.model);
  rm.dd.save(o);
}

void write_rank_file(const std::string& path, const RankModel& rm, std::uint64_t key) {
  CheckpointFile file(path, CheckpointKind::rank_file);
  put_rank_model(file.out(), rm, key);
  file.commit();
}

RankModel read_rank_file(const std::string& path, std::uint64_t key) {
  CheckpointIn in = read_checkpoint(path, CheckpointKind::rank_file);
  RankModel rm = get_rank_model(in, key);
  in.finish();
  return rm;
}

RankModel get_rank_model(CheckpointIn& in, std::uint64_t key) {
  const std::string& path = in.file();
  std::uint64_t magic = 0, file_key = 0;
  in.get(magic);
  if (magic != kRankFileMagic)
    throw InputError(path + ": not a rank file of fdem partition. Fix: write the rank files with fdem partition");
  in.get(file_key);
  if (file_key != key)
    throw InputError(path +
                     ": partitioned from another mesh, material, mass scaling, damping or fracture regions "
                     "than this scene's. Fix: run fdem partition again with this scene");
  RankModel rm;
  Model& m = rm.model;
  model_fields([&](auto& v) { in.get(v); }, m);
  rm.dd.load(in);
  // Indices must stay inside their arrays (a damaged or hand-edited file must not crash the run).
  const std::size_t nn = m.X.size(), nt = m.tet_nodes.size();
  auto bad = [&](const char* what) {
    throw InputError(path + ": inconsistent rank file (" + std::string(what) +
                     "). Fix: write the rank files again with fdem partition");
  };
  if (m.mass.size() != nn || m.node_vertex.size() != nn || rm.dd.node_global.size() != nn ||
      rm.dd.node_owned.size() != nn || rm.dd.tet_global.size() != nt || rm.dd.tet_owned.size() != nt ||
      m.tet_Xinv.size() != nt || m.tet_V0.size() != nt || m.tet_eta.size() != nt || m.tet_material.size() != nt ||
      m.ce6_tets.size() != m.ce6_nodes.size() || m.ce6_h.size() != m.ce6_nodes.size() ||
      m.ce6_law.size() != m.ce6_nodes.size() ||
      (!m.ce6_strength.empty() && m.ce6_strength.size() != m.ce6_nodes.size()) ||
      (!m.tet_stiffness.empty() && m.tet_stiffness.size() != nt) ||
      (!m.tet_joint.empty() && m.tet_joint.size() != nt) || (!m.tet_history.empty() && m.tet_history.size() != nt) ||
      (!m.tet_group.empty() && m.tet_group.size() != nt) || (!m.tet_stage.empty() && m.tet_stage.size() != nt) ||
      (!m.node_history.empty() && m.node_history.size() != nn) || rm.dd.ce6_owned.size() != m.ce6_nodes.size() ||
      (!m.surface_conditions.empty() && m.surface_conditions.size() != m.surface_faces.size()) ||
      (!m.node_conditions.empty() && m.node_conditions.size() != nn))
    bad("array sizes differ");
  for (const auto& q : m.tet_nodes)
    for (int n : q)
      if (n < 0 || std::size_t(n) >= nn) bad("a tet node out of range");
  for (const auto& q : m.ce6_nodes)
    for (int n : q)
      if (n < 0 || std::size_t(n) >= nn) bad("a CE6 node out of range");
  for (const auto& ab : m.ce6_tets)
    for (int t : ab)
      if (t < 0 || std::size_t(t) >= nt) bad("a CE6 tet out of range");
  for (const auto& q : m.surface_faces)
    for (int n : q)
      if (n < 0 || std::size_t(n) >= nn) bad("a surface node out of range");
  for (const auto* list : {&m.platen_nodes, &m.top_nodes, &m.bottom_nodes, &m.lateral_nodes})
    for (int n : *list)
      if (n < 0 || std::size_t(n) >= nn) bad("a node group entry out of range");
  for (const auto* c : {&m.tet_colours, &m.ce6_colours}) {
    const std::size_t n = c == &m.tet_colours ? nt : m.ce6_nodes.size();
    std::vector<char> seen(n, 0);
    for (int e : c->order) {
      if (e < 0 || std::size_t(e) >= n) bad("a colouring out of range");
      if (seen[e]++) bad("an element twice in a colouring");
    }
  }
  for (const Neighbour& nb : rm.dd.neighbours) {
    for (const auto* list : {&nb.send_nodes, &nb.recv_nodes})
      for (int n : *list)
        if (n < 0 || std::size_t(n) >= nn) bad("a halo node out of range");
    for (int t : nb.shared_tets)
      if (t < 0 || std::size_t(t) >= nt) bad("a shared tet out of range");
  }
  return rm;
}

}  // namespace fdem
