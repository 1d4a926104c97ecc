#include "solver/stable_step.hpp"

#include <mpi.h>

#include <algorithm>
#include <cmath>

#include "core/format.hpp"
#include "physics/surface_loads.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"

namespace fdem {

namespace {

/// Per node, the damping rate (1/s) the dashpots of absorbing faces add: (A/3) z_p / m per face,
/// the row sum of the face's three coupled corners (each takes a third of the face's mean
/// velocity). It adds to the TET4s' damping in the bound, as Weyl's inequality allows.
std::vector<real> dashpot_damping(const Model& m, const Scene& scene, const ElementLaws& laws) {
  std::vector<real> c(m.X.size(), 0);
  std::uint32_t absorbing = 0;
  for (std::size_t i = 0; i < scene.conditions.size(); ++i)
    if (scene.conditions[i].type == ConditionType::absorbing) absorbing |= std::uint32_t(1) << i;
  if (absorbing == 0) return c;
  for (std::size_t k = 0; k < m.surface_faces.size(); ++k) {
    const int faces = __builtin_popcount(m.conditions_of(k) & absorbing);
    if (faces == 0) continue;
    const Tet4Law l = tet4_law_of(laws, m.tet_material, m.tet_stiffness, m.surface_tet[k]);
    const real zp = p_impedance(l.density, l.lambda, l.mu);
    const auto& q = m.surface_faces[k];
    const real area = 0.5 * norm(cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]));
    for (int n : q) c[n] += faces * area * zp / (3 * m.mass[n]);
  }
  return c;
}

}  // namespace

