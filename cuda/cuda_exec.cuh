#pragma once
// CudaExec: the device time loop's forall and sum (core/forall.hpp) as CUDA kernels.
#include <cuda_runtime.h>

#include <array>
#include <string>

#include "core/error.hpp"
#include "core/forall.hpp"

namespace fdem {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw RunError(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

namespace cuda_detail {
constexpr int kBlock = 256;

template <class Body>
__global__ void forall_kernel(int n, Body body) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) body(i);
}

// Each thread sums a grid-stride share, the block reduces in shared memory, and one atomicAdd
// per block and value goes to out[N] (so the last bits can differ from run to run).
template <int N, class Body>
__global__ void sum_kernel(int n, Body body, real* out) {
  __shared__ real part[N][kBlock];
  real acc[N];
  for (int k = 0; k < N; ++k) acc[k] = 0;
  for (int i = blockIdx.x * blockDim.x + threadIdx.x; i < n; i += gridDim.x * blockDim.x) body(i, acc);
  for (int k = 0; k < N; ++k) part[k][threadIdx.x] = acc[k];
  __syncthreads();
  for (int s = kBlock / 2; s > 0; s >>= 1) {
    if (threadIdx.x < s)
      for (int k = 0; k < N; ++k) part[k][threadIdx.x] += part[k][threadIdx.x + s];
    __syncthreads();
  }
  if (threadIdx.x == 0)
    for (int k = 0; k < N; ++k) atomicAdd(&out[k], part[k][0]);
}

/// A small device buffer for the sums, allocated once per thread of the host program.
real* sum_buffer();
}  // namespace cuda_detail

struct CudaExec {
  static constexpr bool on_gpu = true;
  template <class Body>
  static void forall(int n, Body body) {
    if (n <= 0) return;
    cuda_detail::forall_kernel<<<(n + cuda_detail::kBlock - 1) / cuda_detail::kBlock, cuda_detail::kBlock>>>(n, body);
    cuda_check(cudaGetLastError(), "kernel launch");
  }
  template <int N, class Body>
  static std::array<real, N> sum(int n, Body body) {
    static_assert(N <= 16, "at most 16 sums per pass");
    std::array<real, N> out{};
    if (n <= 0) return out;
    real* buf = cuda_detail::sum_buffer();
    cuda_check(cudaMemsetAsync(buf, 0, N * sizeof(real)), "cudaMemsetAsync");
    int blocks = (n + cuda_detail::kBlock - 1) / cuda_detail::kBlock;
    if (blocks > 1024) blocks = 1024;
    cuda_detail::sum_kernel<N><<<blocks, cuda_detail::kBlock>>>(n, body, buf);
    cuda_check(cudaGetLastError(), "kernel launch");
    cuda_check(cudaMemcpy(out.data(), buf, N * sizeof(real), cudaMemcpyDeviceToHost), "cudaMemcpy of sums");
    return out;
  }
  template <int N, class Body>
  static void sum_to(int n, Body body, real* out) {
    if (n <= 0) return;
    int blocks = (n + cuda_detail::kBlock - 1) / cuda_detail::kBlock;
    if (blocks > 1024) blocks = 1024;
    cuda_detail::sum_kernel<N><<<blocks, cuda_detail::kBlock>>>(n, body, out);
    cuda_check(cudaGetLastError(), "kernel launch");
  }
  static void synchronize() { cuda_check(cudaDeviceSynchronize(), "cudaDeviceSynchronize"); }
};

}  // namespace fdem
