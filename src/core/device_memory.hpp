#pragma once
// Where the time loop runs and the memory it runs in.
//   cpu   : the device time loop (solver/device_loop.hpp) on the host with OpenMP, in place: its
//           arrays borrow the Solver's state and the Model's constants (DeviceArray::borrow).
//   debug : the same loop on the host, with its "device" arrays
//           in separate host buffers and the Solver's host copies poisoned (NaN) while the
//           device holds the newer state, so a missing copy shows up without a GPU (as MFEM's
//           debug device); its fresh allocations poisoned too (every byte 0xFF), so a pass that
//           reads what nothing wrote fails as well.
//   cuda  : the same device time loop as CUDA kernels (built where nvcc is found).
#include <algorithm>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "core/backend.hpp"

namespace fdem {

/// The backend named `name`; throws InputError naming `where` and the choices.
Backend parse_backend(const std::string& name, const std::string& where);
/// True when this build has the CUDA backend (nvcc was found at build time).
bool cuda_built();
/// Number of CUDA devices visible (0 without the CUDA backend or without a GPU).
int cuda_device_count();
/// Why cuda_device_count() is 0: the CUDA runtime's message ("no CUDA-capable device is
/// detected", "CUDA driver version is insufficient for CUDA runtime version", ...), or "".
std::string cuda_device_count_error();
/// "NVIDIA H100 80GB HBM3, 79 GiB, 132 SMs" or "" (for logs and benchmarks).
std::string cuda_device_description();
/// Makes GPU (local_rank mod the visible count) this process's device, so ranks on one node
/// spread over its GPUs (with one GPU bound per task, each sees one: device 0). Returns the
/// device chosen.
int select_cuda_device(int local_rank);

namespace device {
// Raw memory of a backend (debug: host buffers kept apart from the host copies). Errors throw
// RunError naming the call and the byte count.
void* allocate(Backend b, std::size_t bytes);
void release(Backend b, void* p, std::size_t bytes) noexcept;
void to_device(Backend b, void* dst, const void* src, std::size_t bytes);
void to_host(Backend b, void* dst, const void* src, std::size_t bytes);
/// A copy to the host that the host waits for later, so that device work queued after it runs
/// while the host waits: read_start queues the copy of `bytes` from device memory `src` behind
/// the work queued so far (CUDA: into pinned host memory, then an event); read_finish waits for
/// it and puts the bytes at `dst`. One read at a time per host thread (a new read_start drops one
/// left unfinished); `bytes` the same in both, else read_finish throws std::logic_error.
/// Counted as one copy to the host. The debug backend copies at read_start.
void read_start(Backend b, const void* src, std::size_t bytes);
void read_finish(Backend b, void* dst, std::size_t bytes);
/// Blocks until the backend's queued work is done (CUDA: cudaDeviceSynchronize; for timings).
void synchronize(Backend b);
/// Measured copy bandwidth of the backend's memory, GB/s (bytes read + written per second),
/// from copying `bytes` within it a few times (the best run). For benchmarks.
double copy_bandwidth(Backend b, std::size_t bytes);
/// Bytes the backend's memory has free now: the GPU's (cudaMemGetInfo) for cuda, the host's
/// MemAvailable (/proc/meminfo; 0 where it cannot be read) for cpu and debug. For benchmarks.
std::size_t memory_available(Backend b);
/// Resident memory of this process now and at its peak (VmRSS, VmHWM of /proc/self/status),
/// bytes; 0 where unknown. reset_host_peak() starts the peak afresh from now (Linux's
/// /proc/self/clear_refs); false where that is refused.
std::size_t host_resident();
std::size_t host_peak_resident();
bool reset_host_peak();
/// Bytes allocated now and at most so far, over all arrays of all backends (borrowed ones not:
/// DeviceArray::borrow).
std::size_t bytes_in_use();
std::size_t peak_bytes();
/// Starts peak_bytes() afresh from the bytes in use now.
void reset_peak_bytes();

/// Copies between host and device memory (debug and cuda backends), counted since the last
/// reset_traffic(): the copies of to_host/to_device and the values a reduction or scan returns
/// to the host. The device loop's contract is that between monitor rows and output only a few
/// scalars cross per step, whatever the model's size (tests/regression/test_backends.cpp).
/// Counted on the host thread that drives the device.
/// `launches` counts the device passes in the same way: each kernel CudaExec launches (a
/// forall or reduction of at least one iteration; a reduction's start values set on the device
/// count one more), each Thrust sort or scan one. On a GPU each costs a few microseconds
/// however little it does, so a small model's step is bound by their number.
struct Traffic {
  long to_host = 0, to_device = 0;               // copies
  std::size_t host_bytes = 0, device_bytes = 0;  // bytes copied device to host, host to device
  std::size_t largest_to_host = 0, largest_to_device = 0;
  long launches = 0;
  long launches_ahead = 0;  // of them, made while a read was in flight (read_start to read_finish):
                            // device work queued behind the copy the host waits for
};
const Traffic& traffic();
void reset_traffic();
/// Counts one copy of `bytes` (to the host or to the device).
void count_copy(bool to_host, std::size_t bytes);
/// Counts `n` launches of device work.
void count_launches(long n);
}  // namespace device

/// An array in a backend's memory. Its capacity grows geometrically (x 1.5), and growth after the
/// first allocation is counted so runs can report it (contact pairs). Move-only.
template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(Backend b) : b_(b) {}
  DeviceArray(DeviceArray&& o) noexcept { swap(o); }
  DeviceArray& operator=(DeviceArray&& o) noexcept {
    swap(o);
    return *this;
  }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  ~DeviceArray() { free(); }

