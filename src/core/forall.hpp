#pragma once
// The device time loop's primitives, for the host (cpu and debug backends, OpenMP) here and for CUDA
// in cuda/cuda_exec.cuh, with the same interface:
//   Exec::forall(n, body)      body(i) for i in [0, n)
//   Exec::sum<N>(n, body)      body(i, acc) adds to acc[0..N); returns the N sums on the host
//   Exec::sum_to<N>(n, body, out)  the same, added to out[0..N) in device memory, without a
//                              copy to the host (passes launched one after another, e.g. colour
//                              by colour, then read once); sum_to<N, B> compiles the CUDA kernel
//                              for B resident blocks per multiprocessor (__launch_bounds__: fewer
//                              registers, spilled where they do not fit), the same sums; the host
//                              ignores B. sum_to<N, B>(n, body, out, before_add): before_add()
//                              runs once, after every iteration and just before the sums are
//                              added to out (on a GPU by the reduction's last block, in the same
//                              launch: device memory set up for the sums without a launch of its
//                              own), also where n is 0
//   Exec::max<N>(n, body)      body(i, acc) raises acc[0..N) (acc[k] = max(acc[k], value));
//                              starts from -inf; returns the N maxima on the host
//   Exec::scan(n, in, out)     exclusive prefix sum of n longs; returns the total on the host
//   Exec::sort(first, n, less) sorts n elements in place by a FDEM_LAMBDA comparator
// Bodies are lambdas marked FDEM_LAMBDA that capture raw device pointers by value ([=]), so
// one source compiles for both.
//
// A GPU runs the iterations of a launch in no fixed order, so a body that reads what another
// iteration of the same launch writes (a race) gives results that change from run to run. On the
// host, HostExec therefore runs each launch's iterations in a scrambled order by default (a
// different permutation per launch, the same from run to run): such a race then changes the
// debug backend's results, and the tests that hold them bit for bit to the CPU backend's fail
// without a GPU. Sums are still added in index order, so they do not change with the order.
// FDEM_DEBUG_ORDER=forward (or set_host_order) runs iterations in index order instead.
//
// A race whose result does not depend on the order (two iterations adding to a slot that starts
// at zero, two writing the same value) is not seen that way. Built with FDEM_HOST_RACE_THREADS=T
// (scripts/sanitize.sh --thread, under ThreadSanitizer), HostExec runs each launch on T threads
// of its own, started for the launch and joined after it, each iteration on a thread drawn by a
// hash of its number and the launch's: any two iterations on different threads that touch the
// same memory, one of them writing, are then reported by ThreadSanitizer, whether or not the
// result changes (the threads' start and join order the launches, which OpenMP's pool does not
// show it). Two given iterations share a thread in about 1 launch in T, another each time.
#include <algorithm>
#include <array>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>
#if defined(FDEM_HOST_RACE_THREADS)
#include <thread>
#endif
#if defined(_OPENMP)
#include <omp.h>
#endif

#include "core/config.hpp"
#include "core/device_memory.hpp"
#include "core/error.hpp"

#if defined(__CUDACC__)
#define FDEM_LAMBDA __host__ __device__
#else
#define FDEM_LAMBDA
#endif

