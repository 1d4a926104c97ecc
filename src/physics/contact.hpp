#pragma once
// Tet-tet contact: two normal laws, the conservative overlap-volume law (the default) and
// Munjiza's distributed potential force, with one Coulomb friction law for both.
//
// Overlap-volume law. The pair's contact energy is a function of the volume V of the
// intersection of the two tets:  W = (2P/3) V^2 (1/V_a + 1/V_b),  V_a, V_b the tets' own
// volumes. The nodal forces are its exact gradient, f = -dW/dx, so no closed path of
// overlaps returns more work than it took. dV/dx comes from the intersection's boundary: the
// part of a face of a inside b moves with a's nodes, so dV/dx_(a,i) = int_{dA inside b}
// lambda_i n_a dS (lambda_i the node's weight in the face, n_a outward), and the same with
// the roles swapped. lambda_i is linear, so each clipped polygon needs only its area and
// centroid. V itself is (1/3) int p.n dS over the same polygons. The factor 2/3 makes two
// faces pressed together as stiff as under Munjiza's law: 8 P A / h for equal tets.
//
// Munjiza's law (contact.law: munjiza). Each tet is split into four sub-tets (face k + centroid
// C). In sub-tet k the potential is linear, 0 on face k and 1 at C: phi(p) = s_k(p) / s_k(C)
// with s_k the signed distance from face k's plane (positive inside). phi is continuous.
//
// Force. On tet a from tet b:  F_a = P int_{a cap b} (grad phi_a - grad phi_b) dV.
// By the divergence theorem, summed over all sub-tet pairs the internal sub-tet faces cancel
// (phi is continuous across them) and only the outer faces remain:
//   F_a = P [ - int_{dA inside b} phi_b n_a dS  +  int_{dB inside a} phi_a n_b dS ]
// with n_a, n_b outward unit normals. The two terms are the same operation with the roles
// swapped ("faces of one tet inside the other"), so the pair is symmetric by construction.
// Each term is a field of point forces: at a point p on a face of `a` inside `b` the force
// dF = -P phi_b(p) n_a dS acts on `a` (shared by a's face nodes with p's barycentric weights
// in the face) and -dF on `b` (shared by b's four nodes with p's barycentric weights in b).
// Both parts act at the same point, so the pair exerts no net force and no net torque.
// The faces are clipped against b (its four face planes) and then against each sub-tet's
// three inner planes; on each clipped polygon phi_b is linear, the fan triangles are
// integrated with the three edge-midpoint rule, exact for the product of two linear fields.
//
// Friction. A tangential elastic predictor per pair: the spring u (global vector, kept in
// the tangent plane of the current normal) grows with the relative tangential velocity at
// the contact point (the centre of the normal pressure); the trial force
// -k_t u is returned to mu N when it exceeds it (sliding), and u is kept per pair across
// candidate-list rebuilds. k_t = P (V_min)^(1/3): the normal stiffness scale of the pair.
#include <cmath>

#include "core/choice.hpp"
#include "core/portable_math.hpp"
#include "core/vec.hpp"
#include "physics/tet4.hpp"

