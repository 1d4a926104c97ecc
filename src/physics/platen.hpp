#pragma once
// Rigid platen: an analytic plane with unit normal n pointing into the rock.
// Node-to-plane penalty: gap g = (p - x).n > 0 means the node is inside the platen;
// normal force k g n with k = P_n_con A_trib / h (N/m). Coulomb friction by a
// tangential elastic predictor k_t = k anchored at `anchor` (the stick point, in
// platen coordinates): t = -k (x_t - anchor); if |t| > mu k g the anchor slides so
// that |t| = mu k g. Out of contact the anchor follows the node.
#include "core/vec.hpp"

namespace fdem {

struct PlatenEval {
  Vec3 force;       // on the node, N
  real stored;      // penalty + friction-spring energy, J
  real dissipated;  // friction work in this call (slip distance x friction force), J
};

/// `xr` is the node position relative to the platen's reference point (moves with it).
FDEM_HD PlatenEval platen_node_force(Vec3 xr, Vec3 n, real k, real mu, Vec3& anchor) {
  PlatenEval e{{0, 0, 0}, 0, 0};
  const real g = -dot(xr, n);
  const Vec3 xt = xr - dot(xr, n) * n;  // tangential position on the platen
  if (!(g > 0)) {
    anchor = xt;
    return e;
  }
  const real fn = k * g;
  Vec3 d = xt - anchor;
  real dn = norm(d);
  const real limit = mu * fn;
  if (k * dn > limit) {
    const real keep = limit / k;  // spring length at the slip limit
    const Vec3 dir = (1 / dn) * d;
    const Vec3 new_anchor = xt - keep * dir;
    e.dissipated = limit * norm(new_anchor - anchor);
    anchor = new_anchor;
    d = keep * dir;
    dn = keep;
  }
  e.force = fn * n - k * d;
  e.stored = real(0.5) * k * (g * g + dn * dn);
  return e;
}

/// Two platens along z, the top one's face at height ztop pressing down, the bottom one's at zbot
/// pressing up: node x meets the nearer one only (`top`: which). Its force as platen_node_force.
FDEM_HD PlatenEval nearer_platen_force(Vec3 x, real ztop, real zbot, real k, real mu, Vec3& anchor, bool& top) {
  top = x.z > real(0.5) * (ztop + zbot);
  return platen_node_force(x - Vec3{0, 0, top ? ztop : zbot}, Vec3{0, 0, top ? real(-1) : real(1)}, k, mu, anchor);
}

}  // namespace fdem
