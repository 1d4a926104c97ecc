#pragma once
// The time loop's halo on several ranks, on any Exec (core/forall.hpp): the halo's packed
// layout (partition/halo.hpp) as device index lists, the ghosts' x and v from their owners, and
// the activation flags OR-ed among the ranks that hold a tet. Buffers go to MPI as they are
// where it reads device memory (GPU-aware MPI, or host memory on the cpu backend), else staged
// through the host.
#include <mpi.h>

#include <array>
#include <cstdint>
#include <vector>

#include "contact/bonded.hpp"
#include "core/device_memory.hpp"
#include "core/forall.hpp"
#include "core/vec.hpp"
#include "partition/halo.hpp"
#include "partition/partition.hpp"

namespace fdem {

template <class Exec>
class HaloPasses {
 public:
  /// `direct_mpi`: MPI reads and writes the device buffers.
  void set_backend(Backend b, bool direct_mpi) {
    direct_mpi_ = direct_mpi;
    auto set = [&](auto&... a) { (a.set_backend(b), ...); };
    set(send_node_, send_x_, send_v_, recv_node_, recv_x_, recv_v_, flag_tet_, send_, recv_, flag_send_, flag_recv_);
  }

  /// The layout of halo h on decomposition dd: the shared tets' flags and the node lists.
  void plan(const Halo& h, const Decomposition& dd) {
    std::vector<int> ft;
    for (const Neighbour& nb : dd.neighbours)
      for (int t : nb.shared_tets) ft.push_back(t);
    flag_tet_.upload(ft);
    flag_send_.resize(h.flag_size());
    flag_recv_.resize(h.flag_size());
    host_fsend_.resize(h.flag_size());  // also with direct MPI: the merged flags for the node lists
    host_frecv_.resize(h.flag_size());
    shared_active_ = -1;
    plan_node_lists(h);
  }

  /// Ghost nodes take their owners' x and v: packed, handed to MPI, unpacked. With `only`: the
  /// neighbours i with only[i] set (Halo::exchange_nodes). Adds its wall time to `seconds`.
  void update_nodes(Halo& h, DeviceArray<Vec3>& x, DeviceArray<Vec3>& v, double& seconds,
                    const std::vector<char>* only = nullptr) {
    const double w0 = MPI_Wtime();
    const Vec3* xr = x.data();
    const Vec3* vr = v.data();
    Vec3* buf = send_.data();
    const int* sn = send_node_.data();
    const int* sx = send_x_.data();
    const int* sv = send_v_.data();
    Exec::forall(int(send_node_.size()), [=] FDEM_LAMBDA(int j) {
      buf[sx[j]] = xr[sn[j]];
      buf[sv[j]] = vr[sn[j]];
    });
    if (direct_mpi_) {
      Exec::synchronize();  // the packing kernel has finished before MPI reads the buffer
      h.exchange_nodes(send_.data(), recv_.data(), only);
    } else {
      send_.download(host_send_.data());
      h.exchange_nodes(host_send_.data(), host_recv_.data(), only);
      recv_.upload(host_recv_.data(), host_recv_.size());
    }
    if (!only) {
      unpack(x, v, 0, recv_range_.back());
    } else {
      for (std::size_t i = 0; i + 1 < recv_range_.size(); ++i)
        if ((*only)[i]) unpack(x, v, recv_range_[i], recv_range_[i + 1]);
    }
    seconds += MPI_Wtime() - w0;
  }

