#include "partition/grow.hpp"

#include <algorithm>
#include <array>
#include <cstring>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "contact/broad_phase.hpp"
#include "core/error.hpp"
#include "io/checkpoint.hpp"
#include "partition/halo.hpp"
#include "partition/local_ids.hpp"

namespace fdem {
namespace {

/// Byte strings to every rank of comm and from every rank (out[r] goes to rank r; the result's
/// [r] came from rank r). Collective.
std::vector<std::string> exchange_all(MPI_Comm comm, const std::vector<std::string>& out) {
  const int size = size_of(comm);
  std::vector<std::uint64_t> n_out(size), n_in(size);
  for (int r = 0; r < size; ++r) n_out[r] = out[r].size();
  MPI_Alltoall(n_out.data(), 1, MPI_UINT64_T, n_in.data(), 1, MPI_UINT64_T, comm);
  std::vector<std::string> in(size);
  std::vector<MPI_Request> req;
  constexpr std::uint64_t kPiece = std::uint64_t(1) << 30;  // MPI counts are int
  constexpr int kTag = 110;
  for (int r = 0; r < size; ++r) {
    in[r].resize(n_in[r]);
    for (std::uint64_t at = 0; at < n_in[r]; at += kPiece) {
      req.emplace_back();
      MPI_Irecv(in[r].data() + at, int(std::min(kPiece, n_in[r] - at)), MPI_BYTE, r, kTag, comm, &req.back());
    }
  }
  for (int r = 0; r < size; ++r)
    for (std::uint64_t at = 0; at < n_out[r]; at += kPiece) {
      req.emplace_back();
      MPI_Isend(out[r].data() + at, int(std::min(kPiece, n_out[r] - at)), MPI_BYTE, r, kTag, comm, &req.back());
    }
  MPI_Waitall(int(req.size()), req.data(), MPI_STATUSES_IGNORE);
  return in;
}

bool overlap(const Aabb& a, const Aabb& b) {
  for (int d = 0; d < 3; ++d)
    if (a.lo[d] > b.hi[d] || b.lo[d] > a.hi[d]) return false;
  return true;
}

/// What a node brings along with a tet.
struct NodeRec {
  long id = 0;
  Vec3 X{0, 0, 0}, x{0, 0, 0}, v{0, 0, 0};
  real mass = 0;
  std::uint8_t groups = 0;  // 1 top, 2 bottom, 4 lateral
};
struct Ce6Rec {
  long id = 0, a = 0, b = 0;  // global ids of the CE6 and its tets (A side, B side)
  std::array<long, 6> nodes{};
  real h = 0;
  std::uint8_t law = 0;  // Model::ce6_law
  real strength = 1;     // Model::ce6_strength
  Ce6State state{};
};
struct TetRec {
  long id = 0;
  int input = 0;
  Mat3 Xinv{};
  real V0 = 0, eta = 0;
  Model::TetProperties props;
  std::uint8_t active = 0;
  std::vector<int> holders;  // every rank holding it once this growth is done, ascending
  std::array<long, 4> nodes{};
  std::vector<std::array<long, 3>> faces;  // its surface faces
};

/// This rank's tets boxed at the current positions (grown by half the reach), and their bounds.
struct OwnBoxes {
  std::vector<Aabb> box;  // per local tet; only the owned ones are set
  Aabb bounds;
};

OwnBoxes box_own_tets(const Model& m, const Decomposition& dd, const GhostStateNow& now, real half) {
  const int nt = int(m.tet_nodes.size());
  constexpr real kBig = std::numeric_limits<real>::max();
  OwnBoxes own{std::vector<Aabb>(nt), Aabb{{kBig, kBig, kBig}, {-kBig, -kBig, -kBig}}};
  for (int t = 0; t < nt; ++t) {
    if (!dd.tet_owned[t]) continue;
    const auto& q = m.tet_nodes[t];
    Aabb b{now.x[q[0]], now.x[q[0]]};
    for (int n : q)
      for (int d = 0; d < 3; ++d) b.lo[d] = std::min(b.lo[d], now.x[n][d]), b.hi[d] = std::max(b.hi[d], now.x[n][d]);
    for (int d = 0; d < 3; ++d) {
      b.lo[d] -= half, b.hi[d] += half;
      own.bounds.lo[d] = std::min(own.bounds.lo[d], b.lo[d]), own.bounds.hi[d] = std::max(own.bounds.hi[d], b.hi[d]);
    }
    own.box[t] = b;
  }
  return own;
}

/// The boxes of own tets for each rank whose bounds they reach into, and those tets (the shell).
struct BoxOffer {
  std::vector<int> shell;        // own tets whose boxes went somewhere
  std::vector<std::string> out;  // per rank: (global id, box) of each tet sent there
};

BoxOffer offer_boxes(const Decomposition& dd, const std::vector<Aabb>& box, const std::vector<Aabb>& all_bounds) {
  const int rank = dd.rank, size = dd.size, nt = int(box.size());
  BoxOffer offer;
  std::vector<CheckpointOut> o(size);
  for (int t = 0; t < nt; ++t) {
    if (!dd.tet_owned[t]) continue;
    bool sent = false;
    for (int r = 0; r < size; ++r)
      if (r != rank && overlap(box[t], all_bounds[r])) o[r].put(dd.tet_global[t]), o[r].put(box[t]), sent = true;
    if (sent) offer.shell.push_back(t);
  }
  offer.out.resize(size);
  for (int r = 0; r < size; ++r) offer.out[r] = o[r].payload();
  return offer;
}

/// The shell's boxes, then every received box with its tet's global id and the rank it came from.
struct Candidates {
  std::vector<Aabb> boxes;
  std::vector<long> id;   // per received box (after the shell's)
  std::vector<int> from;  // per received box
};

Candidates gather_candidate_boxes(const std::vector<std::string>& in, const std::vector<Aabb>& box,
                                  const std::vector<int>& shell) {
  Candidates cand;
  for (int t : shell) cand.boxes.push_back(box[t]);
  for (int r = 0; r < int(in.size()); ++r) {
    CheckpointIn rd(in[r], "the tet boxes from rank " + std::to_string(r));
    while (rd.remaining() > 0) {
      long g = 0;
      Aabb b;
      rd.get(g), rd.get(b);
      cand.boxes.push_back(b), cand.id.push_back(g), cand.from.push_back(r);
    }
  }
  return cand;
}

/// Per owner rank: the sorted, unique ids of the received tets whose boxes overlap a shell box
/// and that this rank does not hold yet.
std::vector<std::string> request_ghosts(const Candidates& cand, int shell_size, const LocalIds& tets, int size) {
  std::vector<int> ids(cand.boxes.size());
  for (std::size_t i = 0; i < ids.size(); ++i) ids[i] = int(i);
  std::vector<int> received(cand.boxes.size(), 0);  // 0: own shell box, 1: received
  std::fill(received.begin() + shell_size, received.end(), 1);
  std::vector<std::array<int, 2>> pairs;
  find_box_pairs(cand.boxes, ids, 0, pairs, nullptr, 64, &received);
  std::vector<std::vector<long>> want(size);
  const int ns = shell_size;
  for (const auto& p : pairs)  // (min, max): an own box and a received one
    if (tets.find(cand.id[p[1] - ns]) < 0) want[cand.from[p[1] - ns]].push_back(cand.id[p[1] - ns]);
  std::vector<std::string> ask(size);
  for (int r = 0; r < size; ++r) {
    std::sort(want[r].begin(), want[r].end());
    want[r].erase(std::unique(want[r].begin(), want[r].end()), want[r].end());
    CheckpointOut w;
    w.put(want[r]);
    ask[r] = w.payload();
  }
  return ask;
}

/// Own tet -> the ranks asking for it; a request for a tet this rank does not own is an error.
std::map<long, std::vector<int>> read_requests(const std::vector<std::string>& asked, const Decomposition& dd,
                                               const LocalIds& tets) {
  std::map<long, std::vector<int>> new_holders;
  for (int r = 0; r < int(asked.size()); ++r) {
    CheckpointIn rd(asked[r], "the contact-ghost requests of rank " + std::to_string(r));
    std::vector<long> asked_ids;
    rd.get(asked_ids);
    for (long g : asked_ids) {
      const int t = tets.find(g);
      if (t < 0 || !dd.tet_owned[t])
        throw RunError("contact ghosts: rank " + std::to_string(r) + " asked rank " + std::to_string(dd.rank) +
                       " for tet " + std::to_string(g) + ", which it does not own");
      new_holders[g].push_back(r);
    }
  }
  return new_holders;
}

/// What the owner writes into the records of the requested tets: the groups of their nodes,
/// and the CE6s and surface faces of each. The maps hold the requested tets only; their CE6s
/// and faces are found by one pass over the model's arrays, without a lookup in a map.
struct RecordIndex {
  std::unordered_map<int, std::uint8_t> groups;                // the requested tets' nodes: 1 top, 2 bottom, 4 lateral
  std::unordered_map<int, std::vector<int>> ce6_of, faces_of;  // the requested tets'
};

RecordIndex index_requested(const Model& m, const std::map<long, std::vector<int>>& new_holders, const LocalIds& tets) {
  RecordIndex ix;
  std::vector<char> asked(m.tet_nodes.size(), 0);
  for (const auto& [g, rs] : new_holders) {
    const int t = tets.at(g, "requested tet");
    asked[t] = 1, ix.ce6_of[t], ix.faces_of[t];
    for (int n : m.tet_nodes[t]) ix.groups[n];
  }
  for (auto [list, bit] : {std::pair{&m.top_nodes, 1}, {&m.bottom_nodes, 2}, {&m.lateral_nodes, 4}})
    for (int n : *list)
      if (auto it = ix.groups.find(n); it != ix.groups.end()) it->second |= std::uint8_t(bit);
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c)
    for (int t : m.ce6_tets[c])
      if (asked[t]) ix.ce6_of[t].push_back(int(c));
  for (std::size_t i = 0; i < m.surface_tet.size(); ++i)
    if (asked[m.surface_tet[i]]) ix.faces_of[m.surface_tet[i]].push_back(int(i));
  return ix;
}

/// One requested tet's record: the tet with its holders, its nodes, its CE6s and its surface faces.
void put_ghost_record(CheckpointOut& o, const Model& m, const Decomposition& dd, const GhostStateNow& now,
                      const RecordIndex& ix, long g, int t, const std::vector<int>& h) {
  const bool flags = !now.active.empty();
  o.put(g), o.put(m.tet_input[t]), o.put(m.tet_Xinv[t]), o.put(m.tet_V0[t]), o.put(m.tet_eta[t]);
  const Model::TetProperties p = m.tet_properties(t);
  o.put(p.material), o.put(p.stiffness), o.put(p.joint), o.put(p.history), o.put(p.group), o.put(p.stage);
  o.put(std::uint8_t(flags ? now.active[t] : 0)), o.put(h);
  for (int n : m.tet_nodes[t]) {
    o.put(dd.node_global[n]), o.put(m.X[n]), o.put(m.mass[n]), o.put(now.x[n]);
    o.put(now.v[n]), o.put(ix.groups.at(n));
  }
  const std::vector<int>& ce6s = ix.ce6_of.at(t);
  o.put(std::uint64_t(ce6s.size()));
  for (int c : ce6s) {
    o.put(dd.ce6_global[c]), o.put(dd.tet_global[m.ce6_tets[c][0]]), o.put(dd.tet_global[m.ce6_tets[c][1]]);
    for (int n : m.ce6_nodes[c]) o.put(dd.node_global[n]);
    o.put(m.ce6_h[c]), o.put(m.ce6_law[c]), o.put(m.ce6_strength.empty() ? real(1) : m.ce6_strength[c]);
    o.put(now.ce6_state(c));
  }
  const std::vector<int>& faces = ix.faces_of.at(t);
  o.put(std::uint64_t(faces.size()));
  for (int i : faces)
    for (int n : m.surface_faces[i]) o.put(dd.node_global[n]);
}

/// Holders now of the own tets asked for: this rank, the neighbours sharing it, those asking.
std::unordered_map<long, std::vector<int>> holders_before(const std::map<long, std::vector<int>>& new_holders,
                                                          const Decomposition& dd) {
  std::unordered_map<long, std::vector<int>> own_holders;
  for (const auto& [g, rs] : new_holders) own_holders[g] = {dd.rank};
  for (const Neighbour& nb : dd.neighbours)
    for (int t : nb.shared_tets)
      if (auto it = own_holders.find(dd.tet_global[t]); it != own_holders.end()) it->second.push_back(nb.rank);
  return own_holders;
}

/// Per rank: the records of the tets it asked for, then who holds each own tet it held already.
/// Adds the asking ranks to own_holders (sorted), which then lists the holders after growth.
std::vector<std::string> answer_requests(const Model& m, const Decomposition& dd, const GhostStateNow& now,
                                         const std::map<long, std::vector<int>>& new_holders, const LocalIds& tets,
                                         std::unordered_map<long, std::vector<int>>& own_holders) {
  const int rank = dd.rank, size = dd.size;
  const RecordIndex ix = index_requested(m, new_holders, tets);
  std::vector<CheckpointOut> rec(size), upd(size);
  std::vector<long> n_rec(size, 0), n_upd(size, 0);
  for (const auto& [g, asking] : new_holders) {
    std::vector<int>& h = own_holders[g];
    const std::vector<int> before = h;
    h.insert(h.end(), asking.begin(), asking.end());
    std::sort(h.begin(), h.end());
    for (int r : before)
      if (r != rank) upd[r].put(g), upd[r].put(h), ++n_upd[r];
    const int t = tets.at(g, "requested tet");
    for (int r : asking) {
      ++n_rec[r];
      put_ghost_record(rec[r], m, dd, now, ix, g, t, h);
    }
  }
  std::vector<std::string> answer(size);
  for (int r = 0; r < size; ++r) {
    CheckpointOut o;
    o.put(n_rec[r]);
    o.put(n_upd[r]);
    answer[r] = o.payload() + rec[r].payload() + upd[r].payload();
  }
  return answer;
}

/// The records and holder updates that arrived: tets sorted by global id, nodes and CE6s by id.
struct Arrivals {
  std::vector<TetRec> tets;
  std::map<long, NodeRec> nodes;
  std::map<long, Ce6Rec> ce6s;
  std::unordered_map<long, std::vector<int>> updates;  // held tet -> its holders now
};

void read_ghost_record(CheckpointIn& rd, Arrivals& a) {
  TetRec t;
  rd.get(t.id), rd.get(t.input), rd.get(t.Xinv), rd.get(t.V0), rd.get(t.eta), rd.get(t.props.material),
      rd.get(t.props.stiffness), rd.get(t.props.joint), rd.get(t.props.history), rd.get(t.props.group),
      rd.get(t.props.stage);
  rd.get(t.active), rd.get(t.holders);
  for (long& nid : t.nodes) {
    NodeRec nr;
    rd.get(nr.id), rd.get(nr.X), rd.get(nr.mass), rd.get(nr.x), rd.get(nr.v), rd.get(nr.groups);
    nid = nr.id;
    a.nodes.emplace(nr.id, nr);
  }
  std::uint64_t kc = 0;
  rd.get(kc);
  for (std::uint64_t j = 0; j < kc; ++j) {
    Ce6Rec c;
    rd.get(c.id), rd.get(c.a), rd.get(c.b);
    for (long& nid : c.nodes) rd.get(nid);
    rd.get(c.h), rd.get(c.law), rd.get(c.strength), rd.get(c.state);
    a.ce6s.emplace(c.id, c);
  }
  std::uint64_t kf = 0;
  rd.get(kf);
  t.faces.resize(kf);
  for (auto& f : t.faces)
    for (long& nid : f) rd.get(nid);
  a.tets.push_back(std::move(t));
}

Arrivals read_answers(const std::vector<std::string>& got) {
  Arrivals a;
  for (int r = 0; r < int(got.size()); ++r) {
    CheckpointIn rd(got[r], "the contact ghosts from rank " + std::to_string(r));
    long k_rec = 0, k_upd = 0;
    rd.get(k_rec), rd.get(k_upd);
    for (long k = 0; k < k_rec; ++k) read_ghost_record(rd, a);
    for (long k = 0; k < k_upd; ++k) {
      long g = 0;
      std::vector<int> h;
      rd.get(g), rd.get(h);
      a.updates[g] = std::move(h);
    }
    rd.finish();
  }
  std::sort(a.tets.begin(), a.tets.end(), [](const TetRec& x, const TetRec& y) { return x.id < y.id; });
  return a;
}

/// A position's exact bits, as a hash key (two nodes share a mesh vertex only at the same double).
struct PositionKey {
  std::array<std::uint64_t, 3> bits{};
  explicit PositionKey(const Vec3& p) { std::memcpy(bits.data(), &p, sizeof(bits)); }
  bool operator==(const PositionKey& o) const { return bits == o.bits; }
  struct Hash {
    std::size_t operator()(const PositionKey& k) const { return std::size_t(fnv1a64(k.bits.data(), sizeof(k.bits))); }
  };
};
static_assert(sizeof(Vec3) == sizeof(std::array<std::uint64_t, 3>), "a position is three doubles");

/// Appends the arrived nodes not held yet, in global order, and takes them into `nodes`.
void append_ghost_nodes(Model& m, Decomposition& dd, const std::map<long, NodeRec>& arrived, LocalIds& nodes,
                        GhostState& added) {
  const int nn = int(m.X.size());
  // Mesh vertices: a new node at the position of a held one shares its vertex (split nodes
  // keep their vertex's reference position). Only held nodes within the new ones' bounds are
  // looked up.
  std::unordered_map<PositionKey, int, PositionKey::Hash> vertex_at;  // -1: no node there yet
  constexpr real kBig = std::numeric_limits<real>::max();
  Aabb span{{kBig, kBig, kBig}, {-kBig, -kBig, -kBig}};
  for (const auto& [g, nr] : arrived)
    if (nodes.find(g) < 0) {
      vertex_at.emplace(PositionKey(nr.X), -1);
      for (int d = 0; d < 3; ++d)
        span.lo[d] = std::min(span.lo[d], nr.X[d]), span.hi[d] = std::max(span.hi[d], nr.X[d]);
    }
  int vertices = 0;
  for (int n = 0; n < nn; ++n) {
    vertices = std::max(vertices, m.node_vertex[n] + 1);
    if (!overlap(span, Aabb{m.X[n], m.X[n]})) continue;
    if (auto it = vertex_at.find(PositionKey(m.X[n])); it != vertex_at.end() && it->second < 0)
      it->second = m.node_vertex[n];
  }
  for (const auto& [g, nr] : arrived) {
    if (nodes.find(g) >= 0) continue;
    const int n = int(m.X.size());
    m.X.push_back(nr.X);
    m.mass.push_back(nr.mass);
    if (!m.node_conditions.empty()) m.node_conditions.push_back(0);  // (moved by its owner's halo)
    if (!m.node_history.empty()) m.node_history.push_back(0);        // (its owner counts it)
    int& vertex = vertex_at.at(PositionKey(nr.X));
    if (vertex < 0) vertex = vertices++;
    m.node_vertex.push_back(vertex);
    if (nr.groups & 1) m.top_nodes.push_back(n);
    if (nr.groups & 2) m.bottom_nodes.push_back(n);
    if (nr.groups & 4) m.lateral_nodes.push_back(n);
    dd.node_global.push_back(g);
    dd.node_owned.push_back(0);
    added.x.push_back(nr.x);
    added.v.push_back(nr.v);
  }
  nodes.extend();
}

/// A held tet whose holders changed (local id, every rank holding it now, ascending).
struct NewHolders {
  int tet;
  std::vector<int> ranks;
};

/// The held tets whose holders the owners told (`updates`) or this rank answered for
/// (`own_holders`), in local ids. RunError for a tet this rank does not hold.
std::vector<NewHolders> held_with_new_holders(const Decomposition& dd, const LocalIds& tets,
                                              std::unordered_map<long, std::vector<int>>& updates,
                                              std::unordered_map<long, std::vector<int>>& own_holders) {
  std::vector<NewHolders> changed;
  for (auto* given : {&updates, &own_holders})
    for (auto& [g, h] : *given) {
      const int t = tets.find(g);
      if (t < 0)
        throw RunError("contact ghosts: rank " + std::to_string(dd.rank) + " was told who holds tet " +
                       std::to_string(g) + ", which it does not hold");
      changed.push_back({t, std::move(h)});
    }
  return changed;
}

/// Appends the arrived tets (in global order) with their faces, takes them into `tets`, and
/// their holders into `changed`.
void append_ghost_tets(std::vector<TetRec>& arrived, const LocalIds& nodes, LocalIds& tets,
                       std::vector<NewHolders>& changed, Model& gm, Decomposition& gd, GhostState& added) {
  for (TetRec& t : arrived) {
    const int i = int(gm.tet_nodes.size());
    std::array<int, 4> q;
    for (int k = 0; k < 4; ++k) q[k] = nodes.at(t.nodes[k], "node");
    append_tet(gm, q, t.input, t.Xinv, t.V0, t.eta, t.props);
    gd.tet_global.push_back(t.id);
    gd.tet_owned.push_back(0);
    changed.push_back({i, std::move(t.holders)});
    added.active.push_back(t.active);
    for (const auto& f : t.faces) {
      gm.surface_faces.push_back({nodes.at(f[0], "node"), nodes.at(f[1], "node"), nodes.at(f[2], "node")});
      gm.surface_tet.push_back(i);
      // A contact ghost's nodes move with their owner's halo: its faces need no condition.
      if (!gm.surface_conditions.empty()) gm.surface_conditions.push_back(0);
    }
  }
  tets.extend();
}

/// Appends the arrived CE6s not held yet whose two tets are both held now, in global order.
void append_ghost_ce6s(const std::map<long, Ce6Rec>& arrived, const LocalIds& nodes, const LocalIds& tets, Model& gm,
                       Decomposition& gd, GhostState& added) {
  const LocalIds ce6s(gd.ce6_global);
  for (const auto& [g, c] : arrived) {  // a CE6 whose two tets are both held now
    if (ce6s.find(g) >= 0 || tets.find(c.a) < 0 || tets.find(c.b) < 0) continue;
    std::array<int, 6> q;
    for (int k = 0; k < 6; ++k) q[k] = nodes.at(c.nodes[k], "node");
    gm.ce6_nodes.push_back(q);
    gm.ce6_tets.push_back({tets.find(c.a), tets.find(c.b)});
    gm.ce6_h.push_back(c.h);
    gm.ce6_law.push_back(c.law);
    if (!gm.ce6_strength.empty()) gm.ce6_strength.push_back(c.strength);
    gd.ce6_global.push_back(g);
    gd.ce6_owned.push_back(0);
    added.ce6.push_back(c.state);
  }
}

/// The neighbours after growth: node lists as before (the new ghosts are never computed here);
/// shared tets as before, but for the tets in `changed`, listed with the ranks holding them now.
/// The old lists are in global order (as every rank model and every growth makes them), so the
/// changes merge into them in order. Costs the shared lists and the changes, not the model.
std::vector<Neighbour> grown_neighbours(const Decomposition& dd, const std::vector<NewHolders>& changed) {
  const int rank = dd.rank, size = dd.size;
  auto by_global = [&](int a, int b) { return dd.tet_global[a] < dd.tet_global[b]; };
  std::unordered_set<int> moved;  // the changed tets: out of the old lists, into `more`
  std::vector<std::vector<int>> more(size);
  for (const NewHolders& c : changed) {
    moved.insert(c.tet);
    for (int r : c.ranks)
      if (r != rank) more[r].push_back(c.tet);
  }
  std::vector<Neighbour> nb(size);
  for (int r = 0; r < size; ++r) nb[r].rank = r;
  for (const Neighbour& old : dd.neighbours) {
    Neighbour& n = nb[old.rank];
    n.send_nodes = old.send_nodes;
    n.recv_nodes = old.recv_nodes;
    for (int t : old.shared_tets)
      if (!moved.count(t)) n.shared_tets.push_back(t);
  }
  for (int r = 0; r < size; ++r) {
    if (more[r].empty()) continue;
    std::sort(more[r].begin(), more[r].end(), by_global);
    std::vector<int> merged;
    merged.reserve(nb[r].shared_tets.size() + more[r].size());
    std::merge(nb[r].shared_tets.begin(), nb[r].shared_tets.end(), more[r].begin(), more[r].end(),
               std::back_inserter(merged), by_global);
    nb[r].shared_tets = std::move(merged);
  }
  std::vector<Neighbour> out;
  for (int r = 0; r < size; ++r)
    if (r != rank && (!nb[r].send_nodes.empty() || !nb[r].recv_nodes.empty() || !nb[r].shared_tets.empty()))
      out.push_back(std::move(nb[r]));
  return out;
}

}  // namespace

