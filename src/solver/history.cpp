// History points: monitors.csv follows the displacement, velocity and stress at a few points
// of the rock. Each point lies in one tet of the reference configuration; the rank that owns
// that tet interpolates its nodes' values with the point's barycentric weights.
#include <mpi.h>

#include <climits>

#include "core/error.hpp"
#include "core/format.hpp"
#include "model/laws.hpp"
#include "physics/tet4.hpp"
#include "solver/solver.hpp"

namespace fdem {

namespace {

/// The barycentric weights of point p in tet t of m (reference configuration).
std::array<real, 4> weights_in(const Model& m, int t, Vec3 p) {
  const Vec3 xi = m.tet_Xinv[t] * (p - m.X[m.tet_nodes[t][0]]);
  return {1 - xi.x - xi.y - xi.z, xi.x, xi.y, xi.z};
}

}  // namespace

void Solver::locate_history_points() {
  const Model& m = model_;
  probes_.assign(scene_.history.size(), HistoryProbe{});
  const real slack = -1e-9;  // (a point on a face or edge is in both tets: the lower input number wins)
  for (std::size_t i = 0; i < scene_.history.size(); ++i) {
    int best = INT_MAX;
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
      if (!layout_.own_tet[t] || m.tet_input[t] >= best) continue;
      const std::array<real, 4> w = weights_in(m, int(t), scene_.history[i].at);
      if (w[0] >= slack && w[1] >= slack && w[2] >= slack && w[3] >= slack)
        best = m.tet_input[t], probes_[i] = HistoryProbe{int(t), w};
    }
    int first = best;
    if (layout_.distributed()) MPI_Allreduce(&best, &first, 1, MPI_INT, MPI_MIN, layout_.comm);
    if (first == INT_MAX) {
      const Vec3 p = scene_.history[i].at;
      throw InputError(scene_.file + ": history[" + std::to_string(i) + "] ('" + scene_.history[i].name + "').at: (" +
                       fmt(p.x) + ", " + fmt(p.y) + ", " + fmt(p.z) +
                       ") m is in no tet of the model; give a point inside the rock (reference positions, m)");
    }
    if (best != first) probes_[i] = HistoryProbe{};
  }
}

void Solver::history_columns(Monitors& r) {
  if (probes_.empty()) return;
  sync_host();
  const Model& m = model_;
  std::vector<real> v(HistoryPoint::kColumns * probes_.size(), 0);
  for (std::size_t i = 0; i < probes_.size(); ++i) {
    const HistoryProbe& p = probes_[i];
    if (p.tet < 0) continue;
    Vec3 x[4], vel[4], f[4], u{0, 0, 0}, rate{0, 0, 0};
    for (int k = 0; k < 4; ++k) {
      const int n = m.tet_nodes[p.tet][k];
      x[k] = state.x[n], vel[k] = state.v[n];
      u += p.w[k] * (state.x[n] - m.X[n]);
      rate += p.w[k] * state.v[n];
    }
    const Tet4Law law = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, p.tet);
    const Sym3 s =
        tet4_forces(x, vel, m.tet_Xinv[p.tet], m.tet_V0[p.tet], law.lambda, law.mu, m.tet_eta[p.tet], f).stress;
    const real values[HistoryPoint::kColumns] = {u.x,  u.y,  u.z,  rate.x, rate.y, rate.z,
                                                 s.xx, s.yy, s.zz, s.xy,   s.yz,   s.xz};
    std::copy(values, values + HistoryPoint::kColumns, v.begin() + HistoryPoint::kColumns * i);
  }
  if (layout_.distributed()) layout_.sum(v.data(), int(v.size()));  // (one rank holds each point)
  r.history_columns = int(v.size());
  std::copy(v.begin(), v.end(), r.history.begin());
}

}  // namespace fdem