namespace fdem {

/// The order in which HostExec runs the iterations of a launch.
enum class HostOrder { forward, scrambled };

/// HostExec's order now: scrambled unless FDEM_DEBUG_ORDER=forward was set at start-up. Another
/// value throws InputError (the debug backend reads it when it is set up).
inline HostOrder& host_order() {
  static HostOrder order = [] {
    const char* e = std::getenv("FDEM_DEBUG_ORDER");
    const std::string v = e ? e : "";
    if (v.empty() || v == "scrambled") return HostOrder::scrambled;
    if (v == "forward") return HostOrder::forward;
    throw InputError("FDEM_DEBUG_ORDER=" + v +
                     ": unknown order of the debug backend's iterations. Fix: FDEM_DEBUG_ORDER=scrambled (the "
                     "default) or forward, or unset it");
  }();
  return order;
}
inline void set_host_order(HostOrder o) {
  host_order() = o;
}

/// The k-th iteration of a launch of n runs index (a k + b) mod n, with a coprime to n (so every
/// index runs once): a is near 0.618 n, so neighbouring indices run far apart, and b moves on
/// with every launch. Forward order is a = 1, b = 0.
struct HostPermutation {
  long a = 1, b = 0, n = 1;
  int operator()(int k) const { return int((a * k + b) % n); }
};

/// The permutation of the next launch of n iterations in order `order` (the host thread calls
/// it, once per launch).
inline HostPermutation next_host_permutation(int n, HostOrder order) {
  static unsigned long launches = 0;
  HostPermutation p;
  p.n = std::max(n, 1);
  if (order == HostOrder::forward || n < 2) return p;
  ++launches;
  p.a = std::max(n > 2 ? 2L : 1L, long(0.6180339887 * n));
  while (std::gcd(p.a, p.n) != 1) ++p.a;
  p.b = long((launches * 2654435761UL) % static_cast<unsigned long>(n));
  return p;
}

/// fn(k, t) for k in [0, n), t the worker's number in [0, host_workers()): OpenMP's threads
/// (static schedule), or where built with FDEM_HOST_RACE_THREADS, that many threads started for
/// this call and joined before it returns (k on the thread a hash of k and the call's number
/// picks; called from one host thread).
inline int host_workers() {
#if defined(FDEM_HOST_RACE_THREADS)
  static_assert(FDEM_HOST_RACE_THREADS >= 2, "FDEM_HOST_RACE_THREADS: 2 threads or more");
  return FDEM_HOST_RACE_THREADS;
#elif defined(_OPENMP)
  return omp_get_max_threads();
#else
  return 1;
#endif
}
/// Launches of fewer iterations run on the calling thread: starting OpenMP's team costs about as
/// much as that many light iterations (clearing a sum, the prescribed nodes, a small model's
/// contact), and a step makes about twenty launches. On one thread no launch starts a team.
#ifndef FDEM_HOST_SERIAL_BELOW
#define FDEM_HOST_SERIAL_BELOW 64
#endif
constexpr int kHostSerialBelow = FDEM_HOST_SERIAL_BELOW;
template <class Fn>
inline void host_parallel_for(int n, Fn fn) {
#if defined(FDEM_HOST_RACE_THREADS)
  constexpr int T = FDEM_HOST_RACE_THREADS;
  static unsigned long long calls = 0;
  const unsigned long long salt = ++calls * 0x9E3779B97F4A7C15ull;
  auto share = [&](int t) {
    for (int k = 0; k < n; ++k) {
      unsigned long long h = (unsigned long long)(k) + salt;  // (splitmix64's finaliser)
      h = (h ^ (h >> 30)) * 0xBF58476D1CE4E5B9ull;
      h = (h ^ (h >> 27)) * 0x94D049BB133111EBull;
      if (int((h ^ (h >> 31)) % T) == t) fn(k, t);
    }
  };
  std::thread others[T - 1];
  for (int t = 1; t < T; ++t) others[t - 1] = std::thread(share, t);
  share(0);
  for (std::thread& th : others) th.join();
#elif defined(_OPENMP)
  if (n < kHostSerialBelow || host_workers() == 1) {  // (no team to start)
    for (int k = 0; k < n; ++k) fn(k, 0);
    return;
  }
#pragma omp parallel
  {
    const int t = omp_get_thread_num();
#pragma omp for schedule(static) nowait
    for (int k = 0; k < n; ++k) fn(k, t);
  }
#else
  for (int k = 0; k < n; ++k) fn(k, 0);
#endif
}

/// Sets the flag *p (0 or 1) to 1 and returns whether it was 0, as one atomic operation: the
/// iterations of a launch that raise the same flag then neither race nor count it twice. On a
/// GPU an atomicOr on the aligned 4-byte word that holds the byte (device allocations are
/// rounded up to 8 bytes, cuda/device_memory.cu, so the word lies inside the allocation).
FDEM_HD bool raise_flag(std::uint8_t* p) {
#if defined(__CUDA_ARCH__)
  const unsigned long long a = reinterpret_cast<unsigned long long>(p);
  const unsigned shift = 8u * unsigned(a & 3u);
  const unsigned old = atomicOr(reinterpret_cast<unsigned*>(a & ~3ull), 1u << shift);
  return (old >> shift & 0xffu) == 0;
#else
  return __atomic_fetch_or(p, std::uint8_t(1), __ATOMIC_RELAXED) == 0;
#endif
}
/// Sets `bits` in the byte *p as one atomic operation, as raise_flag does; returns whether one of
/// them was not set before (a byte holding several flags: TetFlag).
FDEM_HD bool raise_bits(std::uint8_t* p, std::uint8_t bits) {
#if defined(__CUDA_ARCH__)
  const unsigned long long a = reinterpret_cast<unsigned long long>(p);
  const unsigned shift = 8u * unsigned(a & 3u);
  const unsigned old = atomicOr(reinterpret_cast<unsigned*>(a & ~3ull), unsigned(bits) << shift);
  return (old >> shift & bits) != bits;
#else
  return (__atomic_fetch_or(p, bits, __ATOMIC_RELAXED) & bits) != bits;
#endif
}
/// The same for a flag held in a long (the scans' input).
FDEM_HD bool raise_flag(long* p) {
  static_assert(sizeof(long) == sizeof(unsigned long long), "a long of 8 bytes");
#if defined(__CUDA_ARCH__)
  return atomicOr(reinterpret_cast<unsigned long long*>(p), 1ull) == 0;
#else
  return __atomic_fetch_or(p, 1L, __ATOMIC_RELAXED) == 0;
#endif
}

/// The before_add of a sum_to that has none.
struct NoEpilogue {
  FDEM_HD void operator()() const {}
};

/// The host's executor. kChecking (the debug backend, HostExec): each launch's iterations in
/// host_order(), scrambled by default, and sort() refuses ties. Without (the cpu backend,
/// CpuExec): always in index order, which is what OpenMP's static schedule runs fastest.
template <bool kChecking>
struct HostExecutor {
  static constexpr bool on_gpu = false;
  static HostOrder order() { return kChecking ? host_order() : HostOrder::forward; }
  // Launches counted as CudaExec makes them (device::Traffic).
  template <class Body>
  static void forall(int n, Body body) {
    if (n > 0) device::count_launches(1);
    const HostPermutation p = next_host_permutation(n, order());
    host_parallel_for(n, [&](int k, int) { body(p(k)); });
  }
  // The values a reduction returns cross to the host on a GPU: counted as such.
  template <int N, class Body>
  static std::array<real, N> sum(int n, Body body) {
    if (n <= 0) return {};
    device::count_copy(true, N * sizeof(real));
    device::count_launches(2);  // the start values, the reduction
    return sum_here<N>(n, body);
  }
  template <int N, int kBlocksPerSm = 1, class Body>
  static void sum_to(int n, Body body, real* out) {
    if (n > 0) device::count_launches(1);
    const std::array<real, N> r = sum_here<N>(n, body);
    for (int k = 0; k < N; ++k) out[k] += r[k];
  }
  template <int N, int kBlocksPerSm = 1, class Body, class Before>
  static void sum_to(int n, Body body, real* out, Before before_add) {
    if constexpr (std::is_same_v<Before, NoEpilogue>)
      if (n <= 0) return;
    device::count_launches(1);
    const std::array<real, N> r = sum_here<N>(n, body);
    before_add();
    for (int k = 0; k < N; ++k) out[k] += r[k];
  }
  template <int N, class Body>
  static std::array<real, N> max(int n, Body body) {
    std::array<real, N> out;
    out.fill(-std::numeric_limits<real>::infinity());
    if (n <= 0) return out;
    device::count_copy(true, N * sizeof(real));  // CudaExec's maxima (the start values are set there)
    device::count_launches(2);
    const HostPermutation p = next_host_permutation(n, order());
    // Each worker's maxima apart (a cache line each), then taken in worker order (a maximum does
    // not depend on it).
    struct alignas(64) Part {
      std::array<real, N> m;
    };
    std::vector<Part> part(std::size_t(host_workers()), Part{out});
    host_parallel_for(n, [&](int k, int t) { body(p(k), part[std::size_t(t)].m.data()); });
    for (const Part& w : part)
      for (int k = 0; k < N; ++k) out[k] = std::max(out[k], w.m[k]);
    return out;
  }
  static long scan(long n, const long* in, long* out) {
    // CudaExec copies the last input and the last output (a long each) to the host.
    if (n <= 0) return 0;
    device::count_copy(true, sizeof(long)), device::count_copy(true, sizeof(long));
    device::count_launches(1);
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
    if (n > 1) device::count_launches(1);
    std::sort(first, first + n, less);
    // Elements that compare equal could come out in another order from the GPU's sort.
    if (order() == HostOrder::scrambled)
      for (long k = 1; k < n; ++k)
        if (!less(first[k - 1], first[k]))
          throw std::logic_error("HostExec::sort: elements " + std::to_string(k - 1) + " and " + std::to_string(k) +
                                 " of " + std::to_string(n) + " compare equal, so their order is not fixed");
  }
  static void synchronize() {}

 private:
  template <int N, class Body>
  static std::array<real, N> sum_here(int n, Body body) {
    std::array<real, N> out{};
#if !defined(FDEM_HOST_RACE_THREADS)
    if (order() == HostOrder::forward) {
      real acc[N] = {};
      if (n < kHostSerialBelow || host_workers() == 1) {  // (no team to start)
        for (int i = 0; i < n; ++i) body(i, acc);
      } else {
#pragma omp parallel for schedule(static) reduction(+ : acc[:N])
        for (int i = 0; i < n; ++i) body(i, acc);
      }
      for (int k = 0; k < N; ++k) out[k] = acc[k];
      return out;
    }
#endif
    // Each iteration's terms kept apart, then added in index order (the race check: forward
    // order too).
    const HostPermutation p = next_host_permutation(n, order());
    std::vector<std::array<real, N>> part(std::size_t(std::max(n, 0)), std::array<real, N>{});
    host_parallel_for(n, [&](int k, int) {
      const int i = p(k);
      body(i, part[i].data());
    });
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < N; ++k) out[k] += part[i][k];
    return out;
  }
};

using HostExec = HostExecutor<true>;  // the debug backend's
using CpuExec = HostExecutor<false>;  // the cpu backend's

}  // namespace fdem
