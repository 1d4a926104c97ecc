// A restart on another rank count: each saved rank's part of a checkpoint, in global numbering,
// taken into this rank's layout (docs/restart.md, "Another rank count").
#include <mpi.h>

#include <algorithm>
#include <map>
#include <string>
#include <utility>

#include "io/checkpoint.hpp"
#include "solver/solver.hpp"

namespace fdem {

void SavedLayout::save(CheckpointOut& out) const {
  out.put(rank), out.put(size), out.put(nodes), out.put(tets), out.put(ce6s);
  out.put(node), out.put(tet), out.put(ce6), out.put(node_owned), out.put(tet_owned), out.put(ce6_owned);
  out.put(platen_node), out.put(prescribed_node), out.put(face), out.put(face_condition), out.put(faces_kept);
  out.put(model);
}

void SavedLayout::load(CheckpointIn& in) {
  in.get(rank), in.get(size), in.get(nodes), in.get(tets), in.get(ce6s);
  in.get(node), in.get(tet), in.get(ce6), in.get(node_owned), in.get(tet_owned), in.get(ce6_owned);
  in.get(platen_node), in.get(prescribed_node), in.get(face), in.get(face_condition), in.get(faces_kept);
  in.get(model);
  auto sized = [](const auto& v, long n) { return v.empty() || long(v.size()) == n; };
  bool ok = rank >= 0 && rank < size && nodes >= 0 && tets >= 0 && ce6s >= 0;
  ok = ok && sized(node, nodes) && sized(node_owned, nodes) && sized(tet, tets) && sized(tet_owned, tets);
  ok = ok && sized(ce6, ce6s) && sized(ce6_owned, ce6s) && faces_kept <= face.size();
  ok = ok && (face_condition.empty() || face_condition.size() == face.size());
  for (int n : platen_node) ok = ok && n >= 0 && n < nodes;
  for (int n : prescribed_node) ok = ok && n >= 0 && n < nodes;
  for (const auto& f : face)
    for (int n : f) ok = ok && n >= 0 && n < nodes;
  if (!ok) in.mismatch("a rank layout that does not add up");
}

namespace {

/// Global -> local ids of one kind on this rank (identity on one rank).
class SavedLocalIds {
 public:
  SavedLocalIds() = default;
  SavedLocalIds(const std::vector<long>& global, std::size_t count) : count_(long(count)) {
    for (std::size_t i = 0; i < global.size(); ++i) sorted_.push_back({global[i], int(i)});
    std::sort(sorted_.begin(), sorted_.end());
  }
  int find(long g) const {
    if (sorted_.empty()) return g >= 0 && g < count_ ? int(g) : -1;
    const auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::pair<long, int>{g, -1});
    return it != sorted_.end() && it->first == g ? it->second : -1;
  }

 private:
  long count_ = 0;
  std::vector<std::pair<long, int>> sorted_;
};

/// A saved contact pair in global numbering, with what it carries.
struct SavedPair {
  long joint = -1;          // the CE6 joining the two tets (-1: none)
  bool from_owner = false;  // saved by the owner of tet a (whose copy the run accounts)
  PairHistory history;
  ContactEval eval;
  std::array<Vec3, 8> force;
};

/// A loaded face's key: its global nodes, sorted, and its condition (-1: the confinement's). A
/// face under the confinement and a condition is listed once for each.
using FaceKey = std::array<long, 4>;
FaceKey face_key(const SavedLayout& l, std::size_t i) {
  const std::array<int, 3>& f = l.face[i];
  FaceKey k{l.global_node(f[0]), l.global_node(f[1]), l.global_node(f[2]),
            l.face_condition.empty() ? -1L : long(l.face_condition[i])};
  std::sort(k.begin(), k.begin() + 3);
  return k;
}
/// The face's lowest node in global numbering: its owner holds every tet around that node, so
/// the face, and takes the face's state.
int lowest_node(const SavedLayout& l, std::size_t i) {
  const std::array<int, 3>& f = l.face[i];
  return *std::min_element(f.begin(), f.end(), [&](int a, int b) { return l.global_node(a) < l.global_node(b); });
}

}  // namespace

/// What a saved rank's file holds of the solver, read as it was saved.
struct SavedRankState {
  GhostGrowths growth;
  int excavated = 0;
  real relax_start = 0;
  std::vector<NodePush> push;
  SolverState state;
  Loads loads;
  EnergyLedger energy;
  ContactSet contacts;
};

