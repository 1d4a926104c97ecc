#pragma once
// Distributed memory: the tet partition (METIS on the dual graph), the per-rank model with its
// ghosts, and the halo plan. See docs/architecture.md, "Multi-rank runs".
//
// Scheme: every tet belongs to one rank (Lagrangian partition); a node belongs to the rank of
// the lowest-numbered tet holding it. A rank keeps its own tets plus one layer of ghost tets
// (tets sharing a mesh vertex with one of its own), and, with contact, every tet whose
// reference box comes within `reach` of one of its own (contact ghosts: a separate body
// across the boundary too); their nodes; and every CE6 whose two tets it keeps. Contact is
// exact while no node has moved reach/2 from where the contact ghosts were planned (two tets
// further apart than reach cannot touch before): the solver gathers them again with the
// current positions once a node has moved reach/4 (partition/grow.hpp).
// With the ghost layer every element acting on an owned node is present, so a rank computes
// the complete force on each node it owns: no force is sent back. After each step the owners
// send the positions and velocities of their nodes to the ranks that read them (the nodes of
// the elements a rank computes: Neighbour lists; with contact the halo adds the nodes of the
// active ghost tets, partition/halo.hpp). Energies and
// counts take each element once: a tet on its owner, a CE6 and a contact pair on the owner of
// their lower-numbered tet, a node term on the node's owner.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "model/model.hpp"

namespace fdem {

class CheckpointOut;
class CheckpointIn;

/// What a rank exchanges with one other rank; every list is in global-id order, so both sides
/// agree on it without sending ids.
struct Neighbour {
  int rank = 0;
  std::vector<int> send_nodes;   // local ids of owned nodes the other rank holds as ghosts
  std::vector<int> recv_nodes;   // local ids of ghost nodes the other rank owns
  std::vector<int> shared_tets;  // local ids of tets both ranks hold (activation flags)
};

/// A rank's part of the model: local -> global ids, what it owns, and its neighbours.
/// Default-constructed: one rank that owns everything.
struct Decomposition {
  int rank = 0, size = 1;
  real reach = 0;  // m, contact ghosts: tets within this distance of an owned tet (0 without contact)
  long global_nodes = 0, global_tets = 0, global_ce6 = 0;
  std::vector<long> node_global, tet_global, ce6_global;
  std::vector<std::uint8_t> node_owned, tet_owned, ce6_owned;
  std::vector<Neighbour> neighbours;
  bool distributed() const { return size > 1; }

  void save(CheckpointOut& out) const;
  void load(CheckpointIn& in);
};

/// What METIS balances over the ranks: the tets' step cost (the default) or their number.
enum class PartitionWeights { cost, uniform };

/// The step cost of each tet for the partition, in units of about 22 ns on one CPU core:
/// 4 for its TET4 and 3 for each CE6 on its faces (half of a CE6's 6: its two tets share it).
/// From docs/benchmarks.md (one thread): a TET4 costs about 90 ns, a CE6 with the gathers and
/// node updates of its split nodes about 135 ns, so a tet inside a fracture region (about 4
/// CE6s) costs 4 times one outside. Models whose fracture regions cover part of the mesh are
/// then split into equal work, not equal tet counts.
std::vector<int> tet_cost_weights(const Model& m);

/// The rank (0 .. parts-1) of every tet: METIS k-way on the dual graph (tets sharing a face),
/// balancing tet_cost_weights (or tet counts), seeded so that the result is reproducible.
/// InputError if parts exceeds the tet count or a part comes out empty, naming the counts and
/// the fix.
std::vector<int> partition_tets(const Model& m, int parts, PartitionWeights w = PartitionWeights::cost);

/// Rank `rank`'s model (its tets, one ghost layer and the contact ghosts within `reach`
/// m, nodes, CE6s, surfaces and node groups, renumbered in global order; platen nodes only
/// where owned) and its decomposition. part[t] is the rank of global tet t.
struct RankModel {
  Model model;
  Decomposition dd;
};
RankModel extract_rank(const Model& global, const std::vector<int>& part, int rank, real reach = 0);

/// What every rank's extraction needs, computed once for all ranks (fdem partition cuts out
/// N ranks from one plan): the partition, node owners, and which ranks hold each tet (with its
/// own or as a ghost) and which ranks need each node sent to them every step.
struct PartitionPlan {
  int size = 0;
  real reach = 0;
  std::vector<int> part, node_owner;
  std::vector<std::vector<int>> held;        // per tet: the ranks holding it, ascending
  std::vector<std::vector<int>> node_ranks;  // per node: the ranks that need it (ascending)
};
PartitionPlan plan_partition(const Model& global, const std::vector<int>& part, real reach = 0);
RankModel extract_rank(const Model& global, const PartitionPlan& plan, int rank);

/// A piece of the global model (partition/plex.cpp): some of its tets with their nodes, CE6s
/// and surfaces, numbered in global order, and the plan restricted to them. `ids` gives the
/// global id of each and the global counts. A piece holding every tet the rank holds gives
/// the rank model extract_rank(global, plan, rank) gives, field for field.
struct PieceIds {
  std::vector<long> node, tet, ce6;
  long nodes = 0, tets = 0, ce6s = 0;
};
RankModel extract_rank(const Model& piece, const PartitionPlan& plan, int rank, const PieceIds& ids);

/// Appends a tet (its nodes by local id, its input index and reference data) to m's tet arrays
/// (the pieces of the DMPlex distribution and the grown contact ghosts are built this way).
void append_tet(Model& m, const std::array<int, 4>& nodes, int input, const Mat3& Xinv, real V0, real eta,
                const Model::TetProperties& props);

/// The default contact reach (0 without contact): two mean edge lengths, or 2.5 times the
/// platen travel by the end of the run where the scene's end condition bounds it (axial strain
/// x height, platen velocity x time), whichever is larger, so that the platen's motion alone
/// makes the ranks gather their contact ghosts again (partition/grow.hpp) at most once.
real default_reach(const Model& m, const Scene& s);

/// A hash of every scene value the model build uses (mesh, material density and elasticity,
/// mass scaling, damping, fracture regions): a rank file is used only with a scene that
/// builds the same model.
std::uint64_t model_key(const Scene& s);

/// Writes and reads a pre-partitioned rank file (fdem partition): the rank model and its
/// decomposition in the checkpoint container (versioned, checksummed, written atomically).
void write_rank_file(const std::string& path, const RankModel& rm, std::uint64_t key);
/// InputError naming the file when it is damaged, not a rank file, or made for another scene (key).
RankModel read_rank_file(const std::string& path, std::uint64_t key);
/// The same contents in a checkpoint payload (rank 0 sends each rank its model this way; a
/// checkpoint holds it after the contact ghosts grew); get_rank_model reads it and stops there.
void put_rank_model(CheckpointOut& out, const RankModel& rm, std::uint64_t key);
RankModel get_rank_model(CheckpointIn& in, std::uint64_t key);

}  // namespace fdem
