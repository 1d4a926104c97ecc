#pragma once
// CudaExec: the device time loop's forall and sum (core/forall.hpp) as CUDA kernels.
#include <cuda_runtime.h>
#include <thrust/execution_policy.h>
#include <thrust/scan.h>
#include <thrust/sort.h>
#include <thrust/system/cuda/execution_policy.h>

#include <array>
#include <cstdlib>
#include <exception>
#include <string>
#include <type_traits>

#include "core/error.hpp"
#include "core/forall.hpp"

namespace fdem {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw RunError(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

/// After a kernel launch: launch errors at once; with FDEM_CUDA_SYNC=1 the kernel is also waited
/// for, so that a fault inside it (an illegal address) is reported here and not at a later copy.
inline void check_launch() {
  static const bool sync = [] {
    const char* e = std::getenv("FDEM_CUDA_SYNC");
    return e && std::string(e) == "1";
  }();
  cuda_check(cudaGetLastError(), "kernel launch");
  if (sync) cuda_check(cudaDeviceSynchronize(), "kernel run (FDEM_CUDA_SYNC=1: the fault is in this kernel)");
}

namespace cuda_detail {
constexpr int kBlock = 256;

template <class Body>
__global__ void __launch_bounds__(kBlock) forall_kernel(int n, Body body) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) body(i);
}

constexpr int kMaxBlocks = 1024;  // of a reduction: the grid-stride loops cover the rest

// The block's sums of acc by a fixed tree in shared memory: part[k][0] afterwards.
template <int N>
__device__ inline void block_sum(real (&part)[N][kBlock], const real (&acc)[N]) {
  for (int k = 0; k < N; ++k) part[k][threadIdx.x] = acc[k];
  __syncthreads();
  for (int s = kBlock / 2; s > 0; s >>= 1) {
    if (threadIdx.x < s)
      for (int k = 0; k < N; ++k) part[k][threadIdx.x] += part[k][threadIdx.x + s];
    __syncthreads();
  }
}

// Each thread sums a grid-stride share and each block reduces its threads' sums in a fixed
// tree; the blocks write their sums to `partials`, and the last block to finish (a ticket
// counter; it wraps to 0 for the next launch) adds them in block order into out[N]. The
// order of every addition is fixed by n alone, so sums are the same bit for bit from run to
// run (an atomicAdd per block would add in the order the blocks finish).
// kBlocksPerSm > 1: the blocks a multiprocessor should hold at once (__launch_bounds__), so ptxas
// keeps the registers per thread under 65536 / (kBlocksPerSm kBlock) and spills the rest; the order
// of the sums is the same. 1 leaves the minimum unset (0; nvcc 13.0 then writes no .minnctapersm
// into the PTX, as for __launch_bounds__(kBlock)): stated as 1, it let ptxas take more registers
// (the stepping pass 236 instead of 202), where one block fits either way.
// before_add(): run by the last block's first thread just before it adds to out.
template <int N, int kBlocksPerSm, class Body, class Before>
__global__ void __launch_bounds__(kBlock, kBlocksPerSm > 1 ? kBlocksPerSm : 0)
    sum_kernel(int n, Body body, real* out, real* partials, unsigned* ticket, Before before_add) {
  __shared__ real part[N][kBlock];
  __shared__ bool last;
  real acc[N];
  for (int k = 0; k < N; ++k) acc[k] = 0;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) body(i, acc);
  block_sum<N>(part, acc);
  if (threadIdx.x == 0) {
    for (int k = 0; k < N; ++k) partials[blockIdx.x * N + k] = part[k][0];
    __threadfence();  // the partials are visible to every block before the ticket is
    last = atomicInc(ticket, gridDim.x - 1) == gridDim.x - 1;
    if (last) __threadfence();  // and the last block reads them after its ticket
  }
  __syncthreads();
  if (!last) return;
  for (int k = 0; k < N; ++k) acc[k] = 0;
  for (int b = threadIdx.x; b < int(gridDim.x); b += blockDim.x)
    for (int k = 0; k < N; ++k) acc[k] += __ldcg(&partials[b * N + k]);  // from L2, not a stale L1
  block_sum<N>(part, acc);
  if (threadIdx.x == 0) {
    before_add();
    for (int k = 0; k < N; ++k) out[k] += part[k][0];
  }
}

__device__ inline void atomic_max(real* a, real v) {
  unsigned long long* p = reinterpret_cast<unsigned long long*>(a);
  unsigned long long old = *p, seen;
  do {
    seen = old;
    if (__longlong_as_double(seen) >= v) return;
    old = atomicCAS(p, seen, __double_as_longlong(v));
  } while (old != seen);
}

// The start values of a reduction set on the device (no copy from the host).
template <int N>
__global__ void fill_kernel(real* out, real value) {
  if (threadIdx.x < N) out[threadIdx.x] = value;
}

template <int N, class Body>
__global__ void __launch_bounds__(kBlock) max_kernel(int n, Body body, real* out) {
  real acc[N];
  for (int k = 0; k < N; ++k) acc[k] = -INFINITY;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) body(i, acc);
  for (int k = 0; k < N; ++k) atomic_max(&out[k], acc[k]);
}

/// A device's reduction buffers, allocated at the first use (once per thread of the host
/// program and device): the sums of CudaExec::sum and the maxima (16 values), the block sums
/// of a reduction (kMaxBlocks x 16) and its ticket counter (zeroed), and the cached block of
/// ThrustScratch.
struct DeviceScratch {
  real* sums = nullptr;
  real* partials = nullptr;
  unsigned* ticket = nullptr;
  char* thrust = nullptr;
  std::size_t thrust_bytes = 0;
  bool thrust_busy = false;
};
DeviceScratch& device_scratch();

