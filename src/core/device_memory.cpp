#include "core/device_memory.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/error.hpp"

namespace fdem {

// The CUDA side (cuda/device_memory.cu where nvcc is found; otherwise the refusals below).
namespace cuda_impl {
bool built();
int device_count();
std::string count_error();
std::string description();
int select_device(int local_rank);
void* allocate(std::size_t bytes);
void release(void* p) noexcept;
void to_device(void* dst, const void* src, std::size_t bytes);
void to_host(void* dst, const void* src, std::size_t bytes);
void read_start(const void* src, std::size_t bytes);
void read_finish(void* dst, std::size_t bytes);
void synchronize();
double copy_bandwidth(std::size_t bytes);
std::size_t memory_free();
}  // namespace cuda_impl

#ifndef FDEM_HAVE_CUDA
namespace cuda_impl {
namespace {
[[noreturn]] void refuse() {
  throw InputError(
      "backend cuda: this fdem was built without CUDA (nvcc was not found at build time). Fix: build where "
      "nvcc is installed (cmake -DFDEM_ENABLE_CUDA=ON), or run with --backend cpu");
}
}  // namespace
bool built() {
  return false;
}
int device_count() {
  return 0;
}
std::string count_error() {
  return "this fdem was built without CUDA";
}
std::string description() {
  return "";
}
int select_device(int) {
  refuse();
}
void* allocate(std::size_t) {
  refuse();
}
void release(void*) noexcept {}
void to_device(void*, const void*, std::size_t) {
  refuse();
}
void to_host(void*, const void*, std::size_t) {
  refuse();
}
void read_start(const void*, std::size_t) {
  refuse();
}
void read_finish(void*, std::size_t) {
  refuse();
}
void synchronize() {}
double copy_bandwidth(std::size_t) {
  refuse();
}
std::size_t memory_free() {
  refuse();
}
}  // namespace cuda_impl
#endif

Backend parse_backend(const std::string& name, const std::string& where) {
  Backend b = Backend::cpu;
  if (choice_named(name, b)) return b;
  throw InputError(where + ": unknown backend '" + name + "'. Fix: give cpu, cuda, or debug (the device loop on the " +
                   "CPU with separate device memory, for checking)");
}

bool cuda_built() {
  return cuda_impl::built();
}
int cuda_device_count() {
  return cuda_impl::device_count();
}
std::string cuda_device_count_error() {
  return cuda_impl::count_error();
}
std::string cuda_device_description() {
  return cuda_impl::description();
}
int select_cuda_device(int local_rank) {
  return cuda_impl::select_device(local_rank);
}

namespace device {
namespace {
std::atomic<std::size_t> in_use{0}, peak{0};
Traffic copies;
}  // namespace

namespace {
// The read in flight on this host thread (read_start to read_finish): its size, and the debug
// backend's copy of the bytes.
struct PendingRead {
  std::size_t bytes = 0;
  bool open = false;
  std::vector<char> staged;
};
thread_local PendingRead pending_read;
}  // namespace

const Traffic& traffic() {
  return copies;
}
void reset_traffic() {
  copies = Traffic{};
}
void count_launches(long n) {
  copies.launches += n;
  if (pending_read.open) copies.launches_ahead += n;
}
void count_copy(bool to_host, std::size_t bytes) {
  if (to_host) {
    ++copies.to_host, copies.host_bytes += bytes;
    copies.largest_to_host = std::max(copies.largest_to_host, bytes);
  } else {
    ++copies.to_device, copies.device_bytes += bytes;
    copies.largest_to_device = std::max(copies.largest_to_device, bytes);
  }
}

void* allocate(Backend b, std::size_t bytes) {
  if (bytes == 0) return nullptr;
  void* p = nullptr;
  if (b == Backend::cuda) {
    p = cuda_impl::allocate(bytes);
  } else {
    p = std::malloc(bytes);
    if (!p)
      throw RunError("host memory (" + std::string(name_of(b)) + " backend): cannot allocate " + std::to_string(bytes) +
                     " bytes");
    // Debug: poisoned, as the GPU's fresh memory holds whatever was there: a pass that reads an
    // element nothing wrote reads NaN (reals), -1 (indices) or 255 (flags), not the zeros a
    // fresh page of the host gives, and the bit-for-bit tests fail.
    if (b == Backend::debug) std::memset(p, 0xFF, bytes);
  }
  const std::size_t now = in_use += bytes;
  std::size_t seen = peak.load();
  while (now > seen && !peak.compare_exchange_weak(seen, now)) {
  }
  return p;
}

void release(Backend b, void* p, std::size_t bytes) noexcept {
  if (!p) return;
  in_use -= std::min<std::size_t>(bytes, in_use.load());
  if (b == Backend::cuda) {
    cuda_impl::release(p);
  } else {
    std::free(p);
  }
}

void to_device(Backend b, void* dst, const void* src, std::size_t bytes) {
  count_copy(false, bytes);
  if (b == Backend::cuda) {
    cuda_impl::to_device(dst, src, bytes);
  } else {
    std::memcpy(dst, src, bytes);
  }
}

void to_host(Backend b, void* dst, const void* src, std::size_t bytes) {
  count_copy(true, bytes);
  if (b == Backend::cuda) {
    cuda_impl::to_host(dst, src, bytes);
  } else {
    std::memcpy(dst, src, bytes);
  }
}

void read_start(Backend b, const void* src, std::size_t bytes) {
  PendingRead& r = pending_read;  // (a read left unfinished by an exception is dropped)
  count_copy(true, bytes);
  if (b == Backend::cuda) {
    cuda_impl::read_start(src, bytes);
  } else {
    r.staged.resize(bytes);
    std::memcpy(r.staged.data(), src, bytes);
  }
  r.bytes = bytes, r.open = true;
}

void read_finish(Backend b, void* dst, std::size_t bytes) {
  PendingRead& r = pending_read;
  if (!r.open || r.bytes != bytes)
    throw std::logic_error("device::read_finish: no read of " + std::to_string(bytes) + " bytes in flight");
  r.open = false;
  if (b == Backend::cuda)
    cuda_impl::read_finish(dst, bytes);
  else
    std::memcpy(dst, r.staged.data(), bytes);
}

void synchronize(Backend b) {
  if (b == Backend::cuda) cuda_impl::synchronize();
}

double copy_bandwidth(Backend b, std::size_t bytes) {
  if (b == Backend::cuda) return cuda_impl::copy_bandwidth(bytes);
  std::vector<char> src(bytes, 1), dst(bytes, 0);
  double best = 1e300;
  for (int rep = 0; rep < 5; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    std::memcpy(dst.data(), src.data(), bytes);
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  return 2.0 * double(bytes) / best / 1e9;
}

namespace {
/// The number in kB after `key` in a /proc file, as bytes; 0 where missing.
std::size_t proc_kb(const char* file, const std::string& key) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
    if (line.compare(0, key.size(), key) == 0)
      return std::size_t(std::strtoull(line.c_str() + key.size(), nullptr, 10)) * 1024;
  return 0;
}
}  // namespace

std::size_t memory_available(Backend b) {
  if (b == Backend::cuda) return cuda_impl::memory_free();
  return proc_kb("/proc/meminfo", "MemAvailable:");
}

std::size_t host_resident() {
  return proc_kb("/proc/self/status", "VmRSS:");
}

std::size_t host_peak_resident() {
  return proc_kb("/proc/self/status", "VmHWM:");
}

bool reset_host_peak() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return bool(out);
}

std::size_t bytes_in_use() {
  return in_use.load();
}
void reset_peak_bytes() {
  peak.store(in_use.load());
}

std::size_t peak_bytes() {
  return peak.load();
}
}  // namespace device

}  // namespace fdem