StableStep stable_step_bound(const Model& m, const Scene& scene, const ElementLaws& laws,
                             const std::vector<real>& platen_k, const RankLayout& layout) {
  // An upper bound of the model's highest frequency, node by node (Gershgorin on the rows
  // of M^-1 K, with Weyl's inequality for the sum of parts): the TET4's own eigenvalue
  // (exact per element) plus, for every CE6 node pair and platen spring at the node, the
  // row sum of its stiffness over the node's mass. A split node sits in up to three CE6s,
  // so a one-pair estimate would overstate the stable step by up to sqrt(3).
  const Material& mat = scene.material();  // (the contact penalty: every material's)
  const std::size_t nn = m.X.size();
  std::vector<real> w2_tet(nn, 0), c_tet(nn, 0), g_ce6(nn, 0), g_platen(nn, 0);
  for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
    const Tet4Law l = tet4_law_of(laws, m.tet_material, m.tet_stiffness, t);
    const real w2 = tet4_max_eigenvalue(m.tet_Xinv[t], l.lambda, l.mu, l.density);
    const real c = tet4_max_eigenvalue(m.tet_Xinv[t], 0, 0.5 * m.tet_eta[t], l.density);
    for (int n : m.tet_nodes[t]) {
      w2_tet[n] = std::max(w2_tet[n], w2);
      c_tet[n] = std::max(c_tet[n], c);
    }
  }
  // Each CE6 law's largest penalty; the message names the largest of all.
  std::vector<real> penalty;
  for (const Ce6Params& p : laws.ce6) penalty.push_back(std::max({p.P_open, p.P_tan, p.P_overlap}));
  const real P_max = *std::max_element(penalty.begin(), penalty.end());
  for (std::size_t c = 0; c < m.ce6_nodes.size(); ++c) {
    // A frictional joint's CE6s start broken; with tet-tet contact on they carry no force.
    const int j = laws.joint_of_law(m.ce6_law[c]);
    if (j >= 0 && laws.joint_frictional[j] && laws.ce6[m.ce6_law[c]].broken_inert) continue;
    const auto& q = m.ce6_nodes[c];
    const real P = penalty[m.ce6_law[c]];
    const real area = 0.5 * norm(cross(m.X[q[1]] - m.X[q[0]], m.X[q[2]] - m.X[q[0]]));
    const real k = P * area / (3 * m.ce6_h[c]);  // row sum of the pair's relative stiffness
    for (int i = 0; i < 3; ++i)
      if (q[i] != q[i + 3]) {  // a pair that is one node (region border) has no spring
        g_ce6[q[i]] += 2 * k / m.mass[q[i]];
        g_ce6[q[i + 3]] += 2 * k / m.mass[q[i + 3]];
      }
  }
  // Tet-tet contact: two faces of area A pressed together stiffen by about 4 P_n A (1/h_a + 1/h_b)
  // (the potential gradient is 4/h at a face of altitude h); shared by the face's three nodes,
  // doubled for the Gershgorin row of the coupled pair, for up to three faces of a tet at a node.
  std::vector<real> g_con(nn, 0);
  if (scene.contact.enabled())
    for (std::size_t t = 0; t < m.tet_nodes.size(); ++t) {
      Vec3 xe[4];
      for (int i = 0; i < 4; ++i) xe[i] = m.X[m.tet_nodes[t][i]];
      real amax = 0;
      for (int k = 0; k < 4; ++k)
        amax = std::max(amax, 0.5 * norm(cross(xe[(k + 2) % 4] - xe[(k + 1) % 4], xe[(k + 3) % 4] - xe[(k + 1) % 4])));
      const real k_face = 8 * mat.contact_penalty * amax / tet4_min_altitude(xe);
      for (int n : m.tet_nodes[t]) g_con[n] = std::max(g_con[n], 2 * k_face / m.mass[n]);
    }
  if (scene.platens.enabled)
    for (std::size_t i = 0; i < m.platen_nodes.size(); ++i)
      g_platen[m.platen_nodes[i]] += platen_k[i] / m.mass[m.platen_nodes[i]];

  const std::vector<real> c_dash = dashpot_damping(m, scene, laws);

  StableStep st;
  st.dt = st.dt_tet = st.dt_ce6 = st.dt_platen = st.dt_contact = 1e300;
  std::size_t lim = nn;  // none: a rank that owns no node (a tiny model on many ranks)
  for (std::size_t n = 0; n < nn; ++n) {
    if (!layout.own_node[n]) continue;  // a ghost's row lacks the elements beyond this rank
    const real dt = damped_stable_step(w2_tet[n] + g_ce6[n] + g_platen[n] + g_con[n], c_tet[n] + c_dash[n]);
    if (lim == nn || dt < st.dt) st.dt = dt, lim = n;
    st.dt_tet = std::min(st.dt_tet, damped_stable_step(w2_tet[n], c_tet[n]));
    if (g_ce6[n] > 0) st.dt_ce6 = std::min(st.dt_ce6, 2 / std::sqrt(g_ce6[n]));
    if (g_platen[n] > 0) st.dt_platen = std::min(st.dt_platen, 2 / std::sqrt(g_platen[n]));
    if (g_con[n] > 0) st.dt_contact = std::min(st.dt_contact, 2 / std::sqrt(g_con[n]));
  }
  if (lim < nn) {
    const real w2 = w2_tet[lim] + g_ce6[lim] + g_platen[lim] + g_con[lim];
    auto pct = [&](real part) { return std::to_string(int(std::lround(100 * part / w2))) + " %"; };
    const long lim_id = layout.dd.distributed() ? layout.dd.node_global[lim] : long(lim);
    st.limit = "node " + std::to_string(lim_id + 1) + " (its squared frequency: TET4 " + pct(w2_tet[lim]) +
               ", CE6 penalty " + std::string(laws.ce6.size() > 1 ? "up to " : "") + fmt(P_max, 3) + " Pa " +
               pct(g_ce6[lim]) + ", platen " + pct(g_platen[lim]) + ", contact " + pct(g_con[lim]) + ")";
  }
  if (layout.dd.distributed()) {  // the smallest over the ranks, and the limit named by the rank that has it
    struct {
      double dt;
      int rank;
    } mine{st.dt, layout.dd.rank}, best{};
    MPI_Allreduce(&mine, &best, 1, MPI_DOUBLE_INT, MPI_MINLOC, layout.comm);
    real parts[4] = {st.dt_tet, st.dt_ce6, st.dt_platen, st.dt_contact};
    MPI_Allreduce(MPI_IN_PLACE, parts, 4, MPI_DOUBLE, MPI_MIN, layout.comm);
    st.dt = best.dt;
    st.dt_tet = parts[0], st.dt_ce6 = parts[1], st.dt_platen = parts[2], st.dt_contact = parts[3];
    int len = int(st.limit.size());
    MPI_Bcast(&len, 1, MPI_INT, best.rank, layout.comm);
    st.limit.resize(len);
    MPI_Bcast(st.limit.data(), len, MPI_CHAR, best.rank, layout.comm);
  }
  return st;
}

}  // namespace fdem