namespace fdem {

/// The normal law of tet-tet contact (contact.law in a scene).
enum class ContactLaw { volume, munjiza };
template <>
struct ChoiceNames<ContactLaw> {
  static constexpr std::array<const char*, 2> words{"volume", "munjiza"};
};

struct ContactEval {
  Vec3 normal;   // net normal contact force on tet a, N (b receives -normal)
  Vec3 point;    // centre of the normal pressure, m; valid if weight > 0
  real weight;   // integral of |dF|, N (0 when the tets do not overlap)
  real energy;   // J, the pair's contact energy W (the volume law; 0 under Munjiza's)
  real overlap;  // m^3, the volume of the tets' intersection (the volume law; 0 under Munjiza's)
};

/// What a candidate pair keeps from one evaluation to the next (and across rebuilds).
struct PairHistory {
  Vec3 spring;        // m, the friction spring (contact_friction)
  real overlap_zero;  // m^3, the overlap at which the volume law's energy is zero; < 0: not yet evaluated
};

/// A pair's history before its first evaluation.
FDEM_HD_INLINE PairHistory new_pair_history() {
  return PairHistory{{0, 0, 0}, -1};
}

namespace contact_detail {

constexpr int kMaxPoly = 16;  // a triangle clipped by 7 planes: 10 vertices, a few more by round-off

struct Poly {
  Vec3 p[kMaxPoly];
  int n;
};

/// Keep the part of `in` where dot(nrm, p - o) >= 0 (Sutherland-Hodgman, one plane).
FDEM_HD void clip(const Poly& in, Vec3 nrm, Vec3 o, Poly& out) {
  out.n = 0;
  if (in.n == 0) return;
  real sp = dot(nrm, in.p[in.n - 1] - o);
  Vec3 prev = in.p[in.n - 1];
  for (int i = 0; i < in.n; ++i) {
    const Vec3 cur = in.p[i];
    const real sc = dot(nrm, cur - o);
    if ((sc >= 0) != (sp >= 0)) {
      const real t = sp / (sp - sc);
      if (out.n < kMaxPoly) out.p[out.n++] = prev + t * (cur - prev);
    }
    if (sc >= 0 && out.n < kMaxPoly) out.p[out.n++] = cur;
    prev = cur;
    sp = sc;
  }
}

FDEM_HD Vec3 centroid4(const Vec3 (&x)[4]) {
  return real(0.25) * (x[0] + x[1] + x[2] + x[3]);
}

/// Barycentric weights of p in tet x (may fall slightly outside [0,1] by round-off).
FDEM_HD void tet_weights(const Vec3 (&x)[4], const Mat3& Einv, Vec3 p, real (&L)[4]) {
  const Vec3 l = Einv * (p - x[0]);
  L[1] = l.x;
  L[2] = l.y;
  L[3] = l.z;
  L[0] = 1 - l.x - l.y - l.z;
}

/// A tet's four face planes, inside positive: face k is opposite node k, its (unnormalised)
/// normal points toward node k; h[k] = s_k(C), the plane function at the centroid. And the
/// six planes through the centroid and each edge, which split the tet into its sub-tets.
struct Planes {
  Vec3 n[4], o[4];
  real h[4];
  Vec3 C;
  Vec3 en[6];  // edge plane normals, edge e = (kEdge[e][0], kEdge[e][1])
};

/// The six edges (i, j) of a tet and the two other vertices (k, l).
FDEM_HD void tet_edge(int e, int& i, int& j, int& k, int& l) {
  const int E[6][4] = {{0, 1, 2, 3}, {0, 2, 1, 3}, {0, 3, 1, 2}, {1, 2, 0, 3}, {1, 3, 0, 2}, {2, 3, 0, 1}};
  i = E[e][0];
  j = E[e][1];
  k = E[e][2];
  l = E[e][3];
}

/// The four face planes alone (n, o and h; the edge planes are left unset). |n[k]| is twice
/// face k's area, so n[k] / 6 is the derivative of the tet's volume with respect to node k.
FDEM_HD_INLINE Planes tet_face_planes(const Vec3 (&b)[4]) {
  Planes P;
  P.C = centroid4(b);
  for (int k = 0; k < 4; ++k) {
    const Vec3 p0 = b[(k + 1) % 4], p1 = b[(k + 2) % 4], p2 = b[(k + 3) % 4];
    Vec3 nrm = cross(p1 - p0, p2 - p0);
    if (dot(nrm, b[k] - p0) < 0) nrm = -nrm;
    P.n[k] = nrm;
    P.o[k] = p0;
    P.h[k] = dot(nrm, P.C - p0);
  }
  return P;
}

FDEM_HD_INLINE Planes tet_planes(const Vec3 (&b)[4]) {
  Planes P = tet_face_planes(b);
  // Edge plane through b_i, b_j and C, oriented toward b_l: sub-tet k (face opposite k holds
  // i, j, l) lies on its positive side, sub-tet l (face holds i, j, k) on its negative side.
  for (int e = 0; e < 6; ++e) {
    int i, j, k, l;
    tet_edge(e, i, j, k, l);
    Vec3 nrm = cross(b[j] - b[i], P.C - b[i]);
    if (dot(nrm, b[l] - b[i]) < 0) nrm = -nrm;
    P.en[e] = nrm;
  }
  return P;
}

/// True if some face plane of b has all of a's vertices on or beyond it: no overlap volume.
FDEM_HD_INLINE bool separated_by(const Planes& pb, const Vec3 (&a)[4]) {
  for (int k = 0; k < 4; ++k) {
    bool out = true;
    for (int i = 0; i < 4 && out; ++i) out = dot(pb.n[k], a[i] - pb.o[k]) <= 0;
    if (out) return true;
  }
  return false;
}

/// True if an axis normal to an edge of a and an edge of b separates them (their projections
/// meet at most in a point): no overlap volume. With the face planes (separated_by) these are
/// all the axes that can separate two convex polyhedra, so a pair that passes every test
/// overlaps, and no pair is clipped in vain.
FDEM_HD_INLINE bool separated_by_edges(const Vec3 (&a)[4], const Vec3 (&b)[4]) {
  const int E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      const Vec3 axis = cross(a[E[i][1]] - a[E[i][0]], b[E[j][1]] - b[E[j][0]]);
      if (is_zero(axis)) continue;  // parallel edges: a face axis covers them
      real alo = dot(axis, a[0]), ahi = alo, blo = dot(axis, b[0]), bhi = blo;
      for (int k = 1; k < 4; ++k) {
        const real pa = dot(axis, a[k]), pb = dot(axis, b[k]);
        alo = pa < alo ? pa : alo, ahi = pa > ahi ? pa : ahi;
        blo = pb < blo ? pb : blo, bhi = pb > bhi ? pb : bhi;
      }
      if (ahi <= blo || bhi <= alo) return true;
    }
  return false;
}

/// Triangle (q0, q1, q2) clipped to tet b (its face planes pb), ping-pong between buf[0] and
/// buf[1]: the index of the buffer that holds the part inside b, or -1 where none is (the
/// triangle wholly on or beyond one of b's planes, a cheap rejection first, or clipped away).
FDEM_HD int clip_to_tet(Vec3 q0, Vec3 q1, Vec3 q2, const Planes& pb, Poly* buf) {
  for (int k = 0; k < 4; ++k)
    if (dot(pb.n[k], q0 - pb.o[k]) <= 0 && dot(pb.n[k], q1 - pb.o[k]) <= 0 && dot(pb.n[k], q2 - pb.o[k]) <= 0)
      return -1;
  int cur = 0;
  buf[0].n = 3;
  buf[0].p[0] = q0;
  buf[0].p[1] = q1;
  buf[0].p[2] = q2;
  for (int k = 0; k < 4 && buf[cur].n >= 3; ++k) {
    clip(buf[cur], pb.n[k], pb.o[k], buf[1 - cur]);
    cur = 1 - cur;
  }
  return buf[cur].n >= 3 ? cur : -1;
}

/// Faces of tet `a` inside tet `b`: adds the point forces to fa (a's nodes) and fb (b's
/// nodes) and their sums to `e`. `sign` is +1 when `a` is the pair's first tet, -1 when the
/// roles are swapped (e.normal is always the force on the pair's first tet).
FDEM_HD void faces_inside(const Vec3 (&a)[4], const Vec3 (&b)[4], const Planes& pb, const Mat3& Binv, real P,
                          Vec3 (&fa)[4], Vec3 (&fb)[4], real sign, ContactEval& e) {
  // Three polygons in all: the face clipped by b (ping-pong between buf[0] and buf[1]), and
  // each sub-tet's part of it clipped from there into the other two by turns, never copied
  // (a Poly is 16 vertices; on a GPU it lives in local memory).
  Poly buf[3];
  for (int f = 0; f < 4; ++f) {  // face of a opposite node f
    const int i0 = (f + 1) % 4, i1 = (f + 2) % 4, i2 = (f + 3) % 4;
    const Vec3 q0 = a[i0], q1 = a[i1], q2 = a[i2];
    const Vec3 na = cross(q1 - q0, q2 - q0);  // for barycentric weights: keep its sign
    const real na2 = dot(na, na);
    if (!(na2 > 0)) continue;
    const int cur = clip_to_tet(q0, q1, q2, pb, buf);
    if (cur < 0) continue;
    const real inv_na2 = real(1) / na2;
    const Vec3 nhat = (dot(na, a[f] - q0) > 0 ? real(-1) : real(1)) / std::sqrt(na2) * na;  // outward
    const Poly& inside = buf[cur];
    Poly* const spare[2] = {&buf[1 - cur], &buf[2]};
    // Split among b's sub-tets: sub-tet k is cut out by the edge planes of face k's edges.
    for (int k = 0; k < 4; ++k) {
      if (!(pb.h[k] > 0)) continue;
      const Poly* from = &inside;
      int c = 0;  // the next clip writes spare[c]
      for (int ed = 0; ed < 6 && from->n >= 3; ++ed) {
        int i, j, kk, l;
        tet_edge(ed, i, j, kk, l);
        if (i == k || j == k) continue;  // only the three edges of face k
        // Face k holds i, j and the one of (kk, l) that is not k.
        const Vec3 nrm = (kk == k) ? pb.en[ed] : -pb.en[ed];
        clip(*from, nrm, b[i], *spare[c]);
        from = spare[c];
        c = 1 - c;
      }
      const Poly& q = *from;
      if (q.n < 3) continue;
      for (int t = 1; t + 1 < q.n; ++t) {
        const Vec3 r0 = q.p[0], r1 = q.p[t], r2 = q.p[t + 1];
        const real area = real(0.5) * norm(cross(r1 - r0, r2 - r0));
        if (!(area > 0)) continue;
        const Vec3 mids[3] = {real(0.5) * (r0 + r1), real(0.5) * (r1 + r2), real(0.5) * (r2 + r0)};
        for (const Vec3& m : mids) {
          const real phi = dot(pb.n[k], m - pb.o[k]) / pb.h[k];
          const real g = P * (area / 3) * phi;  // |dF|
          if (!(g > 0)) continue;
          const Vec3 F = -g * nhat;  // on a
          // Barycentric weights of m in a's face and in b.
          const real l0 = dot(cross(q1 - m, q2 - m), na) * inv_na2;
          const real l1 = dot(cross(q2 - m, q0 - m), na) * inv_na2;
          const real l2 = 1 - l0 - l1;
          fa[i0] += l0 * F;
          fa[i1] += l1 * F;
          fa[i2] += l2 * F;
          real L[4];
          tet_weights(b, Binv, m, L);
          for (int j = 0; j < 4; ++j) fb[j] -= L[j] * F;
          e.normal += sign * F;
          e.point += g * m;
          e.weight += g;
        }
      }
    }
  }
}

}  // namespace contact_detail