  void set_backend(Backend b) {
    free();
    b_ = b;
  }
  /// The cpu backend works in place: the array becomes the n elements at host memory p, which
  /// it does not own (the Solver's state, the Model's constants). upload() and download() of
  /// those same elements then copy nothing. p must outlive the array or be borrowed again.
  void borrow(T* p, std::size_t n) {
    free();
    p_ = p, n_ = cap_ = n, borrowed_ = true;
  }
  void borrow(std::vector<T>& h) { borrow(h.data(), h.size()); }
  bool borrowed() const { return borrowed_; }
  /// No elements and no memory (a borrowed array lets go).
  void release() { free(); }
  /// n elements; the contents are kept only when no reallocation happens. A borrowed array
  /// cannot grow.
  void resize(std::size_t n) {
    if (n > cap_ && borrowed_)
      throw std::logic_error("DeviceArray: a borrowed array of " + std::to_string(cap_) + " cannot grow to " +
                             std::to_string(n));
    if (n > cap_) {
      const std::size_t cap = cap_ == 0 ? n : std::max(n, cap_ + cap_ / 2);
      if (cap_ > 0) ++grown_;
      free();
      p_ = static_cast<T*>(device::allocate(b_, cap * sizeof(T)));
      cap_ = cap;
    }
    n_ = n;
  }
  void upload(const T* h, std::size_t n) {
    resize(n);
    if (n && h != p_) device::to_device(b_, p_, h, n * sizeof(T));
  }
  void upload(const std::vector<T>& h) { upload(h.data(), h.size()); }
  void download(T* h) const {
    if (n_ && h != p_) device::to_host(b_, h, p_, n_ * sizeof(T));
  }
  void download(std::vector<T>& h) const {
    h.resize(n_);
    download(h.data());
  }
  T* data() { return p_; }
  const T* data() const { return p_; }
  std::size_t size() const { return n_; }
  /// How often the array was reallocated larger after its first allocation.
  long times_grown() const { return grown_; }

 private:
  void swap(DeviceArray& o) {
    std::swap(b_, o.b_), std::swap(p_, o.p_), std::swap(n_, o.n_), std::swap(cap_, o.cap_), std::swap(grown_, o.grown_);
    std::swap(borrowed_, o.borrowed_);
  }
  void free() {
    if (!borrowed_) device::release(b_, p_, cap_ * sizeof(T));
    p_ = nullptr, n_ = cap_ = 0, borrowed_ = false;
  }
  Backend b_ = Backend::debug;
  T* p_ = nullptr;
  std::size_t n_ = 0, cap_ = 0;
  long grown_ = 0;
  bool borrowed_ = false;
};

}  // namespace fdem
