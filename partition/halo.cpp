#include "partition/halo.hpp"

namespace fdem {

Halo::Halo(MPI_Comm comm, const Decomposition& dd) : comm_(comm), dd_(&dd) {
  const std::size_t k = dd.neighbours.size();
  send_.resize(k);
  recv_.resize(k);
  fsend_.resize(k);
  frecv_.resize(k);
  for (std::size_t i = 0; i < k; ++i) {
    send_[i].resize(2 * dd.neighbours[i].send_nodes.size());
    recv_[i].resize(2 * dd.neighbours[i].recv_nodes.size());
    fsend_[i].resize(dd.neighbours[i].shared_tets.size());
    frecv_[i].resize(dd.neighbours[i].shared_tets.size());
  }
  req_.reserve(2 * k);
}

void Halo::update_nodes(std::vector<Vec3>& x, std::vector<Vec3>& v) {
  constexpr int kTag = 101;
  const auto& nbs = dd_->neighbours;
  req_.clear();
  for (std::size_t i = 0; i < nbs.size(); ++i)
    if (!recv_[i].empty()) {
      req_.emplace_back();
      MPI_Irecv(recv_[i].data(), int(recv_[i].size() * sizeof(Vec3)), MPI_BYTE, nbs[i].rank, kTag, comm_, &req_.back());
    }
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& s = nbs[i].send_nodes;
    if (s.empty()) continue;
    const std::size_t n = s.size();
    for (std::size_t j = 0; j < n; ++j) send_[i][j] = x[s[j]], send_[i][n + j] = v[s[j]];
    req_.emplace_back();
    MPI_Isend(send_[i].data(), int(send_[i].size() * sizeof(Vec3)), MPI_BYTE, nbs[i].rank, kTag, comm_, &req_.back());
  }
  MPI_Waitall(int(req_.size()), req_.data(), MPI_STATUSES_IGNORE);
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& r = nbs[i].recv_nodes;
    const std::size_t n = r.size();
    for (std::size_t j = 0; j < n; ++j) x[r[j]] = recv_[i][j], v[r[j]] = recv_[i][n + j];
  }
}

bool Halo::merge_flags(std::vector<std::uint8_t>& flags) {
  constexpr int kTag = 102;
  const auto& nbs = dd_->neighbours;
  req_.clear();
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    if (nbs[i].shared_tets.empty()) continue;
    req_.emplace_back();
    MPI_Irecv(frecv_[i].data(), int(frecv_[i].size()), MPI_BYTE, nbs[i].rank, kTag, comm_, &req_.back());
  }
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& s = nbs[i].shared_tets;
    if (s.empty()) continue;
    for (std::size_t j = 0; j < s.size(); ++j) fsend_[i][j] = flags[s[j]];
    req_.emplace_back();
    MPI_Isend(fsend_[i].data(), int(fsend_[i].size()), MPI_BYTE, nbs[i].rank, kTag, comm_, &req_.back());
  }
  MPI_Waitall(int(req_.size()), req_.data(), MPI_STATUSES_IGNORE);
  bool raised = false;
  for (std::size_t i = 0; i < nbs.size(); ++i) {
    const auto& s = nbs[i].shared_tets;
    for (std::size_t j = 0; j < s.size(); ++j)
      if (frecv_[i][j] && !flags[s[j]]) flags[s[j]] = 1, raised = true;
  }
  return raised;
}

std::size_t Halo::node_bytes_sent() const {
  std::size_t b = 0;
  for (const auto& s : send_) b += s.size() * sizeof(Vec3);
  return b;
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
