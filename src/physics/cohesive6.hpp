#pragma once
// CE6: six-node zero-thickness intrinsic cohesive element between tets A and B.
// Nodes 0,1,2 on A's face, 3,4,5 the paired nodes of B (same vertices, same order);
// n by the right-hand rule 0->1->2 points from A into B.
//
//   m_i = (x_i + x_{i+3})/2,  n = unit((m1-m0) x (m2-m0)),  A = |.|/2
//   d_i = x_{i+3} - x_i (reference gap 0); point k at the midpoint of edge (k, k+1 mod 3):
//   d_k = (d_k + d_{k+1})/2,  o = n.d_k,  s_vec = d_k - o n,  s = |s_vec|,  weight A/3
//   overlap (o<0):  sigma = P_overlap o / h         (never damaged, also when broken)
//   tension (o>=0): o_p = 2 h f_t / P_open, x = o/o_p, sigma = z(D) f_t (2x - x^2) (x<1), z(D) f_t (x>=1)
//   shear:          f_s = c + max(0, -sigma_overlap) tan(phi)
//                   s_p = 2 h f_s / P_tan,  y = s/s_p, tau = z(D) f_s (2y - y^2) (y<1), z(D) f_s (y>=1)
//   softening:      o_r = o_p + (G_I  - 2/3 f_t o_p)/(f_t Z),  s_r = s_p + (G_II - 2/3 f_s s_p)/(f_s Z),
//                   Z = int_0^1 z(D) dD, so the work of a monotone pure-mode separation is G exactly.
//   damage:         Dn = max(0, o-o_p)/(o_r-o_p), Ds = max(0, s-s_p)/(s_r-s_p),
//                   D = max(D_old, min(1, sqrt(Dn^2 + Ds^2)))
//   z(D):           Munjiza: [1 - (a+b-1)/(a+b) exp(D (a+c b)/((a+b)(1-a-b)))] [a(1-D) + b(1-D)^c],
//                   a = 0.63, b = 1.8, c = 6;  linear: 1 - D
//   broken (>= 2 of 3 points at D = 1; mode from Dn^2/(Dn^2+Ds^2) of those points: >= 0.9 I,
//   <= 0.1 II, else mixed): no cohesion. With tet-tet contact on (broken_inert) no force at
//   all: the faces meet through contact. Otherwise: overlap penalty + Coulomb friction with an elastic
//   predictor tau_trial = (P_tan/h)(s_vec - slip_t), |tau| <= mu_rock |sigma|; open: traction 0.
//   slip_t: the anchor on the current plane: s_vec of the step before the break (stored while the
//   CE6 is damaged; s_vec of the break step itself if it broke straight from undamaged), then
//   moved by the return to |tau| = mu_rock |sigma| and by opening.
//   traction t_k = sigma n + tau s_vec/s; force (A/3) t_k shared half/half by the two node pairs
//   of point k: +(A/6) t_k on the A node, -(A/6) t_k on the B node (opening pulls B back).
//   power  = sum_k (A/3) t_k . d_k_dot = -sum_i f_i . v_i
//   stored = sum_k (A/3) [z(D)(Phi_n(o) + Phi_s(s)) + P_overlap o^2/(2h) (o<0)],
//            Phi(a) = f p (x^2 - x^3/3) for x = a/p < 1, f (a - p/3) beyond;
//            broken: overlap energy + (P_tan/h)|s_vec - slip|^2 / 2.
//   in-situ stress (scene initial_stress): a constant offset added to each point's opening,
//   o += o0_k and s_vec += s1_k e1 + s2_k e2 with e1 = unit(m1 - m0), e2 = n x e1 turning with the
//   face, chosen (model/initial_stress.cpp) so that the law gives the in-situ traction at zero
//   gap. Damage and strength then see the whole traction, in-situ part included.
#include <cmath>

#include "core/config.hpp"
#include "core/portable_math.hpp"
#include "core/vec.hpp"