namespace contact_detail {

/// True where the boxes of a and b overlap (with volume): the first, cheapest rejection.
FDEM_HD_INLINE bool boxes_overlap(const Vec3 (&a)[4], const Vec3 (&b)[4]) {
  for (int d = 0; d < 3; ++d) {
    real alo = a[0][d], ahi = a[0][d], blo = b[0][d], bhi = b[0][d];
    for (int i = 1; i < 4; ++i) {
      const real ai = a[i][d], bi = b[i][d];
      alo = ai < alo ? ai : alo;
      ahi = ai > ahi ? ai : ahi;
      blo = bi < blo ? bi : blo;
      bhi = bi > bhi ? bi : bhi;
    }
    if (alo >= bhi || blo >= ahi) return false;
  }
  return true;
}

/// The boundary of the intersection of two tets, as far as it is summed: the intersection's
/// volume and its derivative with respect to the nodes of each tet.
struct Overlap {
  real volume;        // m^3, (1/3) int p.n dS (p relative to the pair's origin)
  Vec3 grad_a[4];     // m^2, dV/dx of a's nodes
  Vec3 grad_b[4];     // m^2, dV/dx of b's nodes
  Vec3 first_moment;  // m^3, int p dS over the boundary
  real area;          // m^2, the boundary's area
};

constexpr int kMaxVerts = 40;    // a tet cut by four planes has at most 26 vertices
constexpr int kMaxEdges = 72;    // and at most 18 edges, each held twice (once per face)
constexpr int kMaxCuts = 4;      // crossings of one plane by one face (1 but for round-off)
constexpr int kMaxCrossed = 16;  // edges one plane crosses (at most 7 but for round-off)

/// Tet a cut by tet b's four face planes, kept as a closed surface: a pool of vertices and
/// directed edges, each edge tagged with the face it bounds (0-3: a's face opposite that
/// node; 4-7: b's face plane k + 4, the caps). Each edge lies in two faces, once in each
/// direction, on the same two vertices of the pool. So the surface closes exactly whatever
/// the round-off, and V = (1/3) int p.n dS does not depend on the origin. (Two clipped faces
/// that each decide alone which side of a plane they lie on do not close where a face of a
/// lies in a face of b, as on a joint: one of them can keep its whole face and the other
/// none, and V was then off by up to a tet's volume.)
struct CutTet {
  Vec3 v[kMaxVerts];
  int nv;
  unsigned char from[kMaxEdges], to[kMaxEdges], face[kMaxEdges];
  int ne;
};

FDEM_HD_INLINE void cut_tet_start(const Vec3 (&a)[4], CutTet& t) {
  t.nv = 4;
  t.ne = 0;
  for (int i = 0; i < 4; ++i) t.v[i] = a[i];
  for (int f = 0; f < 4; ++f) {  // face opposite f, its edges outward (counter-clockwise from outside)
    int q[3] = {(f + 1) % 4, (f + 2) % 4, (f + 3) % 4};
    if (dot(cross(a[q[1]] - a[q[0]], a[q[2]] - a[q[0]]), a[f] - a[q[0]]) > 0) {
      const int swap = q[1];
      q[1] = q[2];
      q[2] = swap;
    }
    for (int e = 0; e < 3; ++e) {
      t.from[t.ne] = (unsigned char)q[e];
      t.to[t.ne] = (unsigned char)q[(e + 1) % 3];
      t.face[t.ne++] = (unsigned char)f;
    }
  }
}

/// The vertex where edge (in, out) crosses the plane, s the plane function at both ends:
/// made once per edge and plane (cut[] holds this plane's), from the inner end, so that
/// both faces of the edge share it. -1 where the pool is full.
FDEM_HD_INLINE int crossing(CutTet& t, int in, int out, const real* s, unsigned char (*cut)[3], int& ncut) {
  if (s[in] == 0) return in;
  for (int c = 0; c < ncut; ++c)
    if (cut[c][0] == in && cut[c][1] == out) return cut[c][2];
  if (t.nv == kMaxVerts || ncut == kMaxCrossed) return -1;
  t.v[t.nv] = t.v[in] + (s[in] / (s[in] - s[out])) * (t.v[out] - t.v[in]);
  cut[ncut][0] = (unsigned char)in, cut[ncut][1] = (unsigned char)out, cut[ncut][2] = (unsigned char)t.nv;
  ++ncut;
  return t.nv++;
}

/// Keeps the part of t where dot(n, p - o) >= 0 and closes it with a cap tagged `cap`.
/// Returns false where nothing of positive volume is left, or a buffer would overflow
/// (only round-off could make so many crossings; the pair then counts as apart).
FDEM_HD bool cut_tet_by(CutTet& t, Vec3 n, Vec3 o, int cap) {
  real s[kMaxVerts];
  bool some_in = false, some_out = false;
  for (int i = 0; i < t.nv; ++i) s[i] = dot(n, t.v[i] - o);
  for (int e = 0; e < t.ne; ++e) some_in |= s[t.from[e]] > 0, some_out |= s[t.from[e]] < 0;
  if (!some_in) return false;
  if (!some_out) return true;
  unsigned char cut[kMaxCrossed][3], exits[8][kMaxCuts], entries[8][kMaxCuts];  // (vertex indices: local memory)
  int ncut = 0, nexit[8] = {0}, nentry[8] = {0};
  int kept = 0;
  for (int e = 0; e < t.ne; ++e) {
    const int p = t.from[e], q = t.to[e], f = t.face[e];
    const bool p_in = s[p] >= 0, q_in = s[q] >= 0;
    int a = p, b = q;
    if (p_in && !q_in) {
      b = crossing(t, p, q, s, cut, ncut);
      if (b < 0 || nexit[f] == kMaxCuts) return false;
      exits[f][nexit[f]++] = (unsigned char)b;
    } else if (!p_in && q_in) {
      a = crossing(t, q, p, s, cut, ncut);
      if (a < 0 || nentry[f] == kMaxCuts) return false;
      entries[f][nentry[f]++] = (unsigned char)a;
    } else if (!p_in) {
      continue;
    }
    if (a == b) continue;
    t.from[kept] = (unsigned char)a, t.to[kept] = (unsigned char)b, t.face[kept] = (unsigned char)f;
    ++kept;
  }
  t.ne = kept;
  // Each face leaves at an exit and comes back at an entry, both on the plane: the face is
  // closed along the plane from the one to the other, and the cap runs the other way. Where
  // round-off makes several, any pairing gives the same segments of that one line.
  for (int f = 0; f < 8; ++f) {
    if (nexit[f] != nentry[f]) return false;
    for (int c = 0; c < nexit[f]; ++c) {
      if (exits[f][c] == entries[f][c]) continue;
      if (t.ne + 2 > kMaxEdges) return false;
      t.from[t.ne] = (unsigned char)exits[f][c], t.to[t.ne] = (unsigned char)entries[f][c];
      t.face[t.ne++] = (unsigned char)f;
      t.from[t.ne] = (unsigned char)entries[f][c], t.to[t.ne] = (unsigned char)exits[f][c];
      t.face[t.ne++] = (unsigned char)cap;
    }
  }
  return true;
}

/// Integral of the barycentric weight of q0 over a polygon in triangle (q0, q1, q2) (na its
/// normal, na2 = |na|^2), from the polygon's area A and first moment M: the weight is affine.
FDEM_HD_INLINE real weight_integral(Vec3 q1, Vec3 q2, Vec3 na, real na2, real A, Vec3 M) {
  return (A * dot(cross(q1, q2), na) + dot(cross(M, q1 - q2), na)) / na2;
}

/// Adds face f of the cut tet (its area A and first moment M, outward unit normal nhat) to
/// the overlap: its share of V, and dV/dx of the three nodes q[] of the face it lies on.
FDEM_HD_INLINE void add_face(const Vec3 (&x)[4], const int (&q)[3], Vec3 nhat, real A, Vec3 M, Vec3 (&grad)[4],
                             Overlap& ov) {
  const Vec3 na = cross(x[q[1]] - x[q[0]], x[q[2]] - x[q[0]]);
  const real na2 = dot(na, na);
  if (!(na2 > 0)) return;
  const real l0 = weight_integral(x[q[1]], x[q[2]], na, na2, A, M);
  const real l1 = weight_integral(x[q[2]], x[q[0]], na, na2, A, M);
  grad[q[0]] += l0 * nhat;
  grad[q[1]] += l1 * nhat;
  grad[q[2]] += (A - l0 - l1) * nhat;
  ov.volume += dot(nhat, M) / 3;
  ov.first_moment += M;
  ov.area += A;
}

/// The overlap of tets a and b (face planes pa, pb): a cut by b's four planes, its faces
/// summed. On a's faces the node weights are a's, on the caps b's. Volume 0 where none.
FDEM_HD void overlap_of(const Vec3 (&a)[4], const Vec3 (&b)[4], const Planes& pa, const Planes& pb, Overlap& ov) {
  CutTet t;
  cut_tet_start(a, t);
  for (int k = 0; k < 4; ++k)
    if (!cut_tet_by(t, pb.n[k], pb.o[k], 4 + k)) return;
  real A[8] = {0};
  Vec3 M[8], r[8];
  bool seen[8] = {false};
  Vec3 nhat[8];
  for (int f = 0; f < 8; ++f) {
    const Vec3 n = f < 4 ? pa.n[f] : pb.n[f - 4];  // inward: the overlap lies on its positive side
    nhat[f] = (real(-1) / norm(n)) * n;
    M[f] = Vec3{0, 0, 0};
  }
  for (int e = 0; e < t.ne; ++e) {  // each face fanned from its first vertex met
    const int f = t.face[e];
    if (!seen[f]) seen[f] = true, r[f] = t.v[t.from[e]];
    const Vec3 p = t.v[t.from[e]], q = t.v[t.to[e]];
    const real at = real(0.5) * dot(nhat[f], cross(p - r[f], q - r[f]));
    A[f] += at;
    M[f] += (at / 3) * (r[f] + p + q);
  }
  for (int f = 0; f < 8; ++f) {
    if (!seen[f]) continue;
    const int k = f % 4;
    const int q[3] = {(k + 1) % 4, (k + 2) % 4, (k + 3) % 4};
    if (f < 4)
      add_face(a, q, nhat[f], A[f], M[f], ov.grad_a, ov);
    else
      add_face(b, q, nhat[f], A[f], M[f], ov.grad_b, ov);
  }
}

}  // namespace contact_detail

