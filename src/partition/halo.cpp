#include "partition/halo.hpp"

#include <algorithm>
#include <cstdlib>
#include <string>

#include "contact/bonded.hpp"
#include "core/error.hpp"
#if defined(OPEN_MPI) && __has_include(<mpi-ext.h>)
#include <mpi-ext.h>  // Open MPI's extensions: MPIX_CUDA_AWARE_SUPPORT
#endif

namespace fdem {

bool mpi_cuda_aware() {
#if defined(MPIX_CUDA_AWARE_SUPPORT)
  return MPIX_Query_cuda_support() == 1;  // the library's answer at run time
#elif defined(MPICH_NUMVERSION) && MPICH_NUMVERSION >= 40000000
  int yes = 0;
  return MPIX_GPU_query_support(MPIX_GPU_SUPPORT_CUDA, &yes) == MPI_SUCCESS && yes == 1;
#else
  return false;
#endif
}

bool device_buffers_to_mpi(bool on_gpu) {
  const char* env = std::getenv("FDEM_GPU_AWARE_MPI");
  const std::string v = env ? env : "auto";
  if (v == "auto" || v.empty()) return on_gpu && mpi_cuda_aware();
  if (v == "1") return true;
  if (v == "0") return false;
  throw InputError("FDEM_GPU_AWARE_MPI=" + v +
                   ": use auto (the default: device buffers to MPI when the MPI library says it is CUDA-aware), 1 "
                   "(always, for an MPI that cannot say) or 0 (stage through host memory)");
}

Halo::Halo(MPI_Comm comm, const Decomposition& dd, const std::vector<std::array<int, 4>>* tet_nodes)
    : comm_(comm), dd_(&dd), tet_nodes_(tet_nodes) {
  const auto& nbs = dd.neighbours;
  const std::size_t k = nbs.size();
  flag_off_.assign(1, 0);
  for (std::size_t i = 0; i < k; ++i) {
    send_list_.push_back(nbs[i].send_nodes);
    recv_list_.push_back(nbs[i].recv_nodes);
    flag_off_.push_back(flag_off_.back() + nbs[i].shared_tets.size());
  }
  set_offsets();
  req_.reserve(2 * k);
  active_shared_.assign(k, -1);
  if (!tet_nodes_) return;
  // Which corners of each shared tet this rank owns, sent to the neighbour (both list the
  // shared tets in the same order).
  mine_.resize(k);
  theirs_.resize(k);
  for (std::size_t i = 0; i < k; ++i) {
    for (int t : nbs[i].shared_tets) {
      std::uint8_t bits = 0;
      for (int c = 0; c < 4; ++c) bits |= std::uint8_t(dd.node_owned[(*tet_nodes_)[t][c]] ? 1 << c : 0);
      mine_[i].push_back(bits);
    }
    theirs_[i].resize(mine_[i].size());
  }
  for (std::size_t i = 0; i < k; ++i) {
    req_.emplace_back();
    MPI_Irecv(theirs_[i].data(), int(theirs_[i].size()), MPI_BYTE, nbs[i].rank, 103, comm_, &req_.back());
  }
  for (std::size_t i = 0; i < k; ++i) {
    req_.emplace_back();
    MPI_Isend(mine_[i].data(), int(mine_[i].size()), MPI_BYTE, nbs[i].rank, 103, comm_, &req_.back());
  }
  MPI_Waitall(int(req_.size()), req_.data(), MPI_STATUSES_IGNORE);
  req_.clear();
}

void Halo::set_offsets() {
  send_off_.assign(1, 0);
  recv_off_.assign(1, 0);
  for (std::size_t i = 0; i < send_list_.size(); ++i) {
    send_off_.push_back(send_off_.back() + 2 * send_list_[i].size());
    recv_off_.push_back(recv_off_.back() + 2 * recv_list_[i].size());
  }
}

void Halo::follow_flags(const std::uint8_t* sent, const std::uint8_t* received) {
  grown_.clear();
  if (!tet_nodes_) return;
  const auto& nbs = dd_->neighbours;
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& shared = nbs[i].shared_tets;
    long active = 0;
    for (std::size_t j = 0; j < shared.size(); ++j)
      active += ((sent[flag_off_[i] + j] | received[flag_off_[i] + j]) & TetFlag::kCandidate) != 0;
    if (active == active_shared_[i]) continue;  // flags only rise: the same count is the same set
    active_shared_[i] = active;
    if (grown_.empty()) grown_.assign(nbs.size(), 0);
    grown_[i] = 1;
    // The decomposition's lists and the corners of the active shared tets: this rank's to
    // send, the neighbour's to receive; in global order (the local order, except for contact
    // ghosts appended by a growth, partition/grow.hpp), once each.
    std::vector<int> s = nbs[i].send_nodes, r = nbs[i].recv_nodes;
    for (std::size_t j = 0; j < shared.size(); ++j) {
      if (!((sent[flag_off_[i] + j] | received[flag_off_[i] + j]) & TetFlag::kCandidate)) continue;
      for (int c = 0; c < 4; ++c) {
        const int n = (*tet_nodes_)[shared[j]][c];
        if (mine_[i][j] >> c & 1) s.push_back(n);
        if (theirs_[i][j] >> c & 1) r.push_back(n);
      }
    }
    const std::vector<long>& global = dd_->node_global;
    for (auto* list : {&s, &r}) {
      std::sort(list->begin(), list->end(), [&](int a, int b) { return global[a] < global[b]; });
      list->erase(std::unique(list->begin(), list->end()), list->end());
    }
    send_list_[i].swap(s);
    recv_list_[i].swap(r);
  }
  if (!grown_.empty()) set_offsets();
}

