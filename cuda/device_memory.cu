// The CUDA side of core/device_memory.cpp: allocation, copies and device queries.
#include <cuda_runtime.h>

#include <cstring>
#include <string>

#include "core/device_memory.hpp"
#include "core/error.hpp"
#include "cuda_exec.cuh"

namespace fdem {
namespace cuda_impl {

bool built() {
  return true;
}

int device_count() {
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();  // clear the error of a machine without a driver or GPU (count_error says which)
    return 0;
  }
  return n;
}

std::string count_error() {
  int n = 0;
  const cudaError_t e = cudaGetDeviceCount(&n);
  cudaGetLastError();
  return e == cudaSuccess ? std::string() : std::string(cudaGetErrorString(e));
}

std::string description() {
  if (device_count() == 0) return "";
  int dev = 0;
  cudaGetDevice(&dev);
  cudaDeviceProp p{};
  if (cudaGetDeviceProperties(&p, dev) != cudaSuccess) return "";
  return std::string(p.name) + ", " + std::to_string(p.totalGlobalMem >> 30) + " GiB, " +
         std::to_string(p.multiProcessorCount) + " SMs, sm_" + std::to_string(p.major) + std::to_string(p.minor);
}

int select_device(int local_rank) {
  const int n = device_count();
  if (n == 0) return -1;
  const int dev = local_rank % n;
  cuda_check(cudaSetDevice(dev), "cudaSetDevice");
  return dev;
}

void* allocate(std::size_t bytes) {
  if (device_count() == 0)
    throw InputError("backend cuda: no CUDA device is visible (" + count_error() +
                     "). Fix: run on a machine with an NVIDIA GPU and its driver (check nvidia-smi and "
                     "CUDA_VISIBLE_DEVICES), or run with --backend cpu");
  void* p = nullptr;
  // Rounded up to 8 bytes: an atomic on the 4-byte word that holds a byte flag (raise_flag,
  // core/forall.hpp) stays inside the allocation.
  const cudaError_t e = cudaMalloc(&p, (bytes + 7) / 8 * 8);
  if (e != cudaSuccess)
    throw RunError("CUDA: cannot allocate " + std::to_string(bytes) + " bytes of device memory (" +
                   cudaGetErrorString(e) + "). Fix: a smaller model per GPU, or more ranks");
  return p;
}

void release(void* p) noexcept {
  cudaFree(p);
}

void to_device(void* dst, const void* src, std::size_t bytes) {
  cuda_check(cudaMemcpy(dst, src, bytes, cudaMemcpyHostToDevice), "copy to the device");
}

void to_host(void* dst, const void* src, std::size_t bytes) {
  cuda_check(cudaMemcpy(dst, src, bytes, cudaMemcpyDeviceToHost), "copy to the host");
}

namespace {
// The staging of device::read_start: pinned host memory (a copy from pageable memory would wait
// for the device before returning) and the event after the copy. Per host thread, kept for the
// process's life (never freed: at exit the CUDA runtime may be torn down first).
struct Staging {
  void* pinned = nullptr;
  std::size_t capacity = 0;
  cudaEvent_t done = nullptr;
};
thread_local Staging staging;
}  // namespace

void read_start(const void* src, std::size_t bytes) {
  Staging& s = staging;
  if (bytes > s.capacity) {
    // A copy queued into the old buffer and never finished (a read dropped) must end first.
    if (s.done) cuda_check(cudaEventSynchronize(s.done), "waiting for a queued copy to the host");
    if (s.pinned) cuda_check(cudaFreeHost(s.pinned), "cudaFreeHost");
    s.pinned = nullptr, s.capacity = 0;
    cuda_check(cudaMallocHost(&s.pinned, bytes), "cudaMallocHost (staging of a read)");
    s.capacity = bytes;
  }
  if (!s.done) cuda_check(cudaEventCreateWithFlags(&s.done, cudaEventDisableTiming), "cudaEventCreate");
  cuda_check(cudaMemcpyAsync(s.pinned, src, bytes, cudaMemcpyDeviceToHost, 0), "queued copy to the host");
  cuda_check(cudaEventRecord(s.done, 0), "cudaEventRecord");
}

void read_finish(void* dst, std::size_t bytes) {
  cuda_check(cudaEventSynchronize(staging.done),
             "waiting for a queued copy to the host (or a kernel before it: FDEM_CUDA_SYNC=1 names which)");
  std::memcpy(dst, staging.pinned, bytes);
}

void synchronize() {
  cuda_check(cudaDeviceSynchronize(), "cudaDeviceSynchronize");
}

std::size_t memory_free() {
  std::size_t free = 0, total = 0;
  cuda_check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
  return free;
}

double copy_bandwidth(std::size_t bytes) {
  void *a = nullptr, *b = nullptr;
  cuda_check(cudaMalloc(&a, bytes), "cudaMalloc (bandwidth)");
  cuda_check(cudaMalloc(&b, bytes), "cudaMalloc (bandwidth)");
  cuda_check(cudaMemset(a, 1, bytes), "cudaMemset (bandwidth)");
  cudaEvent_t e0, e1;
  cuda_check(cudaEventCreate(&e0), "cudaEventCreate (bandwidth)");
  cuda_check(cudaEventCreate(&e1), "cudaEventCreate (bandwidth)");
  float best = 1e30f;
  for (int rep = 0; rep < 10; ++rep) {  // the first a warm-up
    cuda_check(cudaEventRecord(e0), "cudaEventRecord (bandwidth)");
    cuda_check(cudaMemcpy(b, a, bytes, cudaMemcpyDeviceToDevice), "device-to-device copy (bandwidth)");
    cuda_check(cudaEventRecord(e1), "cudaEventRecord (bandwidth)");
    cuda_check(cudaEventSynchronize(e1), "cudaEventSynchronize (bandwidth)");
    float ms = 0;
    cuda_check(cudaEventElapsedTime(&ms, e0, e1), "cudaEventElapsedTime (bandwidth)");
    if (rep > 0 && ms < best) best = ms;
  }
  cudaEventDestroy(e0);
  cudaEventDestroy(e1);
  cudaFree(a);
  cudaFree(b);
  if (!(best > 0 && best < 1e30f))
    throw RunError("CUDA: the copy-bandwidth measurement timed " + std::to_string(best) + " ms for " +
                   std::to_string(bytes) + " bytes");
  return 2.0 * double(bytes) / (double(best) * 1e-3) / 1e9;
}

}  // namespace cuda_impl

