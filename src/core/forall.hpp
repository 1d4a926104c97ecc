#pragma once
// The device time loop's two primitives, for the host (debug backend, OpenMP) here and for CUDA
// in cuda/cuda_exec.cuh, with the same interface:
//   Exec::forall(n, body)      body(i) for i in [0, n)
//   Exec::sum<N>(n, body)      body(i, acc) adds to acc[0..N); returns the N sums on the host
//   Exec::sum_to<N>(n, body, out)  the same, added to out[0..N) in device memory, without a
//                              copy to the host (passes launched one after another, e.g. colour
//                              by colour, then read once)
//   Exec::max<N>(n, body)      body(i, acc) raises acc[0..N) (acc[k] = max(acc[k], value));
//                              starts from -inf; returns the N maxima on the host
//   Exec::scan(n, in, out)     exclusive prefix sum of n longs; returns the total on the host
//   Exec::sort(first, n, less) sorts n elements in place by a FDEM_LAMBDA comparator
// Bodies are lambdas marked FDEM_LAMBDA that capture raw device pointers by value ([=]), so
// one source compiles for both.
#include <algorithm>
#include <array>
#include <limits>

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
  template <int N, class Body>
  static std::array<real, N> max(int n, Body body) {
    std::array<real, N> out;
    out.fill(-std::numeric_limits<real>::infinity());
#pragma omp parallel
    {
      real acc[N];
      for (int k = 0; k < N; ++k) acc[k] = -std::numeric_limits<real>::infinity();
#pragma omp for schedule(static) nowait
      for (int i = 0; i < n; ++i) body(i, acc);
#pragma omp critical(fdem_exec_max)
      for (int k = 0; k < N; ++k) out[k] = std::max(out[k], acc[k]);
    }
    return out;
  }
  static long scan(long n, const long* in, long* out) {
    long total = 0;
    for (long i = 0; i < n; ++i) {
      const long c = in[i];
      out[i] = total;
      total += c;
    }
    return total;
  }
  template <class T, class Less>
  static void sort(T* first, long n, Less less) {
    std::sort(first, first + n, less);
  }
  static void synchronize() {}
};

}  // namespace fdem