void Halo::exchange_nodes(const Vec3* send, Vec3* recv, const std::vector<char>* only) {
  constexpr int kTag = 101;
  const auto& nbs = dd_->neighbours;
  req_.clear();
  auto skip = [&](std::size_t i) { return only && !(*only)[i]; };
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (recv_off_[i + 1] > recv_off_[i] && !skip(i)) {  // receives posted before the sends
      req_.emplace_back();
      MPI_Irecv(recv + recv_off_[i], int((recv_off_[i + 1] - recv_off_[i]) * sizeof(Vec3)), MPI_BYTE, nbs[i].rank, kTag,
                comm_, &req_.back());
    }
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (send_off_[i + 1] > send_off_[i] && !skip(i)) {
      req_.emplace_back();
      MPI_Isend(send + send_off_[i], int((send_off_[i + 1] - send_off_[i]) * sizeof(Vec3)), MPI_BYTE, nbs[i].rank, kTag,
                comm_, &req_.back());
    }
  MPI_Waitall(int(req_.size()), req_.data(), MPI_STATUSES_IGNORE);
}

void Halo::exchange_flags(const std::uint8_t* send, std::uint8_t* recv) {
  constexpr int kTag = 102;
  const auto& nbs = dd_->neighbours;
  req_.clear();
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (flag_off_[i + 1] > flag_off_[i]) {
      req_.emplace_back();
      MPI_Irecv(recv + flag_off_[i], int(flag_off_[i + 1] - flag_off_[i]), MPI_BYTE, nbs[i].rank, kTag, comm_,
                &req_.back());
    }
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (flag_off_[i + 1] > flag_off_[i]) {
      req_.emplace_back();
      MPI_Isend(send + flag_off_[i], int(flag_off_[i + 1] - flag_off_[i]), MPI_BYTE, nbs[i].rank, kTag, comm_,
                &req_.back());
    }
  MPI_Waitall(int(req_.size()), req_.data(), MPI_STATUSES_IGNORE);
}

std::size_t Halo::node_bytes_sent() const {
  return send_size() * sizeof(Vec3);
}

namespace {
long sums_over_ranks = 0;  // reductions made by sum_over_ranks (sums_over_ranks_made)
}  // namespace

void sum_over_ranks(MPI_Comm comm, double* values, int n) {
  if (size_of(comm) > 1) MPI_Allreduce(MPI_IN_PLACE, values, n, MPI_DOUBLE, MPI_SUM, comm), ++sums_over_ranks;
}

long sums_over_ranks_made() {
  return sums_over_ranks;
}

double sum_over_ranks(MPI_Comm comm, double value) {
  sum_over_ranks(comm, &value, 1);
  return value;
}

double max_over_ranks(MPI_Comm comm, double value) {
  if (size_of(comm) > 1) MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, comm);
  return value;
}

int rank_in(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}

int size_of(MPI_Comm comm) {
  int n = 1;
  MPI_Comm_size(comm, &n);
  return n;
}

void send_bytes(MPI_Comm comm, const std::string& bytes, int to) {
  const std::uint64_t n = bytes.size();
  MPI_Send(&n, 1, MPI_UINT64_T, to, 7, comm);
  constexpr std::uint64_t kPiece = 1u << 30;
  for (std::uint64_t at = 0; at < n; at += kPiece)
    MPI_Send(bytes.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, to, 8, comm);
}

std::string receive_bytes(MPI_Comm comm, int from) {
  std::uint64_t n = 0;
  MPI_Recv(&n, 1, MPI_UINT64_T, from, 7, comm, MPI_STATUS_IGNORE);
  std::string bytes(n, '\0');
  constexpr std::uint64_t kPiece = 1u << 30;
  for (std::uint64_t at = 0; at < n; at += kPiece)
    MPI_Recv(bytes.data() + at, int(std::min(kPiece, n - at)), MPI_BYTE, from, 8, comm, MPI_STATUS_IGNORE);
  return bytes;
}

}  // namespace fdem