struct Solver::SavedRanks {
  int next_rank = 0, size = 0;
  SavedLocalIds node, tet, ce6;
  std::map<FaceKey, int> face;  // loaded faces here, by key
  // Per loaded face here: the saved ranks' powers (W) and works (J) of it added up. Each rank
  // keeps its own part of a face's (over the nodes it owns); the new owner takes the sum.
  std::vector<real> face_power, face_work;
  std::vector<int> platen_of;                                                 // per node: its platen entry here, or -1
  long nodes = 0, tets = 0, ce6s = 0, faces = 0, platen = 0, prescribed = 0;  // set so far
  // The last evaluation's powers that each rank keeps of its own (the step's works begin with
  // them and are summed over the ranks): their sums, W, which rank 0 takes here.
  real contact_power = 0, pressure_power = 0, gravity_power = 0;
  std::map<std::pair<long, long>, SavedPair> pairs;  // by global tets (a < b), the builder's order
};

static void read_saved_rank_state(CheckpointIn& in, const SavedLayout& l, bool contact, int stages,
                                  SavedRankState& saved) {
  bool grown = false;
  in.get(saved.growth);
  in.get(grown);
  if (grown) get_rank_model(in, 0);  // (its ids are in the layout)
  in.get(saved.excavated);
  in.get(saved.relax_start);
  in.get(saved.push);
  std::uint64_t fingerprint = 0, fixed = 0;  // (of that rank's model: the layout's fingerprint stands for them)
  in.get(fingerprint);
  in.get(fixed);
  // Sized as that rank saved them, so each part reads as it does on a restart of its own.
  saved.state.x.resize(l.nodes), saved.state.v.resize(l.nodes), saved.state.f.resize(l.nodes);
  saved.state.ce6.assign_intact(l.ce6s);
  saved.state.ce6_broke.resize(l.ce6s);
  saved.loads.platens.anchor.resize(l.platen_node.size());
  saved.loads.prescribed.node.resize(l.prescribed_node.size());
  saved.loads.surface.face_force.resize(l.face.size());
  saved.loads.surface.face_power.resize(l.faces_kept);
  saved.contacts = ContactSet(contact, l.tets, l.size > 1 ? l.nodes : 0);
  saved.state.load(in);
  saved.loads.load(in, false);
  saved.energy.load(in);
  saved.contacts.load(in);
  if (saved.excavated < 0 || saved.excavated > stages || (!saved.push.empty() && long(saved.push.size()) != l.nodes))
    in.mismatch(std::to_string(saved.excavated) + " excavation stages done, with forces on " +
                std::to_string(saved.push.size()) + " nodes");
}

SavedLayout Solver::saved_layout() const {
  const Decomposition& dd = layout_.dd;
  SavedLayout l;
  l.rank = dd.rank, l.size = dd.size;
  l.nodes = long(model_.X.size()), l.tets = long(model_.tet_nodes.size()), l.ce6s = long(model_.ce6_nodes.size());
  if (dd.distributed()) {
    l.node = dd.node_global, l.tet = dd.tet_global, l.ce6 = dd.ce6_global;
    l.node_owned = layout_.own_node, l.tet_owned = layout_.own_tet, l.ce6_owned = layout_.own_ce6;
  }
  l.platen_node = model_.platen_nodes;
  l.prescribed_node = loads_.prescribed.node;
  l.face = loads_.surface.faces;
  l.face_condition = loads_.surface.face_condition;
  l.faces_kept = loads_.surface.face_power.size();
  l.model = model_fp_;
  return l;
}