namespace cuda_detail {
DeviceScratch& device_scratch() {
  // One per host thread and device: a buffer is used on the device it was allocated on.
  static thread_local DeviceScratch scratch[64];
  int dev = 0;
  cuda_check(cudaGetDevice(&dev), "cudaGetDevice");
  if (dev < 0 || dev >= 64) throw RunError("CUDA: device " + std::to_string(dev) + " is beyond the 64 fdem supports");
  DeviceScratch& s = scratch[dev];
  if (!s.sums) {
    cuda_check(cudaMalloc(&s.sums, 16 * sizeof(real)), "cudaMalloc of the sum buffer");
    cuda_check(cudaMalloc(&s.partials, kMaxBlocks * 16 * sizeof(real)), "cudaMalloc of the reduction scratch");
    cuda_check(cudaMalloc(&s.ticket, sizeof(unsigned)), "cudaMalloc of the reduction ticket");
    cuda_check(cudaMemset(s.ticket, 0, sizeof(unsigned)), "cudaMemset of the reduction ticket");
  }
  return s;
}

char* ThrustScratch::allocate(std::ptrdiff_t bytes) {
  const std::size_t n = bytes > 0 ? std::size_t(bytes) : 1;
  DeviceScratch& c = device_scratch();
  if (c.thrust_busy)  // a second request while the block is lent: its own allocation
    return static_cast<char*>(device::allocate(Backend::cuda, n));
  if (n > c.thrust_bytes) {
    device::release(Backend::cuda, c.thrust, c.thrust_bytes);
    c.thrust = nullptr, c.thrust_bytes = 0;
    c.thrust = static_cast<char*>(device::allocate(Backend::cuda, n));
    c.thrust_bytes = n;
  }
  c.thrust_busy = true;
  return c.thrust;
}

void ThrustScratch::deallocate(char* p, std::size_t bytes) noexcept {
  try {
    DeviceScratch& c = device_scratch();
    if (p == c.thrust) {
      c.thrust_busy = false;
      return;
    }
  } catch (...) {
    return;  // the device cannot be asked: p may be the cached block, so it is not freed
  }
  device::release(Backend::cuda, p, bytes > 0 ? bytes : 1);
}
}  // namespace cuda_detail

}  // namespace fdem