/// The overlap-volume law: normal contact forces between tets a and b (current positions),
/// penalty P (Pa), the exact gradient of W = (2P/3) (V - V_0)^2 (1/V_a + 1/V_b) for V > V_0,
/// else 0. V_0 = `overlap_zero` (m^3) is the overlap a pair started with (the caller keeps it:
/// PairHistory); < 0 takes the overlap now, as at a pair's first evaluation. fa and fb are
/// overwritten. Symmetric: swapping a and b swaps fa and fb.
FDEM_HD_INLINE ContactEval contact_volume_pair(const Vec3 (&a_in)[4], const Vec3 (&b_in)[4], real P, Vec3 (&fa)[4],
                                               Vec3 (&fb)[4], real overlap_zero = 0) {
  using namespace contact_detail;
  ContactEval e{{0, 0, 0}, {0, 0, 0}, 0, 0, 0};
  for (int i = 0; i < 4; ++i) fa[i] = fb[i] = Vec3{0, 0, 0};
  if (!boxes_overlap(a_in, b_in)) return e;
  // Positions from a's first node: V sums products of positions, so far from the origin its
  // terms would cancel to round-off.
  const Vec3 o = a_in[0];
  Vec3 a[4], b[4];
  for (int i = 0; i < 4; ++i) a[i] = a_in[i] - o, b[i] = b_in[i] - o;
  const Planes pa = tet_face_planes(a), pb = tet_face_planes(b);
  // The tets' volumes: h_0 = |n_0| H_0 / 4 with |n_0| twice a face's area, H_0 its height.
  const real va = real(2) / 3 * pa.h[0], vb = real(2) / 3 * pb.h[0];
  if (!(va > 0) || !(vb > 0)) return e;  // degenerate
  if (separated_by(pb, a) || separated_by(pa, b) || separated_by_edges(a, b)) return e;
  Overlap ov{0, {}, {}, {0, 0, 0}, 0};  // (the gradients' {} are zeros)
  overlap_of(a, b, pa, pb, ov);
  const real V = ov.volume;
  if (!(V > 0) || !(ov.area > 0)) return e;
  e.overlap = V;
  const real u = V - (overlap_zero < 0 ? V : overlap_zero);  // the overlap beyond the pair's zero
  if (!(u > 0)) return e;
  const real k = real(2) / 3 * P * (1 / va + 1 / vb);  // W = k u^2
  const real dW = 2 * k * u;                           // dW/dV, Pa
  // dW/dV_a = -(2P/3) u^2 / V_a^2, and dV_a/dx_k = n_k / 6.
  const real ka = real(2) / 3 * P * u * u / (va * va) / 6, kb = real(2) / 3 * P * u * u / (vb * vb) / 6;
  for (int i = 0; i < 4; ++i) {
    fa[i] = -dW * ov.grad_a[i] + ka * pa.n[i];
    fb[i] = -dW * ov.grad_b[i] + kb * pb.n[i];
    e.normal += fa[i];
  }
  e.point = o + (real(1) / ov.area) * ov.first_moment;
  e.weight = dW * ov.area;
  e.energy = k * u * u;
  return e;
}

