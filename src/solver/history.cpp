// History entries: monitors.csv follows the displacement, velocity and stress at a few points
// of the rock, or over mesh groups. Each point lies in one tet of the reference configuration;
// the rank that owns that tet interpolates its nodes' values with the point's barycentric
// weights. A group's means are sums over every rank's own nodes and tets.
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
    if (!scene_.history[i].group.empty()) continue;  // (a group: its nodes and tets are marked)
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

/// Group entries: per entry, the sums of u, v and 1 over its own nodes, then of V s and V over its
/// own tets (14 values each).
std::vector<real> Solver::history_group_sums() const {
  const Model& m = model_;
  const std::size_t ne = scene_.history.size();
  std::vector<real> sums(14 * ne, 0);
  if (m.node_history.empty() && m.tet_history.empty()) return sums;
  for (std::size_t n = 0; n < m.X.size(); ++n) {
    const std::uint32_t bits = m.node_history_of(n);
    if (!bits || !layout_.own_node[n]) continue;
    const Vec3 u = state.x[n] - m.X[n], v = state.v[n];
    const real values[7] = {u.x, u.y, u.z, v.x, v.y, v.z, 1};
    for (std::size_t i = 0; i < ne; ++i)
      if (bits >> i & 1)
        for (int k = 0; k < 7; ++k) sums[14 * i + k] += values[k];
  }
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const std::uint32_t bits = m.tet_history.empty() ? 0 : m.tet_history[t];
    if (!bits || !layout_.own_tet[t]) continue;
    Vec3 x[4], vel[4], f[4];
    for (int k = 0; k < 4; ++k) x[k] = state.x[m.tet_nodes[t][k]], vel[k] = state.v[m.tet_nodes[t][k]];
    const Tet4Law law = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, t);
    const Sym3 s =
        tet4_forces(x, vel, m.tet_Xinv[t], m.tet_V0[t], law.lambda, law.mu, m.tet_eta[t], f, m.initial_stress_of(t))
            .stress;
    const real V = m.tet_V0[t];
    const real values[7] = {V * s.xx, V * s.yy, V * s.zz, V * s.xy, V * s.yz, V * s.xz, V};
    for (std::size_t i = 0; i < ne; ++i)
      if (bits >> i & 1)
        for (int k = 0; k < 7; ++k) sums[14 * i + 7 + k] += values[k];
  }
  return sums;
}

/// A point's 12 values: u and v interpolated in its tet, and the tet's stress.
std::array<real, HistoryPoint::kColumns> Solver::history_point_values(const HistoryProbe& p) const {
  const Model& m = model_;
  Vec3 x[4], vel[4], f[4], u{0, 0, 0}, rate{0, 0, 0};
  for (int k = 0; k < 4; ++k) {
    const int n = m.tet_nodes[p.tet][k];
    x[k] = state.x[n], vel[k] = state.v[n];
    u += p.w[k] * (state.x[n] - m.X[n]);
    rate += p.w[k] * state.v[n];
  }
  const Tet4Law law = tet4_law_of(laws_, m.tet_material, m.tet_stiffness, p.tet);
  const Sym3 s = tet4_forces(x, vel, m.tet_Xinv[p.tet], m.tet_V0[p.tet], law.lambda, law.mu, m.tet_eta[p.tet], f,
                             m.initial_stress_of(p.tet))
                     .stress;
  return {u.x, u.y, u.z, rate.x, rate.y, rate.z, s.xx, s.yy, s.zz, s.xy, s.yz, s.xz};
}

void Solver::history_columns(Monitors& r) {
  if (probes_.empty()) return;
  sync_host();
  const std::size_t ne = probes_.size(), nc = HistoryPoint::kColumns;
  // The points' values (from the rank that holds each), then the groups' sums: one reduction.
  std::vector<real> v(nc * ne, 0);
  for (std::size_t i = 0; i < ne; ++i)
    if (probes_[i].tet >= 0) {
      const auto values = history_point_values(probes_[i]);
      std::copy(values.begin(), values.end(), v.begin() + nc * i);
    }
  const std::vector<real> group_sums = history_group_sums();
  v.insert(v.end(), group_sums.begin(), group_sums.end());
  if (layout_.distributed()) layout_.sum(v.data(), int(v.size()));
  for (std::size_t i = 0; i < ne; ++i) {
    if (scene_.history[i].group.empty()) continue;
    const real* g = v.data() + nc * ne + 14 * i;  // (u, v over the nodes; volume-weighted stress)
    for (int k = 0; k < 6; ++k) v[nc * i + k] = g[6] > 0 ? g[k] / g[6] : 0;
    for (int k = 0; k < 6; ++k) v[nc * i + 6 + k] = g[13] > 0 ? g[7 + k] / g[13] : 0;
  }
  r.history_columns = int(nc * ne);
  std::copy(v.begin(), v.begin() + nc * ne, r.history.begin());
}

}  // namespace fdem
