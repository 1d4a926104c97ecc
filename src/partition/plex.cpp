#include "partition/plex.hpp"

#include "core/error.hpp"

#if FDEM_HAVE_PETSC
#include <petscdmplex.h>
#include <petscsf.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "io/checkpoint.hpp"
#include "partition/halo.hpp"
#endif

namespace fdem {

void require_plex() {
  if (!plex_available())
    throw InputError(
        "--distribute plex: this fdem was built without PETSc. Fix: --distribute root, or fdem partition and "
        "--partitioned, or build with PETSc (apt-get install petsc-dev)");
}

#if !FDEM_HAVE_PETSC

bool plex_available() {
  return false;
}

RankModel distribute_with_plex(MPI_Comm, const Model*, const PartitionPlan*, PlexReport*, std::uint64_t) {
  require_plex();
  return {};
}

void plex_finalize() {}

#else

namespace {

bool g_petsc_ours = false;  // PETSc initialised here (finalised by plex_finalize)

void check(PetscErrorCode e, const char* what) {
  if (e == 0) return;
  const char* text = nullptr;
  PetscErrorMessage(e, &text, nullptr);
  throw RunError(std::string("distribution through DMPlex: ") + what + " failed (PETSc: " + (text ? text : "error") +
                 "). Fix: run with --distribute root, or partition first (fdem partition)");
}

void start_petsc() {
  PetscBool up = PETSC_FALSE;
  PetscInitialized(&up);
  if (up) return;
  // fdem handles its own signals (a checkpoint on SIGTERM): PETSc's handlers stay out.
  PetscOptionsSetValue(nullptr, "-no_signal_handler", nullptr);
  check(PetscInitializeNoArguments(), "PetscInitialize");
  g_petsc_ours = true;
}

// What rank 0 knows of each element to write its record: the position of a tet or CE6 in its
// colouring and the colour, a node's platen entry and groups, and the CE6s (by their first tet)
// and surface faces of each tet.
struct Lookup {
  std::vector<int> tet_colour, tet_pos, ce6_colour, ce6_pos, platen_of;
  std::vector<std::uint8_t> flags;  // 1 top, 2 bottom, 4 lateral
  std::vector<int> ce6_ptr, ce6_list, face_ptr, face_list;
};

void invert(const Colouring& c, std::vector<int>& colour, std::vector<int>& pos, std::size_t n) {
  colour.assign(n, -1);
  pos.assign(n, -1);
  for (int k = 0; k < c.colours(); ++k)
    for (int j = c.offsets[k]; j < c.offsets[k + 1]; ++j) colour[c.order[j]] = k, pos[c.order[j]] = j;
}

/// CSR of items by owner: items i with owner[i] == t are list[ptr[t] .. ptr[t+1]).
void bucket(const std::vector<int>& owner, std::size_t n, std::vector<int>& ptr, std::vector<int>& list) {
  ptr.assign(n + 1, 0);
  for (int t : owner) ++ptr[t + 1];
  for (std::size_t t = 0; t < n; ++t) ptr[t + 1] += ptr[t];
  list.resize(owner.size());
  std::vector<int> fill(ptr.begin(), ptr.end() - 1);
  for (std::size_t i = 0; i < owner.size(); ++i) list[fill[owner[i]]++] = int(i);
}

Lookup make_lookup(const Model& g) {
  Lookup lk;
  const std::size_t nt = g.tet_nodes.size(), nn = g.X.size(), nc = g.ce6_nodes.size();
  invert(g.tet_colours, lk.tet_colour, lk.tet_pos, nt);
  invert(g.ce6_colours, lk.ce6_colour, lk.ce6_pos, nc);
  lk.platen_of.assign(nn, -1);
  for (std::size_t i = 0; i < g.platen_nodes.size(); ++i) lk.platen_of[g.platen_nodes[i]] = int(i);
  lk.flags.assign(nn, 0);
  for (int n : g.top_nodes) lk.flags[n] |= 1;
  for (int n : g.bottom_nodes) lk.flags[n] |= 2;
  for (int n : g.lateral_nodes) lk.flags[n] |= 4;
  std::vector<int> first(nc);
  for (std::size_t c = 0; c < nc; ++c) first[c] = g.ce6_tets[c][0];
  bucket(first, nt, lk.ce6_ptr, lk.ce6_list);
  bucket(g.surface_tet, nt, lk.face_ptr, lk.face_list);
  return lk;
}

// One tet's record: the tet, its four nodes, the CE6s whose first tet it is, its surface faces.
// The node lists (platen, top, bottom, lateral) and the colourings are ascending in the global
// model, so flags and positions rebuild them in the same order on any subset.
std::string tet_record(const Model& g, const PartitionPlan& plan, const Lookup& lk, int t) {
  CheckpointOut o;
  o.put(long(t)), o.put(g.tet_input[t]), o.put(g.tet_Xinv[t]), o.put(g.tet_V0[t]), o.put(g.tet_eta[t]);
  const Model::TetProperties p = g.tet_properties(t);
  o.put(p.material), o.put(p.stiffness), o.put(p.joint), o.put(p.history), o.put(p.group), o.put(p.stage);
  o.put(plan.part[t]), o.put(plan.held[t]), o.put(lk.tet_colour[t]), o.put(lk.tet_pos[t]);
  for (int n : g.tet_nodes[t]) {
    const int p = lk.platen_of[n];
    o.put(n), o.put(g.X[n]), o.put(g.mass[n]), o.put(g.node_vertex[n]), o.put(plan.node_owner[n]);
    o.put(plan.node_ranks[n]), o.put(lk.flags[n]), o.put(p >= 0), o.put(g.node_conditions_of(n));
    o.put(g.node_history_of(n));
    if (p >= 0) o.put(g.platen_node_area[p]), o.put(g.platen_node_h[p]);
  }
  o.put(lk.ce6_ptr[t + 1] - lk.ce6_ptr[t]);
  for (int j = lk.ce6_ptr[t]; j < lk.ce6_ptr[t + 1]; ++j) {
    const int c = lk.ce6_list[j];
    o.put(c), o.put(g.ce6_nodes[c]), o.put(g.ce6_tets[c][1]), o.put(g.ce6_h[c]), o.put(g.ce6_law[c]);
    o.put(g.ce6_strength.empty() ? real(1) : g.ce6_strength[c]);
    o.put(lk.ce6_colour[c]);
    o.put(lk.ce6_pos[c]);
  }
  o.put(lk.face_ptr[t + 1] - lk.face_ptr[t]);
  for (int j = lk.face_ptr[t]; j < lk.face_ptr[t + 1]; ++j)
    o.put(lk.face_list[j]), o.put(g.surface_faces[lk.face_list[j]]), o.put(g.conditions_of(lk.face_list[j]));
  return o.payload();
}

// The global values every rank needs beside the records.
struct Header {
  long nodes = 0, tets = 0, ce6s = 0, held = 0;  // held: tets this rank's model holds
  int tet_colours = 0, ce6_colours = 0, size = 0;
  real reach = 0;
  Model scalars;  // box, axis, height, area, line_loaded, min_altitude, mean_edge, source
};

void put_header(CheckpointOut& o, const Model& g, const PartitionPlan& plan, long held) {
  o.put(long(g.X.size())), o.put(long(g.tet_nodes.size())), o.put(long(g.ce6_nodes.size())), o.put(held);
  o.put(g.tet_colours.colours()), o.put(g.ce6_colours.colours()), o.put(plan.size), o.put(plan.reach);
  o.put(g.box_min), o.put(g.box_max), o.put(g.axis_point), o.put(g.height0), o.put(g.area0), o.put(g.line_loaded);
  o.put(g.min_altitude), o.put(g.mean_edge), o.put(g.source), o.put(g.condition_axis);
}

Header get_header(CheckpointIn& in) {
  Header h;
  Model& m = h.scalars;
  in.get(h.nodes), in.get(h.tets), in.get(h.ce6s), in.get(h.held);
  in.get(h.tet_colours), in.get(h.ce6_colours), in.get(h.size), in.get(h.reach);
  in.get(m.box_min), in.get(m.box_max), in.get(m.axis_point), in.get(m.height0), in.get(m.area0), in.get(m.line_loaded);
  in.get(m.min_altitude), in.get(m.mean_edge), in.get(m.source), in.get(m.condition_axis);
  return h;
}

struct NodeRec {
  Vec3 X{0, 0, 0};
  real mass = 0, area = 0, h = 0;
  int vertex = 0, owner = 0;
  std::vector<int> ranks;
  std::uint8_t flags = 0;
  bool platen = false;
  std::uint32_t conditions = 0;  // Model::node_conditions
  std::uint32_t history = 0;     // Model::node_history
};
struct TetRec {
  long id = 0;
  int input = 0, part = 0, colour = 0, pos = 0;
  Mat3 Xinv{};
  real V0 = 0, eta = 0;
  Model::TetProperties props;
  std::vector<int> held;
  std::array<int, 4> nodes{};
};
struct Ce6Rec {
  int id = 0, a = 0, b = 0, colour = 0, pos = 0;
  std::array<int, 6> nodes{};
  real h = 0;
  std::uint8_t law = 0;  // Model::ce6_law
  real strength = 1;     // Model::ce6_strength
};
struct FaceRec {
  int id = 0, tet = 0;
  std::array<int, 3> nodes{};
  std::uint32_t conditions = 0;  // Model::surface_conditions
};

struct Piece {
  std::vector<TetRec> tets;
  std::map<int, NodeRec> nodes;
  std::vector<Ce6Rec> ce6s;
  std::vector<FaceRec> faces;
};

void read_record(const char* bytes, std::size_t n, Piece& p) {
  CheckpointIn in(std::string(bytes, n), "a tet record of the DMPlex distribution");
  TetRec t;
  in.get(t.id), in.get(t.input), in.get(t.Xinv), in.get(t.V0), in.get(t.eta), in.get(t.props.material),
      in.get(t.props.stiffness), in.get(t.props.joint), in.get(t.props.history), in.get(t.props.group),
      in.get(t.props.stage);
  in.get(t.part), in.get(t.held);
  in.get(t.colour), in.get(t.pos);
  for (int& id : t.nodes) {
    in.get(id);
    NodeRec r;
    in.get(r.X), in.get(r.mass), in.get(r.vertex), in.get(r.owner), in.get(r.ranks), in.get(r.flags), in.get(r.platen);
    in.get(r.conditions), in.get(r.history);
    if (r.platen) in.get(r.area), in.get(r.h);
    p.nodes.emplace(id, std::move(r));
  }
  int k = 0;
  in.get(k);
  for (int j = 0; j < k; ++j) {
    Ce6Rec c;
    in.get(c.id), in.get(c.nodes), in.get(c.b), in.get(c.h), in.get(c.law), in.get(c.strength);
    in.get(c.colour), in.get(c.pos);
    c.a = int(t.id);
    p.ce6s.push_back(c);
  }
  in.get(k);
  for (int j = 0; j < k; ++j) {
    FaceRec f;
    in.get(f.id), in.get(f.nodes), in.get(f.conditions);
    f.tet = int(t.id);
    p.faces.push_back(f);
  }
  in.finish();
  p.tets.push_back(std::move(t));
}

/// The colouring of a piece's elements: by their global positions, in the global colours.
template <class Rec>
Colouring piece_colouring(const std::vector<Rec>& recs, int colours) {
  std::vector<std::pair<int, int> > by_pos;  // (global position, piece index)
  for (std::size_t i = 0; i < recs.size(); ++i) by_pos.push_back({recs[i].pos, int(i)});
  std::sort(by_pos.begin(), by_pos.end());
  Colouring c;
  c.offsets.assign(colours + 1, 0);
  for (const auto& r : recs) ++c.offsets[r.colour + 1];
  for (int k = 0; k < colours; ++k) c.offsets[k + 1] += c.offsets[k];
  for (const auto& pi : by_pos) c.order.push_back(pi.second);
  return c;
}

/// The piece as a model in global order, its plan, and the global ids: what extract_rank takes.
RankModel cut_piece(Piece& p, const Header& h, int rank) {
  std::sort(p.tets.begin(), p.tets.end(), [](const TetRec& a, const TetRec& b) { return a.id < b.id; });
  std::unordered_map<long, int> tet_local, node_local;
  for (std::size_t i = 0; i < p.tets.size(); ++i) tet_local[p.tets[i].id] = int(i);
  PieceIds ids;
  ids.nodes = h.nodes, ids.tets = h.tets, ids.ce6s = h.ce6s;
  Model m = h.scalars;
  PartitionPlan plan;
  plan.size = h.size;
  plan.reach = h.reach;
  for (const auto& [id, r] : p.nodes) {
    node_local[id] = int(ids.node.size());
    ids.node.push_back(id);
    m.X.push_back(r.X);
    m.mass.push_back(r.mass);
    m.node_conditions.push_back(r.conditions);
    m.node_history.push_back(r.history);
    m.node_vertex.push_back(r.vertex);
    plan.node_owner.push_back(r.owner);
    plan.node_ranks.push_back(r.ranks);
    const int local = int(m.X.size()) - 1;
    if (r.platen) m.platen_nodes.push_back(local), m.platen_node_area.push_back(r.area), m.platen_node_h.push_back(r.h);
    if (r.flags & 1) m.top_nodes.push_back(local);
    if (r.flags & 2) m.bottom_nodes.push_back(local);
    if (r.flags & 4) m.lateral_nodes.push_back(local);
  }
  for (const TetRec& t : p.tets) {
    ids.tet.push_back(t.id);
    std::array<int, 4> q;
    for (int k = 0; k < 4; ++k) q[k] = node_local.at(t.nodes[k]);
    append_tet(m, q, t.input, t.Xinv, t.V0, t.eta, t.props);
    plan.part.push_back(t.part);
    plan.held.push_back(t.held);
  }
  m.tet_colours = piece_colouring(p.tets, h.tet_colours);
  // A CE6 is in the piece where both its tets are (its nodes then are too).
  std::vector<Ce6Rec> ce6s;
  for (const Ce6Rec& c : p.ce6s)
    if (tet_local.count(c.b)) ce6s.push_back(c);
  std::sort(ce6s.begin(), ce6s.end(), [](const Ce6Rec& a, const Ce6Rec& b) { return a.id < b.id; });
  for (const Ce6Rec& c : ce6s) {
    ids.ce6.push_back(c.id);
    std::array<int, 6> q;
    for (int k = 0; k < 6; ++k) q[k] = node_local.at(c.nodes[k]);
    m.ce6_nodes.push_back(q);
    m.ce6_tets.push_back({tet_local.at(c.a), tet_local.at(c.b)});
    m.ce6_h.push_back(c.h);
    m.ce6_law.push_back(c.law);
    m.ce6_strength.push_back(c.strength);
  }
  m.ce6_colours = piece_colouring(ce6s, h.ce6_colours);
  // (All 1, as without heterogeneity: none held, as on the root's path.)
  if (std::all_of(m.ce6_strength.begin(), m.ce6_strength.end(), [](real f) { return f == 1; })) m.ce6_strength.clear();
  std::sort(p.faces.begin(), p.faces.end(), [](const FaceRec& a, const FaceRec& b) { return a.id < b.id; });
  for (const FaceRec& f : p.faces) {
    m.surface_faces.push_back({node_local.at(f.nodes[0]), node_local.at(f.nodes[1]), node_local.at(f.nodes[2])});
    m.surface_tet.push_back(tet_local.at(f.tet));
    m.surface_conditions.push_back(f.conditions);
  }
  // (None given: none held, as on the root's path.)
  if (std::all_of(m.surface_conditions.begin(), m.surface_conditions.end(), [](auto c) { return c == 0; }))
    m.surface_conditions.clear();
  if (std::all_of(m.node_conditions.begin(), m.node_conditions.end(), [](auto c) { return c == 0; }))
    m.node_conditions.clear();
  if (std::all_of(m.node_history.begin(), m.node_history.end(), [](auto c) { return c == 0; })) m.node_history.clear();
  return extract_rank(m, plan, rank, ids);
}

// The plex of the global tets over their mesh vertices, on rank 0 (cell t = global tet t).
DM global_plex(MPI_Comm comm, const Model* g, int nt, bool root) {
  int nv = 0;
  std::vector<PetscInt> cells;
  std::vector<PetscReal> coords;
  if (root) {
    for (int v : g->node_vertex) nv = std::max(nv, v + 1);
    cells.reserve(4 * std::size_t(nt));
    for (const auto& q : g->tet_nodes)
      for (int n : q) cells.push_back(g->node_vertex[n]);
    coords.assign(3 * std::size_t(nv), 0);
    for (std::size_t n = 0; n < g->X.size(); ++n)
      for (int d = 0; d < 3; ++d) coords[3 * std::size_t(g->node_vertex[n]) + d] = g->X[n][d];
  }
  DM dm = nullptr;
  check(DMPlexCreateFromCellListPetsc(comm, 3, nt, nv, 4, PETSC_FALSE, cells.data(), 3, coords.data(), &dm),
        "DMPlexCreateFromCellListPetsc");
  return dm;
}

// The plan's partition as the plex's shell partitioner (on rank 0: the tets rank by rank).
void set_shell_partition(DM dm, const PartitionPlan* plan, int size, bool root) {
  PetscPartitioner partitioner = nullptr;
  check(DMPlexGetPartitioner(dm, &partitioner), "DMPlexGetPartitioner");
  check(PetscPartitionerSetType(partitioner, PETSCPARTITIONERSHELL), "PetscPartitionerSetType");
  std::vector<PetscInt> sizes(size, 0), points;
  if (root) {  // the tets rank by rank
    std::vector<int> ptr, list;
    bucket(plan->part, std::size_t(size), ptr, list);
    for (int r = 0; r < size; ++r) sizes[r] = ptr[r + 1] - ptr[r];
    points.assign(list.begin(), list.end());
  }
  check(PetscPartitionerShellSetPartition(partitioner, size, sizes.data(), points.data()),
        "PetscPartitionerShellSetPartition");
}

// Every tet's record as the cell's data on rank 0, in blocks of kBlock bytes (the section
// counts blocks, and the star forest that moves them has one leaf per block: per byte it
// would take 12 bytes of graph for each byte moved). A record starts with its length. The
// records go in passes of at most pass_bytes (1 GiB unless a test asks for less): PETSc
// 3.18's DMPlexDistributeData sizes a rank's receive buffer as an int number of bytes, so
// no rank may receive 2 GiB or more in one call.
constexpr std::size_t kBlock = 64;

struct CellData {
  std::string data;                      // rank 0: the records, each padded to whole blocks
  std::vector<std::uint64_t> record_at;  // rank 0: where each tet's record starts, then the end
  std::vector<int> pass_start{0};        // the passes' first tets, then nt (every rank)
};

CellData pack_records(const Model& g, const PartitionPlan& plan, const Lookup& lk, std::uint64_t pass_bytes) {
  const int nt = int(g.tet_nodes.size());
  CellData cd;
  std::string& data = cd.data;
  std::vector<int>& pass_start = cd.pass_start;
  cd.record_at.resize(std::size_t(nt) + 1);
  for (int t = 0; t < nt; ++t) {
    cd.record_at[t] = data.size();
    const std::string r = tet_record(g, plan, lk, t);
    const std::uint64_t n = r.size();
    data.append(reinterpret_cast<const char*>(&n), sizeof n);
    data += r;
    data.resize((data.size() + kBlock - 1) / kBlock * kBlock, '\0');
    if (data.size() - cd.record_at[pass_start.back()] > pass_bytes && t > pass_start.back()) pass_start.push_back(t);
  }
  cd.record_at[nt] = data.size();
  pass_start.push_back(nt);
  return cd;
}

// Rank 0's pass boundaries to every rank.
void share_passes(MPI_Comm comm, std::vector<int>& pass_start) {
  int passes = int(pass_start.size()) - 1;
  MPI_Bcast(&passes, 1, MPI_INT, 0, comm);
  pass_start.resize(std::size_t(passes) + 1);
  MPI_Bcast(pass_start.data(), passes + 1, MPI_INT, 0, comm);
}

// The global plex distributed (dist and migration null on one rank), its chart and its cells
// on this rank, and the MPI type of one block.
struct Distribution {
  DM dm = nullptr, dist = nullptr;
  PetscSF migration = nullptr;
  PetscInt p_start = 0, p_end = 0, c_start = 0, c_end = 0;
  MPI_Datatype block = MPI_DATATYPE_NULL;
};

// Reads the records that arrived on this rank's cells in one pass; returns how many.
long read_arrived(const Distribution& d, PetscSection arrived_section, const void* arrived, Piece& piece) {
  long records = 0;
  for (PetscInt c = d.c_start; c < d.c_end; ++c) {
    PetscInt dof = 0, off = 0;
    check(PetscSectionGetDof(arrived_section, c, &dof), "PetscSectionGetDof");
    if (dof <= 0) continue;  // in another pass
    check(PetscSectionGetOffset(arrived_section, c, &off), "PetscSectionGetOffset");
    const char* at = static_cast<const char*>(arrived) + std::size_t(off) * kBlock;
    std::uint64_t n = 0;
    std::memcpy(&n, at, sizeof n);
    if (n + sizeof n > std::size_t(dof) * kBlock)
      throw RunError("distribution through DMPlex: a damaged tet record arrived (" + std::to_string(n) + " bytes in " +
                     std::to_string(dof * kBlock) + ")");
    read_record(at + sizeof n, n, piece);
    ++records;
  }
  return records;
}

// One pass: rank 0's records of tets pass_start[k] .. pass_start[k+1] along the migration;
// returns how many records arrived here.
long move_pass(MPI_Comm comm, const Distribution& d, CellData& cd, int k, bool root, Piece& piece) {
  PetscSection section = nullptr;
  check(PetscSectionCreate(comm, &section), "PetscSectionCreate");
  check(PetscSectionSetChart(section, d.p_start, d.p_end), "PetscSectionSetChart");
  char* first = cd.data.data();
  if (root) {
    first += cd.record_at[cd.pass_start[k]];
    for (int t = cd.pass_start[k]; t < cd.pass_start[k + 1]; ++t)
      check(PetscSectionSetDof(section, t, PetscInt((cd.record_at[t + 1] - cd.record_at[t]) / kBlock)), "dof");
  }
  check(PetscSectionSetUp(section), "PetscSectionSetUp");
  PetscSection arrived_section = section;
  void* arrived = first;
  if (d.dist) {
    check(PetscSectionCreate(comm, &arrived_section), "PetscSectionCreate");
    arrived = nullptr;
    check(DMPlexDistributeData(d.dm, d.migration, section, d.block, first, arrived_section, &arrived),
          "DMPlexDistributeData");
  }
  const long records = read_arrived(d, arrived_section, arrived, piece);
  if (d.dist) {
    PetscFree(arrived);
    PetscSectionDestroy(&arrived_section);
  }
  PetscSectionDestroy(&section);
  return records;
}

// What arrived through the plex: the records read and the cells this rank's plex has.
struct Delivery {
  long records = 0, cells = 0;
};

// Distribute: the shell partition, overlap 1, and the cell data along the migration.
// (One rank: DMPlexDistribute leaves the plex where it is, and the data stays too.)
Delivery distribute_cells(MPI_Comm comm, DM dm, CellData& cd, bool root, Piece& piece) {
  const int size = size_of(comm);
  Distribution d;
  d.dm = dm;
  check(DMPlexDistribute(dm, 1, &d.migration, &d.dist), "DMPlexDistribute");
  if (size > 1 && (!d.dist || !d.migration))
    throw RunError("distribution through DMPlex: DMPlexDistribute returned no distributed plex");
  check(DMPlexGetChart(dm, &d.p_start, &d.p_end), "DMPlexGetChart");
  check(DMPlexGetHeightStratum(d.dist ? d.dist : dm, 0, &d.c_start, &d.c_end), "DMPlexGetHeightStratum");
  MPI_Type_contiguous(int(kBlock), MPI_BYTE, &d.block);
  MPI_Type_commit(&d.block);
  Delivery got;
  const int passes = int(cd.pass_start.size()) - 1;
  for (int k = 0; k < passes; ++k) got.records += move_pass(comm, d, cd, k, root, piece);
  MPI_Type_free(&d.block);
  got.cells = long(d.c_end - d.c_start);
  if (d.dist) {
    PetscSFDestroy(&d.migration);
    DMDestroy(&d.dist);
  }
  return got;
}

// On rank 0: the tets that arrived on each rank, sorted (empty elsewhere).
std::vector<std::vector<int> > gather_arrived(MPI_Comm comm, const Piece& piece, bool root) {
  const int size = size_of(comm);
  std::vector<long> got;
  for (const TetRec& t : piece.tets) got.push_back(t.id);
  const int n_got = int(got.size());
  std::vector<int> counts(size), displs(size);
  MPI_Gather(&n_got, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  std::vector<long> all_got;
  if (root) {
    for (int r = 1; r < size; ++r) displs[r] = displs[r - 1] + counts[r - 1];
    all_got.resize(std::size_t(displs[size - 1]) + counts[size - 1]);
  }
  MPI_Gatherv(got.data(), n_got, MPI_LONG, all_got.data(), counts.data(), displs.data(), MPI_LONG, 0, comm);
  std::vector<std::vector<int> > arrived_at;  // per rank, sorted
  if (root) {
    arrived_at.resize(size);
    for (int r = 0; r < size; ++r) {
      arrived_at[r].assign(all_got.begin() + displs[r], all_got.begin() + displs[r] + counts[r]);
      std::sort(arrived_at[r].begin(), arrived_at[r].end());
    }
  }
  return arrived_at;
}

// Rank 0's own message, and the cells the overlap brought beyond the tets the ranks hold.
struct RootSend {
  std::string mine;
  long extra_cells = 0;
};

// Rank 0 sends each rank the global values and the records of the tets it holds that did
// not arrive through the plex.
RootSend send_missing(MPI_Comm comm, const Model& g, const PartitionPlan& plan, const Lookup& lk,
                      const std::vector<std::vector<int> >& arrived_at) {
  const int size = size_of(comm), nt = int(g.tet_nodes.size());
  RootSend out;
  std::vector<long> held(size, 0);
  std::vector<std::vector<int> > extra(size);
  for (int t = 0; t < nt; ++t)
    for (int r : plan.held[t]) {
      ++held[r];
      if (!std::binary_search(arrived_at[r].begin(), arrived_at[r].end(), t)) extra[r].push_back(t);
    }
  for (int r = 0; r < size; ++r) {
    out.extra_cells += long(arrived_at[r].size()) + long(extra[r].size()) - held[r];
    CheckpointOut o;
    put_header(o, g, plan, held[r]);
    std::vector<std::string> records;
    for (int t : extra[r]) records.push_back(tet_record(g, plan, lk, t));
    o.put(records);
    if (r == 0)
      out.mine = o.payload();
    else
      send_bytes(comm, o.payload(), r);
  }
  return out;
}

// Every rank checks what it received, and all stop together if one lacks something.
void check_received(MPI_Comm comm, const Piece& piece, const Header& h, const Delivery& got) {
  const int rank = rank_in(comm), size = size_of(comm);
  long held = 0;
  for (const TetRec& t : piece.tets) held += std::binary_search(t.held.begin(), t.held.end(), rank);
  std::string problem;
  if (got.records != got.cells)
    problem = std::to_string(got.cells - got.records) + " of the plex's " + std::to_string(got.cells) +
              " cells came without data";
  else if (held != h.held)
    problem = "received " + std::to_string(held) + " of the " + std::to_string(h.held) + " tets its model holds";
  int bad = problem.empty() ? size : rank;  // the lowest rank with a problem names it
  MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MIN, comm);
  if (bad < size)
    throw RunError("distribution through DMPlex: rank " + std::to_string(bad) + " " +
                   (problem.empty() ? std::string("failed its check") : problem) +
                   ". Fix: run with --distribute root, or partition first (fdem partition)");
}

}  // namespace

bool plex_available() {
  return true;
}

void plex_finalize() {
  if (g_petsc_ours) PetscFinalize();
  g_petsc_ours = false;
}

RankModel distribute_with_plex(MPI_Comm comm, const Model* g, const PartitionPlan* plan, PlexReport* report,
                               std::uint64_t pass_bytes) {
  const int rank = rank_in(comm), size = size_of(comm);
  const bool root = rank == 0;
  if (root && (!g || !plan || plan->size != size || plan->part.size() != g->tet_nodes.size()))
    throw RunError("distribution through DMPlex: rank 0 needs the model and a plan for " + std::to_string(size) +
                   " ranks");
  start_petsc();
  PetscPushErrorHandler(PetscReturnErrorHandler, nullptr);  // errors come back as codes: RunError

  const int nt = root ? int(g->tet_nodes.size()) : 0;
  DM dm = global_plex(comm, g, nt, root);
  set_shell_partition(dm, plan, size, root);
  Lookup lk;
  if (root) lk = make_lookup(*g);
  CellData cd;
  if (root) cd = pack_records(*g, *plan, lk, pass_bytes);
  share_passes(comm, cd.pass_start);
  Piece piece;
  const Delivery got = distribute_cells(comm, dm, cd, root, piece);
  cd.data = {};
  DMDestroy(&dm);
  PetscPopErrorHandler();

  // Rank 0 learns which tets arrived where, and sends each rank the global values and the
  // records of the tets it holds that the overlap did not bring (contact ghosts).
  const std::vector<std::vector<int> > arrived_at = gather_arrived(comm, piece, root);
  RootSend sent;
  if (root)
    sent = send_missing(comm, *g, *plan, lk, arrived_at);
  else
    sent.mine = receive_bytes(comm, 0);
  CheckpointIn in(std::move(sent.mine), "the DMPlex distribution's message from rank 0");
  const Header h = get_header(in);
  std::vector<std::string> extras;
  in.get(extras);
  in.finish();
  for (const std::string& r : extras) read_record(r.data(), r.size(), piece);
  check_received(comm, piece, h, got);
  RankModel rm = cut_piece(piece, h, rank);
  long v[3] = {h.held - long(extras.size()), long(extras.size()), sent.extra_cells};
  MPI_Allreduce(MPI_IN_PLACE, v, 3, MPI_LONG, MPI_SUM, comm);
  if (report) *report = PlexReport{v[0], v[1], v[2]};
  return rm;
}

#endif

}  // namespace fdem