/// Munjiza's law: normal contact forces between tets a and b (current positions), penalty P
/// (Pa). fa and fb are overwritten. Symmetric: swapping a and b swaps fa and fb.
FDEM_HD_INLINE ContactEval contact_munjiza_pair(const Vec3 (&a)[4], const Vec3 (&b)[4], real P, Vec3 (&fa)[4],
                                                Vec3 (&fb)[4]) {
  using namespace contact_detail;
  ContactEval e{{0, 0, 0}, {0, 0, 0}, 0, 0, 0};
  for (int i = 0; i < 4; ++i) fa[i] = fb[i] = Vec3{0, 0, 0};
  const Mat3 Ea = Mat3::from_columns(a[1] - a[0], a[2] - a[0], a[3] - a[0]);
  const Mat3 Eb = Mat3::from_columns(b[1] - b[0], b[2] - b[0], b[3] - b[0]);
  const real da = det(Ea), db = det(Eb);
  if (!(da != 0) || !(db != 0)) return e;  // degenerate: no potential defined
  // Cheap rejection first: the boxes, then the eight face planes (most candidate pairs in a
  // fractured body touch at most along a face, edge or vertex).
  if (!boxes_overlap(a, b)) return e;
  const Planes pa = tet_planes(a), pb = tet_planes(b);
  if (separated_by(pb, a) || separated_by(pa, b)) return e;
  faces_inside(a, b, pb, inverse(Eb), P, fa, fb, 1, e);
  faces_inside(b, a, pa, inverse(Ea), P, fb, fa, -1, e);
  if (e.weight > 0) e.point = (real(1) / e.weight) * e.point;
  return e;
}