std::uint64_t Solver::whole_model_fingerprint() const {
  // A sum of per-entity hashes: the same whatever rank owns each entity.
  const Model& m = model_;
  const Decomposition& dd = layout_.dd;
  auto id = [](const std::vector<long>& g, int i) { return g.empty() ? long(i) : g[std::size_t(i)]; };
  std::uint64_t sum = 0;
  for (int n = 0; n < int(m.X.size()); ++n) {
    if (!layout_.own_node[n]) continue;
    const long g = id(dd.node_global, n);
    sum += fnv1a64(&m.X[n], sizeof(Vec3), fnv1a64(&g, sizeof g));
  }
  for (int t = 0; t < int(m.tet_nodes.size()); ++t) {
    if (!layout_.own_tet[t]) continue;
    const real stiffness = m.tet_stiffness.empty() ? real(1) : m.tet_stiffness[t];
    const long v[] = {id(dd.tet_global, t),
                      id(dd.node_global, m.tet_nodes[t][0]),
                      id(dd.node_global, m.tet_nodes[t][1]),
                      id(dd.node_global, m.tet_nodes[t][2]),
                      id(dd.node_global, m.tet_nodes[t][3]),
                      long(m.tet_material[t]),
                      m.tet_joint.empty() ? 0L : long(m.tet_joint[t]),
                      m.tet_stage.empty() ? 0L : long(m.tet_stage[t])};
    sum += fnv1a64(&stiffness, sizeof stiffness, fnv1a64(v, sizeof v));
  }
  for (int c = 0; c < int(m.ce6_nodes.size()); ++c) {
    if (!layout_.own_ce6[c]) continue;
    const real strength = m.ce6_strength.empty() ? real(1) : m.ce6_strength[c];
    long v[8] = {id(dd.ce6_global, c), long(m.ce6_law[c])};
    for (int i = 0; i < 6; ++i) v[2 + i] = id(dd.node_global, m.ce6_nodes[c][i]);
    sum += fnv1a64(&strength, sizeof strength, fnv1a64(v, sizeof v));
  }
  if (layout_.distributed()) MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_UINT64_T, MPI_SUM, layout_.comm);
  const long counts[] = {dd.distributed() ? dd.global_nodes : long(m.X.size()),
                         dd.distributed() ? dd.global_tets : long(m.tet_nodes.size()),
                         dd.distributed() ? dd.global_ce6 : long(m.ce6_nodes.size())};
  return scene_physics_hash(scene_, dt_, fnv1a64(counts, sizeof counts, fnv1a64(&sum, sizeof sum)));
}

void Solver::check_saved_rank(CheckpointIn& in) const {
  SavedLayout l;
  l.load(in);
  if (l.model != model_fp_) in.mismatch("the mesh, the material, the loading, mass scaling or the time step differ");
  SavedRankState saved;
  read_saved_rank_state(in, l, contacts.enabled(), int(scene_.excavation.size()), saved);
}

EntityMap Solver::read_saved_rank(CheckpointIn& in) {
  if (!saved_) {
    saved_ = std::make_shared<SavedRanks>();
    SavedRanks& g = *saved_;
    const Decomposition& dd = layout_.dd;
    g.node = SavedLocalIds(dd.node_global, model_.X.size());
    g.tet = SavedLocalIds(dd.tet_global, model_.tet_nodes.size());
    g.ce6 = SavedLocalIds(dd.ce6_global, model_.ce6_nodes.size());
  }
  SavedRanks& g = *saved_;
  SavedLayout l;
  l.load(in);
  if (l.model != model_fp_) in.mismatch("the mesh, the material, the loading, mass scaling or the time step differ");
  if (l.rank != g.next_rank || (g.size > 0 && l.size != g.size))
    in.mismatch("rank " + std::to_string(l.rank) + " of " + std::to_string(l.size) + " where rank " +
                std::to_string(g.next_rank) + " was due");
  g.size = l.size;
  SavedRankState saved;
  read_saved_rank_state(in, l, contacts.enabled(), int(scene_.excavation.size()), saved);
  EntityMap map;
  map.node.assign(l.nodes, -1), map.tet.assign(l.tets, -1), map.ce6.assign(l.ce6s, -1);
  for (int n = 0; n < int(l.nodes); ++n)
    if (l.owns_node(n)) map.node[n] = g.node.find(l.global_node(n));
  for (int t = 0; t < int(l.tets); ++t)
    if (l.owns_tet(t)) map.tet[t] = g.tet.find(l.global_tet(t));
  for (int c = 0; c < int(l.ce6s); ++c)
    if (l.owns_ce6(c)) map.ce6[c] = g.ce6.find(l.global_ce6(c));
  take_saved_state(l, map, saved);
  ++g.next_rank;
  return map;
}

