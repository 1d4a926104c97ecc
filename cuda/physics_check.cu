// Device instantiations of every src/physics law: the CUDA backend's kernels will be
// launches of exactly these functions. Built wherever nvcc is found.
#include "physics/cohesive6.hpp"
#include "physics/contact.hpp"
#include "physics/integrate.hpp"
#include "physics/platen.hpp"
#include "physics/tet4.hpp"
#include "physics/time_step.hpp"

namespace fdem {

__global__ void tet4_kernel(int n, const int4* tets, const Vec3* x, const Vec3* v, const Mat3* Xinv, const real* V0,
                            real lambda, real mu, const real* eta, Vec3* f_tet) {
  const int t = blockIdx.x * blockDim.x + threadIdx.x;
  if (t >= n) return;
  const int4 q = tets[t];
  const Vec3 xe[4] = {x[q.x], x[q.y], x[q.z], x[q.w]};
  const Vec3 ve[4] = {v[q.x], v[q.y], v[q.z], v[q.w]};
  Vec3 fe[4];
  tet4_forces(xe, ve, Xinv[t], V0[t], lambda, mu, eta[t], fe);
  for (int i = 0; i < 4; ++i) f_tet[4 * t + i] = fe[i];
}

__global__ void ce6_kernel(int n, const int* nodes, const Vec3* x, const Vec3* v, const real* h, Ce6Params p,
                           Ce6State* state, Vec3* f_ce6) {
  const int c = blockIdx.x * blockDim.x + threadIdx.x;
  if (c >= n) return;
  Vec3 xe[6], ve[6], fe[6];
  for (int i = 0; i < 6; ++i) {
    xe[i] = x[nodes[6 * c + i]];
    ve[i] = v[nodes[6 * c + i]];
  }
  cohesive6_forces(p, xe, ve, h[c], state[c], fe);
  for (int i = 0; i < 6; ++i) f_ce6[6 * c + i] = fe[i];
}

__global__ void platen_kernel(int n, const int* nodes, const Vec3* x, const real* k, real mu, Vec3 n_in, real z,
                              Vec3* anchor, Vec3* f) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= n) return;
  f[nodes[i]] += platen_node_force(x[nodes[i]] - Vec3{0, 0, z}, n_in, k[i], mu, anchor[i]).force;
}

__global__ void contact_kernel(int n, const int2* pairs, const int4* tets, const Vec3* x, const Vec3* v, real P,
                               real mu, real dt, Vec3* spring, Vec3* f_pair) {
  const int p = blockIdx.x * blockDim.x + threadIdx.x;
  if (p >= n) return;
  const int4 a = tets[pairs[p].x], b = tets[pairs[p].y];
  const Vec3 xa[4] = {x[a.x], x[a.y], x[a.z], x[a.w]}, xb[4] = {x[b.x], x[b.y], x[b.z], x[b.w]};
  const Vec3 va[4] = {v[a.x], v[a.y], v[a.z], v[a.w]}, vb[4] = {v[b.x], v[b.y], v[b.z], v[b.w]};
  Vec3 fa[4], fb[4];
  const ContactEval e = contact_tet_pair(xa, xb, P, fa, fb);
  contact_friction(xa, xb, va, vb, e, mu, contact_tangential_stiffness(xa, xb, P), dt, spring[p], fa, fb);
  for (int i = 0; i < 4; ++i) f_pair[8 * p + i] = fa[i], f_pair[8 * p + 4 + i] = fb[i];
}

__global__ void integrate_kernel(int n, Vec3* x, Vec3* v, const Vec3* f, const real* inv_mass, real dt) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) central_difference(x[i], v[i], f[i], inv_mass[i], dt);
}

}  // namespace fdem