GhostGrowth grow_contact_ghosts(MPI_Comm comm, Model& m, Decomposition& dd, const GhostStateNow& now) {
  const int size = dd.size;
  const int nn = int(m.X.size()), nc = int(m.ce6_nodes.size());
  if (size_of(comm) != size || int(now.x.size()) != nn || int(now.v.size()) != nn || int(now.ce6_damage.size()) != nc ||
      int(now.ce6_anchors.size()) != nc)
    throw RunError("contact ghosts: the state does not match the rank model");

  // 1. This rank's tets, boxed at the current positions and grown by half the reach (two boxes
  // overlap when the tets come within the reach), and the bounds of all of them.
  const OwnBoxes own = box_own_tets(m, dd, now, 0.5 * dd.reach);
  std::vector<Aabb> all_bounds(size);
  MPI_Allgather(&own.bounds, int(sizeof(Aabb)), MPI_BYTE, all_bounds.data(), int(sizeof(Aabb)), MPI_BYTE, comm);

  // 2. Each rank gets the boxes of this rank's tets that reach into its bounds.
  const BoxOffer offer = offer_boxes(dd, own.box, all_bounds);
  const std::vector<std::string> in = exchange_all(comm, offer.out);

  // 3. The received tets whose boxes overlap one of this rank's: the contact ghosts it needs.
  LocalIds tets(dd.tet_global);
  const Candidates cand = gather_candidate_boxes(in, own.box, offer.shell);
  // Requests, every rank's to every rank (requests for tets a rank does not own are errors).
  const std::vector<std::string> asked = exchange_all(comm, request_ghosts(cand, int(offer.shell.size()), tets, size));

  // 4. The owner's answer: each requested tet's record for the rank that asked, and to every
  // other rank holding it already, who holds it now.
  const std::map<long, std::vector<int>> new_holders = read_requests(asked, dd, tets);
  GhostGrowth out;
  if (sum_over_ranks(comm, double(new_holders.size())) == 0) return out;  // no rank lacks a tet: m and dd unchanged
  std::unordered_map<long, std::vector<int>> own_holders = holders_before(new_holders, dd);
  const std::vector<std::string> got = exchange_all(comm, answer_requests(m, dd, now, new_holders, tets, own_holders));

  // 5. The records and the holder updates that arrived.
  Arrivals arrived = read_answers(got);

  // 6. The rank model grows in place: the new nodes, tets, CE6s and faces appended, each in
  // global order. The model is not copied, and nothing is looked up in a map of all of it.
  std::vector<NewHolders> changed = held_with_new_holders(dd, tets, arrived.updates, own_holders);
  LocalIds nodes(dd.node_global);
  append_ghost_nodes(m, dd, arrived.nodes, nodes, out.added);
  append_ghost_tets(arrived.tets, nodes, tets, changed, m, dd, out.added);
  append_ghost_ce6s(arrived.ce6s, nodes, tets, m, dd, out.added);
  dd.neighbours = grown_neighbours(dd, changed);
  out.added_tets = long(arrived.tets.size());
  out.added_total = long(sum_over_ranks(comm, double(out.added_tets)));
  return out;
}

}  // namespace fdem
