#include "partition/halo.hpp"

#include <cstdlib>
#include <string>

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

Halo::Halo(MPI_Comm comm, const Decomposition& dd) : comm_(comm), dd_(&dd) {
  const std::size_t k = dd.neighbours.size();
  send_off_.assign(1, 0);
  recv_off_.assign(1, 0);
  flag_off_.assign(1, 0);
  for (std::size_t i = 0; i < k; ++i) {
    send_off_.push_back(send_off_.back() + 2 * dd.neighbours[i].send_nodes.size());
    recv_off_.push_back(recv_off_.back() + 2 * dd.neighbours[i].recv_nodes.size());
    flag_off_.push_back(flag_off_.back() + dd.neighbours[i].shared_tets.size());
  }
  send_.resize(send_size());
  recv_.resize(recv_size());
  fsend_.resize(flag_size());
  frecv_.resize(flag_size());
  req_.reserve(2 * k);
}

void Halo::exchange_nodes(const Vec3* send, Vec3* recv) {
  constexpr int kTag = 101;
  const auto& nbs = dd_->neighbours;
  req_.clear();
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (recv_off_[i + 1] > recv_off_[i]) {  // receives posted before the sends
      req_.emplace_back();
      MPI_Irecv(recv + recv_off_[i], int((recv_off_[i + 1] - recv_off_[i]) * sizeof(Vec3)), MPI_BYTE, nbs[i].rank, kTag,
                comm_, &req_.back());
    }
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (send_off_[i + 1] > send_off_[i]) {
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

void Halo::update_nodes(std::vector<Vec3>& x, std::vector<Vec3>& v) {
  const auto& nbs = dd_->neighbours;
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& sn = nbs[i].send_nodes;
    Vec3* out = send_.data() + send_off_[i];
    for (std::size_t j = 0; j < sn.size(); ++j) out[j] = x[sn[j]], out[sn.size() + j] = v[sn[j]];
  }
  exchange_nodes(send_.data(), recv_.data());
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& rn = nbs[i].recv_nodes;
    const Vec3* in = recv_.data() + recv_off_[i];
    for (std::size_t j = 0; j < rn.size(); ++j) x[rn[j]] = in[j], v[rn[j]] = in[rn.size() + j];
  }
}

bool Halo::merge_flags(std::vector<std::uint8_t>& flags) {
  const auto& nbs = dd_->neighbours;
  for (std::size_t i = 0; i < nbs.size(); ++i)
    for (std::size_t j = 0; j < nbs[i].shared_tets.size(); ++j) fsend_[flag_off_[i] + j] = flags[nbs[i].shared_tets[j]];
  exchange_flags(fsend_.data(), frecv_.data());
  bool raised = false;
  for (std::size_t i = 0; i < nbs.size(); ++i)
    for (std::size_t j = 0; j < nbs[i].shared_tets.size(); ++j) {
      const int t = nbs[i].shared_tets[j];
      if (frecv_[flag_off_[i] + j] && !flags[t]) flags[t] = 1, raised = true;
    }
  return raised;
}

std::size_t Halo::node_bytes_sent() const {
  return send_.size() * sizeof(Vec3);
}

void sum_over_ranks(MPI_Comm comm, double* values, int n) {
  if (size_of(comm) > 1) MPI_Allreduce(MPI_IN_PLACE, values, n, MPI_DOUBLE, MPI_SUM, comm);
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

}  // namespace fdem
