#pragma once
// Halo exchanges of a decomposed model (partition.hpp), non-blocking point to point with each
// neighbour, on buffers the device loop packs. Every rank of the communicator must call each
// exchange together.
//
// Node lists: the decomposition's lists (the nodes of the elements a rank computes) plus, with
// contact, the nodes of the *active* tets two ranks both hold: contact reads a ghost tet's
// nodes only while the tet is a contact candidate. The lists grow when activation flags
// merge (follow_flags); both ranks of a pair see the same merged flags, so they grow their
// lists alike without a message, and refresh the new ghosts at once (exchange_nodes with the
// changed neighbours), before contact reads them.
#include <mpi.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.hpp"
#include "partition/partition.hpp"

namespace fdem {

class Halo {
 public:
  /// tet_nodes: the rank model's tets; with it (contact) the lists follow the active tets
  /// (collective: the ranks tell each neighbour which corners of their shared tets they own).
  Halo(MPI_Comm comm, const Decomposition& dd, const std::vector<std::array<int, 4>>* tet_nodes = nullptr);
  /// The node lists after merged flags, given as the packed flags this rank sent and
  /// received (the device loop merges the flags: a tet flagged on any rank holding it is
  /// flagged on all of them).
  void follow_flags(const std::uint8_t* sent, const std::uint8_t* received);
  /// The neighbours whose node lists grew at the last merge (their new ghosts need a refresh
  /// now); empty when none did.
  const std::vector<char>& grown() const { return grown_; }
  /// Bytes this rank sends per node update (positions and velocities), for the benchmark.
  std::size_t node_bytes_sent() const;
  MPI_Comm comm() const { return comm_; }
  std::size_t neighbours() const { return send_list_.size(); }
  /// Neighbour i's node lists now (local ids, in global order).
  const std::vector<int>& send_nodes(std::size_t i) const { return send_list_[i]; }
  const std::vector<int>& recv_nodes(std::size_t i) const { return recv_list_[i]; }

  // The exchanges, on packed buffers (the device loop packs on the device, and on a GPU without
  // a CUDA-aware MPI stages them through the host): owners send positions and velocities of
  // their nodes to the ranks holding them as ghosts (with `only`, to and from the neighbours i
  // with only[i] set; both sides of a pair agree), and flags. Node buffers hold, neighbour
  // after neighbour, the x of its nodes then their v: neighbour i's send part starts at
  // send_offset(i) and holds 2 x neighbours[i].send_nodes.size() values (recv likewise with
  // recv_nodes). Flag buffers hold the flags of neighbours[i].shared_tets at flag_offset(i).
  std::size_t send_size() const { return send_off_.back(); }
  std::size_t recv_size() const { return recv_off_.back(); }
  std::size_t flag_size() const { return flag_off_.back(); }
  std::size_t send_offset(std::size_t i) const { return send_off_[i]; }
  std::size_t recv_offset(std::size_t i) const { return recv_off_[i]; }
  std::size_t flag_offset(std::size_t i) const { return flag_off_[i]; }
  void exchange_nodes(const Vec3* send, Vec3* recv, const std::vector<char>* only = nullptr);
  void exchange_flags(const std::uint8_t* send, std::uint8_t* recv);

 private:
  void set_offsets();
  MPI_Comm comm_;
  const Decomposition* dd_;
  const std::vector<std::array<int, 4>>* tet_nodes_;
  std::vector<std::vector<int>> send_list_, recv_list_;
  // Per neighbour and shared tet: the corners this rank owns, the corners the neighbour owns
  // (bit k: corner k); the active shared tets at the last merge (-1: none yet).
  std::vector<std::vector<std::uint8_t>> mine_, theirs_;
  std::vector<long> active_shared_;
  std::vector<char> grown_;
  std::vector<std::size_t> send_off_, recv_off_, flag_off_;
  std::vector<MPI_Request> req_;
};

/// Whether the MPI library says it takes CUDA device pointers (Open MPI's
/// MPIX_Query_cuda_support, MPICH's MPIX_GPU_query_support); false where it cannot say.
bool mpi_cuda_aware();
/// Whether a device loop hands its device buffers straight to MPI (GPU-aware MPI) instead of
/// staging them through host memory. FDEM_GPU_AWARE_MPI: unset or "auto": direct on a GPU when
/// mpi_cuda_aware(), staged otherwise (and on the debug backend, on_gpu false); "1": direct
/// (an MPI that cannot say, e.g. MVAPICH2 with MV2_USE_CUDA=1); "0": staged. InputError for any
/// other value, naming the variable and the values it takes.
bool device_buffers_to_mpi(bool on_gpu);

/// Sums n values over the ranks of comm in place (nothing to do on one rank).
void sum_over_ranks(MPI_Comm comm, double* values, int n);
/// How many reductions sum_over_ranks has made in this process (each waits for every rank: a
/// step's count is a cost on a cluster; tests/mpi).
long sums_over_ranks_made();
/// A value's sum and maximum over the ranks of comm.
double sum_over_ranks(MPI_Comm comm, double value);
double max_over_ranks(MPI_Comm comm, double value);
/// This process's rank in comm, and comm's size.
int rank_in(MPI_Comm comm);
int size_of(MPI_Comm comm);
/// Point-to-point transfer of a byte string of any length (in pieces below MPI's int count).
void send_bytes(MPI_Comm comm, const std::string& bytes, int to);
std::string receive_bytes(MPI_Comm comm, int from);

}  // namespace fdem