void Solver::take_saved_state(const SavedLayout& l, const EntityMap& map, SavedRankState& saved) {
  SavedRanks& g = *saved_;
  if (l.rank == 0) {  // the values every rank holds alike
    state.step = saved.state.step, state.time = saved.state.time;
    growth_ = saved.growth;
    excavated_ = saved.excavated;
    loads_.gravity.relax_start = saved.relax_start;
    if (excavated_ > 0) loads_.gravity.relax_time = scene_.excavation[excavated_ - 1].relax;
    PlatenLoad& p = loads_.platens;
    p.top_offset = saved.loads.platens.top_offset;
    p.force_top = saved.loads.platens.force_top, p.force_bottom = saved.loads.platens.force_bottom;
    loads_.surface.pressure = saved.loads.surface.pressure;
    CheckpointOut ledger;  // (the ledger's saved values; its floor and in-situ energies are this run's)
    saved.energy.save(ledger);
    CheckpointIn back(ledger.payload(), "the energy ledger");
    energy_.load(back);
    if (!saved.push.empty()) loads_.gravity.push.assign(model_.X.size(), NodePush{});
  }
  g.contact_power += saved.energy.p_contact;
  g.pressure_power += saved.loads.surface.power;
  g.gravity_power += saved.loads.gravity.power;
  const SolverState& s = saved.state;
  g.nodes += scatter_saved(s.x, map.node, state.x);
  scatter_saved(s.v, map.node, state.v);
  scatter_saved(s.f, map.node, state.f);
  g.ce6s += scatter_saved(s.ce6.damage, map.ce6, state.ce6.damage);
  scatter_saved(s.ce6.anchors, map.ce6, state.ce6.anchors);
  scatter_saved(s.ce6_broke, map.ce6, state.ce6_broke);
  if (!loads_.gravity.push.empty()) scatter_saved(saved.push, map.node, loads_.gravity.push);
  if (contacts.enabled())
    g.tets += scatter_saved(saved.contacts.tet_flags, map.tet, contacts.tet_flags);
  else
    for (int t : map.tet) g.tets += t >= 0;
  // Per entry of a load: its node's (or face's) entry here, from the rank that owns that node.
  if (g.platen_of.empty()) {
    g.platen_of.assign(model_.X.size(), -1);
    for (std::size_t i = 0; i < model_.platen_nodes.size(); ++i) g.platen_of[model_.platen_nodes[i]] = int(i);
  }
  const Loads& sl = saved.loads;
  for (std::size_t i = 0; i < l.platen_node.size(); ++i)
    if (const int n = map.node[l.platen_node[i]]; n >= 0 && g.platen_of[n] >= 0)
      loads_.platens.anchor[g.platen_of[n]] = sl.platens.anchor[i], ++g.platen;
  PrescribedVelocities& pv = loads_.prescribed;
  for (std::size_t i = 0; i < l.prescribed_node.size(); ++i)
    if (const int n = map.node[l.prescribed_node[i]]; n >= 0)
      if (const auto e = pv.slot.find(n); e != pv.slot.end())
        pv.reaction[e->second] = sl.prescribed.reaction[i], pv.work[e->second] = sl.prescribed.work[i], ++g.prescribed;
  take_saved_faces(l, saved.loads.surface);
  // Contact pairs, kept in global numbering until the contact ghosts are gathered here.
  const ContactSet& sc = saved.contacts;
  for (std::size_t k = 0; k < sc.pairs.size(); ++k) {
    const ContactPair& p = sc.pairs[k];
    const long a = l.global_tet(p.a), b = l.global_tet(p.b);
    if (g.tet.find(a) < 0 && g.tet.find(b) < 0) continue;
    const bool owner = l.owns_tet(p.a);
    auto [it, fresh] = g.pairs.try_emplace({a, b});
    if (!fresh && (it->second.from_owner || !owner)) continue;
    SavedPair& s = it->second;
    s.joint = p.joint >= 0 ? l.global_ce6(p.joint) : -1;
    s.from_owner = owner, s.history = sc.history[k], s.eval = sc.eval[k];
    for (int j = 0; j < 8; ++j) s.force[j] = sc.pair_force[8 * k + j];
  }
}

void Solver::take_saved_faces(const SavedLayout& l, const SurfaceLoads& saved) {
  SavedRanks& g = *saved_;
  SurfaceLoads& sf = loads_.surface;
  if (g.face.empty() && !sf.faces.empty()) {
    SavedLayout here;  // (this rank's numbering, for the faces' keys)
    if (layout_.distributed()) here.node = layout_.dd.node_global;
    here.face = sf.faces, here.face_condition = sf.face_condition;
    for (std::size_t i = 0; i < sf.faces.size(); ++i) g.face[face_key(here, i)] = int(i);
    g.face_power.assign(sf.face_power.size(), 0), g.face_work.assign(sf.face_work.size(), 0);
  }
  for (std::size_t i = 0; i < l.face.size(); ++i) {
    const auto here = g.face.find(face_key(l, i));
    if (here == g.face.end()) continue;
    const std::size_t j = std::size_t(here->second);
    if (i < l.faces_kept && j < g.face_power.size())
      g.face_power[j] += saved.face_power[i], g.face_work[j] += saved.face_work[i];
    if (!l.owns_node(lowest_node(l, i))) continue;  // (every holder computes the same force)
    sf.face_force[j] = saved.face_force[i];
    ++g.faces;
  }
}