namespace fdem {

/// CE6 parameters, derived once on the host from the scene's material (model/laws.hpp).
struct Ce6Params {
  real ft, cohesion, tan_phi, GI, GII, P_open, P_tan, P_overlap, mu_rock;
  int softening;     // 0 = Munjiza (a=0.63, b=1.8, c=6), 1 = linear z = 1 - D
  int broken_inert;  // 1: a broken CE6 carries no force (tet-tet contact takes over its faces)
  int joint;         // 1: a joint's law (counted apart from the rock's)
  real Z;            // integral of z(D) over D in [0,1] for the chosen curve
};

/// What every step reads of a CE6 (32 bytes); zero-initialised = intact. The law writes it
/// only when it changes (damage rising, the break), so an undamaged CE6 costs a read of these
/// bytes and no write.
struct Ce6Damage {
  real D[3];         // damage at the 3 integration points, monotone, in [0,1]
  int mode;          // 0 intact, 1 broke in mode I, 2 mode II, 3 mixed, 4 never bonded, 5 excavated
  int reserved = 0;  // no padding bytes: checkpoints hold the state byte for byte
};

/// Per-CE6 persistent state: its damage and the friction anchors (global coordinates) that a
/// broken CE6's friction starts from. While the CE6 is damaged the anchors follow its sliding,
/// so at the break they hold the last step's; while it is undamaged they are neither read nor
/// written (nor once broken when tet-tet contact takes over its faces), which spares the loop
/// their bytes for most CE6s.
struct Ce6State : Ce6Damage {
  Vec3 slip[3];
};
static_assert(sizeof(Ce6Damage) == 32 && sizeof(Ce6State) == 32 + 3 * sizeof(Vec3), "no padding in the CE6 state");

/// The friction anchors of one CE6, where a loop keeps them apart from the damage.
struct Ce6Anchors {
  Vec3 a[3];
};

/// One CE6's state as one value, from its damage and its anchors kept apart.
inline Ce6State ce6_state_of(const Ce6Damage& d, const Ce6Anchors& a) {
  Ce6State s;
  static_cast<Ce6Damage&>(s) = d;
  for (int j = 0; j < 3; ++j) s.slip[j] = a.a[j];
  return s;
}

/// Per CE6 the opening offsets of its three points in the face's own frame (m): x along n, y
/// along e1, z along e2 (see above). Only where the scene has an in-situ stress.
struct Ce6Prestress {
  Vec3 at[3];
};

/// power: rate of work the interface absorbs (W); stored: recoverable elastic energy (J).
struct Ce6Eval {
  real power;
  real stored;
};

/// Softening curve z(D): 1 at D <= 0, 0 at D >= 1.
FDEM_HD real softening_z(real D, int softening) {
  if (D <= 0) return 1;
  if (D >= 1) return 0;
  const real u = 1 - D;
  if (softening == 1) return u;
  const real a = real(0.63), b = real(1.8), c = 6;
  const real ab = a + b;
  const real u2 = u * u;
  const real uc = u2 * u2 * u2;  // (1-D)^c with c = 6
  return (1 - ((ab - 1) / ab) * portable_exp(D * (a + c * b) / (ab * (1 - ab)))) * (a * u + b * uc);
}

/// Z = integral of z over [0,1]: exact 1/2 for linear, composite Simpson (1024 intervals,
/// error below 1e-11) for Munjiza.
FDEM_HD real softening_integral(int softening) {
  if (softening == 1) return real(0.5);
  const int n = 1024;
  const real dq = real(1) / n;
  real sum = softening_z(0, softening) + softening_z(1, softening);
  for (int i = 1; i < n; ++i) sum += real(i % 2 ? 4 : 2) * softening_z(i * dq, softening);
  return sum * dq / 3;
}

/// The mode of a CE6 broken before the run: a frictional joint's (Solver::break_frictional_joints).
constexpr int kCe6NeverBonded = 4;
/// The mode of a CE6 an excavation removed (solver/excavation.cpp): no force, counted nowhere.
constexpr int kCe6Excavated = 5;

FDEM_HD bool ce6_broken(const Ce6Damage& s) {
  return s.mode != 0;
}

/// False for a broken CE6 when tet-tet contact takes over its faces: the law gives it no force
/// and changes nothing, so a loop may skip it without reading its nodes.
FDEM_HD bool ce6_carries_force(const Ce6Params& p, const Ce6Damage& s) {
  return !(s.mode != 0 && (p.broken_inert || s.mode == kCe6Excavated));
}

FDEM_HD real ce6_max_damage(const Ce6Damage& s) {
  real d = s.D[0];
  if (s.D[1] > d) d = s.D[1];
  if (s.D[2] > d) d = s.D[2];
  return d;
}

namespace ce6_detail {

/// The pre-peak curve at a >= 0 for peak p and strength f: the value f (2x - x^2) for x = a/p < 1
/// and f beyond, its integral from 0 (f p (x^2 - x^3/3), f (a - p/3) beyond), and the value
/// over a (0 at a = 0), which shear puts on its slip vector. One division either way.
struct PrepeakPoint {
  real value, energy, per_a;
};
FDEM_HD PrepeakPoint prepeak(real a, real peak, real strength) {
  if (a >= peak) return {strength, strength * (a - peak / 3), a > 0 ? strength / a : real(0)};
  const real ip = 1 / peak;  // peak > a >= 0 here
  const real x = a * ip;
  return {strength * x * (2 - x), strength * peak * x * x * (1 - x / 3), strength * (2 - x) * ip};
}

/// Softening width (r - p) for strength f, peak p and fracture energy G; <= 0 means none.
FDEM_HD real softening_width(real G, real f, real p, real Z) {
  const real den = f * Z;
  return den > 0 ? (G - real(2) / 3 * f * p) / den : real(0);
}

/// Damage measure past the peak p of strength f and fracture energy G: 0 up to p, then (a - p)/w
/// for the softening width w, or 1 at once where there is none. The width is taken only past the
/// peak: below it (most CE6s on most steps) its division is not needed.
FDEM_HD real past_peak(real a, real p, real G, real f, real Z) {
  if (!(a > p)) return 0;
  const real w = softening_width(G, f, p, Z);
  return w > 0 ? (a - p) / w : real(1);
}

/// Breaking: at least two points fully damaged; the mode from those points' mix of the
/// opening and slip damage measures Dn, Ds.
FDEM_HD void ce6_break_mode(Ce6Damage& s, const real (&Dn)[3], const real (&Ds)[3]) {
  int count = 0;
  real num = 0, den = 0;
  for (int k = 0; k < 3; ++k) {
    if (s.D[k] >= 1) {
      ++count;
      num += Dn[k] * Dn[k];
      den += Dn[k] * Dn[k] + Ds[k] * Ds[k];
    }
  }
  if (count >= 2) {
    const real share = den > 0 ? num / den : real(0.5);
    s.mode = share >= real(0.9) ? 1 : (share <= real(0.1) ? 2 : 3);
  }
}

/// Coulomb friction of a broken point in overlap, up to tmax (Pa) with spring stiffness k_t
/// (Pa/m) on slip sv: an elastic predictor on the anchor projected to the current plane. The
/// anchor is the last step's sliding on the step of the break (anchor_stored); it is this
/// step's, so no friction, where the CE6 went from undamaged to broken in one step and stored
/// none. Adds the traction to t and its stored energy per unit area to e.
FDEM_HD void ce6_friction(real tmax, real k_t, Vec3 n, Vec3 sv, bool anchor_stored, Vec3& anchor_k, Vec3& t, real& e) {
  const Vec3 anchor = anchor_stored ? anchor_k - dot(n, anchor_k) * n : sv;
  const Vec3 rel = sv - anchor;
  const Vec3 trial = k_t * rel;
  const real tn = norm(trial);
  if (tn > tmax && tn > 0) {
    const Vec3 dir = (real(1) / tn) * trial;
    anchor_k = sv - (k_t > 0 ? tmax / k_t : real(0)) * dir;
    t += tmax * dir;
    e += k_t > 0 ? real(0.5) * tmax * tmax / k_t : real(0);
  } else {
    anchor_k = anchor;
    t += trial;
    e += real(0.5) * k_t * dot(rel, rel);
  }
}

}  // namespace ce6_detail

/// Forces on the six nodes (overwritten), damage and mode update of `s` and of the friction
/// anchors (damaged or broken CE6s only), power and stored energy. h is the element's characteristic size.
/// `strength` scales the tensile strength and the cohesion of this element (a heterogeneous
/// rock's draw); its fracture energies stay, so it still dissipates G A. `pre`: its in-situ
/// offsets, or null for none.
FDEM_HD Ce6Eval cohesive6_forces(const Ce6Params& p, const Vec3 (&x)[6], const Vec3 (&v)[6], real h, Ce6Damage& s,
                                 Vec3 (&anchors)[3], Vec3 (&f)[6], real strength = 1,
                                 const Ce6Prestress* pre = nullptr) {
  using namespace ce6_detail;
  for (int i = 0; i < 6; ++i) f[i] = Vec3{0, 0, 0};
  Ce6Eval out{0, 0};
  if (!ce6_carries_force(p, s)) return out;

  const Vec3 m0 = real(0.5) * (x[0] + x[3]);
  const Vec3 m1 = real(0.5) * (x[1] + x[4]);
  const Vec3 m2 = real(0.5) * (x[2] + x[5]);
  const Vec3 nn = cross(m1 - m0, m2 - m0);
  const real n2 = norm(nn);  // 2 A
  if (!(n2 > 0) || !(h > 0)) return out;
  const Vec3 n = (real(1) / n2) * nn;
  const real w = n2 * (real(1) / 6);  // A/3, weight of one integration point

  // Divisions and square roots are most of an intact CE6's cost: each is taken once per CE6
  // where it can be, and only where its result is used.
  const real k_ov = p.P_overlap / h;  // overlap stiffness per unit area
  const real ft = strength * p.ft, cohesion = strength * p.cohesion;
  const real o_p = p.P_open > 0 ? 2 * h * ft / p.P_open : real(0);
  const real sp_per_fs = p.P_tan > 0 ? 2 * h / p.P_tan : real(0);  // shear peak slip per unit strength

  Vec3 e1{0, 0, 0}, e2{0, 0, 0};  // the face's own frame, for the in-situ offsets
  if (pre) {
    const Vec3 a = m1 - m0;
    e1 = (real(1) / norm(a)) * a;
    e2 = cross(n, e1);
  }
  Vec3 d[3], dd[3];
  for (int i = 0; i < 3; ++i) {
    d[i] = x[i + 3] - x[i];
    dd[i] = v[i + 3] - v[i];
  }

  // Kinematics at the three points and, while intact, the damage update.
  real o[3], sl[3], fs[3], sp[3], Dn[3], Ds[3];
  Vec3 sv[3], dkdot[3];
  const bool was_broken = s.mode != 0;
  const bool had_damage = ce6_max_damage(s) > 0;  // anchors stored on the last step
  for (int k = 0; k < 3; ++k) {
    const int a = k, b = (k + 1) % 3;
    const Vec3 dk = real(0.5) * (d[a] + d[b]);
    dkdot[k] = real(0.5) * (dd[a] + dd[b]);
    o[k] = dot(n, dk);
    sv[k] = dk - o[k] * n;
    if (pre) o[k] += pre->at[k].x, sv[k] += pre->at[k].y * e1 + pre->at[k].z * e2;
    sl[k] = norm(sv[k]);
    const real sig_ov = o[k] < 0 ? k_ov * o[k] : real(0);
    fs[k] = cohesion + (-sig_ov) * p.tan_phi;
    sp[k] = sp_per_fs * fs[k];
    Dn[k] = past_peak(o[k], o_p, p.GI, ft, p.Z);
    Ds[k] = past_peak(sl[k], sp[k], p.GII, fs[k], p.Z);
    if (!was_broken && (Dn[k] > 0 || Ds[k] > 0)) {  // below both peaks the damage stays
      real Dc = std::sqrt(Dn[k] * Dn[k] + Ds[k] * Ds[k]);
      if (Dc > 1) Dc = 1;
      if (Dc > s.D[k]) s.D[k] = Dc;
    }
  }

  if (!was_broken) ce6_break_mode(s, Dn, Ds);
  const bool broken = s.mode != 0;
  const bool damaged = ce6_max_damage(s) > 0;  // anchors are kept from the first damage on

  for (int k = 0; k < 3; ++k) {
    Vec3 t{0, 0, 0};
    real e = 0;  // stored energy per unit area
    if (o[k] < 0) {
      const real sig = k_ov * o[k];
      t = sig * n;
      e = real(0.5) * k_ov * o[k] * o[k];
    }
    if (broken) {
      if (o[k] < 0) {
        const real tmax = p.mu_rock * (-k_ov * o[k]);
        const real k_t = p.P_tan / h;  // the friction spring's stiffness per unit area
        ce6_friction(tmax, k_t, n, sv[k], was_broken || had_damage, anchors[k], t, e);
      } else {
        anchors[k] = sv[k];
      }
    } else {
      const real z = softening_z(s.D[k], p.softening);
      if (damaged) anchors[k] = sv[k];  // the anchor follows until the break
      if (o[k] >= 0) {
        const PrepeakPoint c = prepeak(o[k], o_p, ft);
        t = (z * c.value) * n;
        e = z * c.energy;
      }
      if (sl[k] > 0) {
        const PrepeakPoint c = prepeak(sl[k], sp[k], fs[k]);
        t += (z * c.per_a) * sv[k];
        e += z * c.energy;
      }
    }
    out.power += w * dot(t, dkdot[k]);
    out.stored += w * e;
    const Vec3 fk = real(0.5) * w * t;
    const int a = k, b = (k + 1) % 3;
    f[a] += fk;
    f[b] += fk;
    f[a + 3] -= fk;
    f[b + 3] -= fk;
  }
  return out;
}

/// The same for a whole Ce6State (damage and anchors together).
FDEM_HD Ce6Eval cohesive6_forces(const Ce6Params& p, const Vec3 (&x)[6], const Vec3 (&v)[6], real h, Ce6State& s,
                                 Vec3 (&f)[6], real strength = 1, const Ce6Prestress* pre = nullptr) {
  return cohesive6_forces(p, x, v, h, s, s.slip, f, strength, pre);
}

}  // namespace fdem