  /// A tet's contact flags (TetFlag: candidate, opened faces) OR-ed among the ranks holding it;
  /// true when one was raised here. When the shared tets' candidate flags changed, the node lists follow them and the
  /// new ghosts take their owners' x and v at once (Halo::follow_flags).
  bool merge_flags(Halo& h, DeviceArray<std::uint8_t>& active, DeviceArray<Vec3>& x, DeviceArray<Vec3>& v,
                   double& seconds) {
    const std::uint8_t* act = active.data();
    std::uint8_t* out = flag_send_.data();
    const int* ft = flag_tet_.data();
    const int nf = int(flag_tet_.size());
    Exec::forall(nf, [=] FDEM_LAMBDA(int j) { out[j] = act[ft[j]]; });
    if (direct_mpi_) {
      Exec::synchronize();
      h.exchange_flags(flag_send_.data(), flag_recv_.data());
    } else {
      flag_send_.download(host_fsend_.data());
      h.exchange_flags(host_fsend_.data(), host_frecv_.data());
      flag_recv_.upload(host_frecv_.data(), host_frecv_.size());
    }
    std::uint8_t* aw = active.data();
    const std::uint8_t* in = flag_recv_.data();
    const std::uint8_t* mine = flag_send_.data();
    const std::array<real, 2> r = Exec::template sum<2>(nf, [=] FDEM_LAMBDA(int j, real* acc) {
      if (in[j] && raise_bits(aw + ft[j], in[j])) acc[0] += 1;  // (a tet listed for two ranks: raised once)
      acc[1] += ((in[j] | mine[j]) & TetFlag::kCandidate) != 0;
    });
    if (long(r[1]) != shared_active_) {  // flags only rise: an unchanged count is an unchanged set
      shared_active_ = long(r[1]);
      if (direct_mpi_) {
        flag_send_.download(host_fsend_.data());
        flag_recv_.download(host_frecv_.data());
      }
      h.follow_flags(host_fsend_.data(), host_frecv_.data());
      if (!h.grown().empty()) {
        plan_node_lists(h);
        update_nodes(h, x, v, seconds, &h.grown());
      }
    }
    return r[0] > 0;
  }

  /// Bytes of the packed buffers (a step sends and receives each once).
  double bytes() const { return double(send_.size() + recv_.size()) * sizeof(Vec3); }

  // (Public, as every function holding a pass: nvcc's extended lambdas need their enclosing
  // function public.)
  /// The node lists (they grow as tets activate, Halo::follow_flags) as device index lists.
  void plan_node_lists(const Halo& h) {
    std::vector<int> sn, sx, sv, rn, rx, rv;
    recv_range_.assign(1, 0);
    for (std::size_t i = 0; i < h.neighbours(); ++i) {
      const auto& a = h.send_nodes(i);
      for (std::size_t j = 0; j < a.size(); ++j) sn.push_back(a[j]), sx.push_back(int(h.send_offset(i) + j));
      const auto& b = h.recv_nodes(i);
      for (std::size_t j = 0; j < b.size(); ++j) rn.push_back(b[j]), rx.push_back(int(h.recv_offset(i) + j));
      // The v of a neighbour's nodes follow their x: offset + count.
      for (std::size_t j = 0; j < a.size(); ++j) sv.push_back(int(h.send_offset(i) + a.size() + j));
      for (std::size_t j = 0; j < b.size(); ++j) rv.push_back(int(h.recv_offset(i) + b.size() + j));
      recv_range_.push_back(int(rn.size()));
    }
    send_node_.upload(sn);
    send_x_.upload(sx);
    send_v_.upload(sv);
    recv_node_.upload(rn);
    recv_x_.upload(rx);
    recv_v_.upload(rv);
    send_.resize(h.send_size());
    recv_.resize(h.recv_size());
    if (!direct_mpi_) {
      host_send_.resize(h.send_size());
      host_recv_.resize(h.recv_size());
    }
  }

  /// Entries first .. last-1 of the receive index lists: ghost x and v from the receive buffer.
  void unpack(DeviceArray<Vec3>& x, DeviceArray<Vec3>& v, int first, int last) {
    Vec3* xw = x.data();
    Vec3* vw = v.data();
    const Vec3* in = recv_.data();
    const int* rn = recv_node_.data();
    const int* rx = recv_x_.data();
    const int* rv = recv_v_.data();
    Exec::forall(last - first, [=] FDEM_LAMBDA(int k) {
      const int j = first + k;
      xw[rn[j]] = in[rx[j]];
      vw[rn[j]] = in[rv[j]];
    });
  }

 private:
  bool direct_mpi_ = false;
  // The packed buffers' index lists: node, and its place for x and v in the buffer.
  DeviceArray<int> send_node_, send_x_, send_v_, recv_node_, recv_x_, recv_v_;
  DeviceArray<int> flag_tet_;  // the shared tets, in the flags' buffer order
  DeviceArray<Vec3> send_, recv_;
  DeviceArray<std::uint8_t> flag_send_, flag_recv_;
  std::vector<Vec3> host_send_, host_recv_;            // staging (empty when direct_mpi_)
  std::vector<std::uint8_t> host_fsend_, host_frecv_;  // staging, and the merged flags for the lists
  std::vector<int> recv_range_;                        // neighbour i's entries of the receive index lists: [i], [i+1]
  long shared_active_ = -1;                            // active flags among the shared tets at the last merge
};

}  // namespace fdem