/// Thrust's temporary memory (sort, scan) through device::allocate, so device::peak_bytes
/// counts it, and kept between calls (DeviceScratch::thrust): the block grows to the largest
/// request, so a broad phase whose pairs stopped growing allocates nothing.
struct ThrustScratch {
  using value_type = char;
  char* allocate(std::ptrdiff_t bytes);
  void deallocate(char* p, std::size_t bytes) noexcept;
};

inline int reduction_blocks(int n) {
  const int blocks = (n + kBlock - 1) / kBlock;
  return blocks < kMaxBlocks ? blocks : kMaxBlocks;
}
}  // namespace cuda_detail

struct CudaExec {
  static constexpr bool on_gpu = true;
  template <class Body>
  static void forall(int n, Body body) {
    if (n <= 0) return;
    device::count_launches(1);
    cuda_detail::forall_kernel<<<(n + cuda_detail::kBlock - 1) / cuda_detail::kBlock, cuda_detail::kBlock>>>(n, body);
    check_launch();
  }
  template <int N, class Body>
  static std::array<real, N> sum(int n, Body body) {
    static_assert(N <= 16, "at most 16 sums per pass");
    std::array<real, N> out{};
    if (n <= 0) return out;
    real* buf = cuda_detail::device_scratch().sums;
    cuda_check(cudaMemsetAsync(buf, 0, N * sizeof(real)), "cudaMemsetAsync");
    device::count_launches(1);
    sum_to<N>(n, body, buf);
    cuda_check(cudaMemcpy(out.data(), buf, N * sizeof(real), cudaMemcpyDeviceToHost), "cudaMemcpy of sums");
    device::count_copy(true, N * sizeof(real));
    return out;
  }
  template <int N, int kBlocksPerSm = 1, class Body>
  static void sum_to(int n, Body body, real* out) {
    sum_to<N, kBlocksPerSm>(n, body, out, NoEpilogue{});
  }
  template <int N, int kBlocksPerSm = 1, class Body, class Before>
  static void sum_to(int n, Body body, real* out, Before before_add) {
    static_assert(N <= 16, "at most 16 sums per pass");
    if constexpr (std::is_same_v<Before, NoEpilogue>)
      if (n <= 0) return;  // (nothing to add and nothing to run before)
    const cuda_detail::DeviceScratch& scratch = cuda_detail::device_scratch();
    device::count_launches(1);
    const int blocks = n > 0 ? cuda_detail::reduction_blocks(n) : 1;  // (n = 0: before_add still runs)
    cuda_detail::sum_kernel<N, kBlocksPerSm>
        <<<blocks, cuda_detail::kBlock>>>(n, body, out, scratch.partials, scratch.ticket, before_add);
    check_launch();
  }
  template <int N, class Body>
  static std::array<real, N> max(int n, Body body) {
    static_assert(N <= 16, "at most 16 maxima per pass");
    std::array<real, N> out;
    out.fill(-INFINITY);
    if (n <= 0) return out;
    real* buf = cuda_detail::device_scratch().sums;
    device::count_launches(2);
    cuda_detail::fill_kernel<N><<<1, N>>>(buf, -INFINITY);
    check_launch();
    cuda_detail::max_kernel<N><<<cuda_detail::reduction_blocks(n), cuda_detail::kBlock>>>(n, body, buf);
    check_launch();
    cuda_check(cudaMemcpy(out.data(), buf, N * sizeof(real), cudaMemcpyDeviceToHost), "cudaMemcpy of maxima");
    device::count_copy(true, N * sizeof(real));
    return out;
  }
  static long scan(long n, const long* in, long* out) {
    if (n <= 0) return 0;
    long last[2];  // the last input is read first: in may be out
    cuda_check(cudaMemcpy(&last[0], in + n - 1, sizeof(long), cudaMemcpyDeviceToHost), "cudaMemcpy");
    try {
      cuda_detail::ThrustScratch scratch;
      device::count_launches(1);
      thrust::exclusive_scan(thrust::cuda::par(scratch), in, in + n, out);
    } catch (const std::exception& e) {  // Thrust's own scratch memory: thrust::system_error, std::bad_alloc
      throw RunError(std::string("CUDA: prefix sum (Thrust): ") + e.what() +
                     ". Fix: a smaller model per GPU, or more ranks");
    }
    cuda_check(cudaMemcpy(&last[1], out + n - 1, sizeof(long), cudaMemcpyDeviceToHost), "cudaMemcpy");
    device::count_copy(true, sizeof(long)), device::count_copy(true, sizeof(long));
    return last[0] + last[1];
  }
  template <class T, class Less>
  static void sort(T* first, long n, Less less) {
    try {
      cuda_detail::ThrustScratch scratch;
      if (n > 1) device::count_launches(1), thrust::sort(thrust::cuda::par(scratch), first, first + n, less);
    } catch (const std::exception& e) {
      throw RunError(std::string("CUDA: sort (Thrust): ") + e.what() + ". Fix: a smaller model per GPU, or more ranks");
    }
    cuda_check(cudaGetLastError(), "thrust::sort");
  }
  static void synchronize() { cuda_check(cudaDeviceSynchronize(), "cudaDeviceSynchronize"); }
};

}  // namespace fdem