/// The normal contact forces of a pair under `law` (see above); overlap_zero: the volume law's.
FDEM_HD_INLINE ContactEval contact_tet_pair(ContactLaw law, const Vec3 (&a)[4], const Vec3 (&b)[4], real P,
                                            Vec3 (&fa)[4], Vec3 (&fb)[4], real overlap_zero = 0) {
  return law == ContactLaw::volume ? contact_volume_pair(a, b, P, fa, fb, overlap_zero)
                                   : contact_munjiza_pair(a, b, P, fa, fb);
}

/// The pair's overlap zero after an evaluation e: the overlap it first met with, then never
/// more than the overlap since. It moves only where the energy is zero, so the energy stays
/// a function of the positions along the way: no work comes of it.
FDEM_HD_INLINE real next_overlap_zero(real overlap_zero, const ContactEval& e) {
  return overlap_zero < 0 || e.overlap < overlap_zero ? e.overlap : overlap_zero;
}

/// Stiffness of a pair's friction spring, N/m: P (V_min)^(1/3), the normal stiffness scale
/// of the pair (two faces pressed together stiffen by about 8 P A / h).
FDEM_HD real contact_tangential_stiffness(const Vec3 (&a)[4], const Vec3 (&b)[4], real P) {
  const real va = std::fabs(tet4_volume(a)), vb = std::fabs(tet4_volume(b));
  return P * portable_cbrt(va < vb ? va : vb);
}

