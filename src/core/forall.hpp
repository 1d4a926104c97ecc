#pragma once
// The device time loop's two primitives, for the host (debug backend, OpenMP) here and for CUDA
// in cuda/cuda_exec.cuh, with the same interface:
//   Exec::forall(n, body)      body(i) for i in [0, n)
//   Exec::sum<N>(n, body)      body(i, acc) adds to acc[0..N); returns the N sums on the host
//   Exec::sum_to<N>(n, body, out)  the same, added to out[0..N) in device memory, without a
//                              copy to the host (passes launched one after another, e.g. colour
//                              by colour, then read once)
// Bodies are lambdas marked FDEM_LAMBDA that capture raw device pointers by value ([=]), so
// one source compiles for both.
#include <array>

#include "core/config.hpp"

#if defined(__CUDACC__)
#define FDEM_LAMBDA __host__ __device__
#else
#define FDEM_LAMBDA
#endif

namespace fdem {

struct HostExec {
  static constexpr bool on_gpu = false;
  template <class Body>
  static void forall(int n, Body body) {
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; ++i) body(i);
  }
  template <int N, class Body>
  static std::array<real, N> sum(int n, Body body) {
    real acc[N] = {};
#pragma omp parallel for schedule(static) reduction(+ : acc[:N])
    for (int i = 0; i < n; ++i) body(i, acc);
    std::array<real, N> out;
    for (int k = 0; k < N; ++k) out[k] = acc[k];
    return out;
  }
  template <int N, class Body>
  static void sum_to(int n, Body body, real* out) {
    const std::array<real, N> r = sum<N>(n, body);
    for (int k = 0; k < N; ++k) out[k] += r[k];
  }
  static void synchronize() {}
};

}  // namespace fdem