void Solver::finish_saved_faces() {
  // A face's power and work go to the rank that owns its lowest node, zero to the others.
  SavedRanks& g = *saved_;
  SurfaceLoads& sf = loads_.surface;
  SavedLayout here;
  if (layout_.distributed()) here.node = layout_.dd.node_global, here.node_owned = layout_.own_node;
  here.face = sf.faces;
  for (std::size_t j = 0; j < sf.face_power.size(); ++j) {
    const bool mine = here.owns_node(lowest_node(here, j));
    sf.face_power[j] = mine ? g.face_power[j] : 0;
    sf.face_work[j] = mine ? g.face_work[j] : 0;
  }
}

void Solver::finish_saved_ranks() {
  SavedRanks& g = *saved_;
  const std::size_t platen = loads_.platens.anchor.size(), prescribed = loads_.prescribed.node.size();
  auto count = [](long got, std::size_t want, const char* what) {
    return long(want) == got ? std::string()
                             : std::to_string(want) + " " + what + " here, " + std::to_string(got) + " found; ";
  };
  const std::string missing =
      (g.next_rank != g.size ? "rank files " + std::to_string(g.next_rank) + " of " + std::to_string(g.size) + "; "
                             : "") +
      count(g.nodes, model_.X.size(), "nodes") + count(g.tets, model_.tet_nodes.size(), "tets") +
      count(g.ce6s, model_.ce6_nodes.size(), "CE6s") + count(g.platen, platen, "platen nodes") +
      count(g.prescribed, prescribed, "prescribed nodes") + count(g.faces, loads_.surface.faces.size(), "loaded faces");
  if (!missing.empty())
    throw InputError("the checkpoint's rank files do not cover the model (" + missing +
                     "). Fix: restart from a whole set of rank files of one step, of this scene");
  finish_saved_faces();
  const bool first = layout_.dd.rank == 0;
  energy_.p_contact = first ? g.contact_power : 0;
  loads_.surface.power = first ? g.pressure_power : 0;
  loads_.gravity.power = first ? g.gravity_power : 0;
  remove_excavated();
  ContactSet& c = contacts;
  c.recount_active();
  c.rebuild_due = true;  // (the pairs are listed afresh at the first evaluation, their histories carried)
  c.touching = 0;
  c.pairs.clear(), c.history.clear(), c.eval.clear(), c.pair_force.clear();
  c.gather_node.clear(), c.gather_slot.clear(), c.watch_nodes.clear(), c.watch_x.clear();
  c.gather_ptr.assign(1, 0);
  host_current_ = true;
  host_changed();
  // The contact ghosts within the reach of the positions reached (the partition planned them in
  // the reference configuration); the reach counts from here.
  if (layout_.distributed() && c.enabled())
    grow_contact_ghosts();
  else
    restart_device();
  place_saved_pairs();
  saved_.reset();
  host_changed();
}

void Solver::place_saved_pairs() {
  // In the candidate builder's order: by the tets' global ids, the lower one first.
  const SavedRanks& g = *saved_;
  const Decomposition& dd = layout_.dd;
  const SavedLocalIds tet(dd.distributed() ? dd.tet_global : std::vector<long>{}, model_.tet_nodes.size());
  const SavedLocalIds ce6(dd.distributed() ? dd.ce6_global : std::vector<long>{}, model_.ce6_nodes.size());
  ContactSet& c = contacts;
  for (const auto& [ab, s] : g.pairs) {
    const int a = tet.find(ab.first), b = tet.find(ab.second);
    if (a < 0 || b < 0) continue;
    c.pairs.push_back({a, b, s.joint >= 0 ? ce6.find(s.joint) : -1});
    c.history.push_back(s.history);
    c.eval.push_back(s.eval);
    c.pair_force.insert(c.pair_force.end(), s.force.begin(), s.force.end());
  }
}

}  // namespace fdem