/// Coulomb friction of one contact pair after contact_tet_pair. u is the pair's tangential
/// spring (its history), k_t its stiffness (N/m), mu the friction coefficient, dt the step.
/// Adds the friction forces to fa and fb; returns the work dissipated by sliding (J).
FDEM_HD real contact_friction(const Vec3 (&a)[4], const Vec3 (&b)[4], const Vec3 (&va)[4], const Vec3 (&vb)[4],
                              const ContactEval& e, real mu, real k_t, real dt, Vec3& u, Vec3 (&fa)[4], Vec3 (&fb)[4]) {
  using namespace contact_detail;
  const real N = norm(e.normal);
  if (!(e.weight > 0) || !(N > 0) || !(k_t > 0)) {
    u = Vec3{0, 0, 0};
    return 0;
  }
  const Vec3 n = (real(1) / N) * e.normal;
  const Mat3 Ea = Mat3::from_columns(a[1] - a[0], a[2] - a[0], a[3] - a[0]);
  const Mat3 Eb = Mat3::from_columns(b[1] - b[0], b[2] - b[0], b[3] - b[0]);
  real La[4], Lb[4];
  tet_weights(a, inverse(Ea), e.point, La);
  tet_weights(b, inverse(Eb), e.point, Lb);
  Vec3 vrel{0, 0, 0};
  for (int i = 0; i < 4; ++i) vrel += La[i] * va[i] - Lb[i] * vb[i];
  const Vec3 vt = vrel - dot(vrel, n) * n;
  // Rotate the old spring into the current tangent plane, keeping its length.
  const real u0 = norm(u);
  Vec3 ut = u - dot(u, n) * n;
  const real ut_len = norm(ut);
  ut = ut_len > 0 ? (u0 / ut_len) * ut : Vec3{0, 0, 0};
  ut += dt * vt;
  Vec3 T = -k_t * ut;  // on a
  const real tn = norm(T), limit = mu * N;
  real dissipated = 0;
  if (tn > limit) {
    dissipated = limit * (tn - limit) / k_t;  // slip distance times the sliding force
    T = (limit / tn) * T;
    ut = (limit / tn) * ut;
  }
  u = ut;
  for (int i = 0; i < 4; ++i) {
    fa[i] += La[i] * T;
    fb[i] -= Lb[i] * T;
  }
  return dissipated;
}

}  // namespace fdem
