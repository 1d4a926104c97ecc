#pragma once
// What every part of the device loop uses: the arrays placed for a backend and the passes'
// clock.
#include <chrono>
#include <cstddef>
#include <vector>

#include "core/device_memory.hpp"

namespace fdem {

/// The array the passes use for host data h (n elements): h itself on the cpu backend, which
/// works in place, else a copy in the backend's memory. (The passes write only the state's.)
template <class T>
void place(Backend b, DeviceArray<T>& d, const T* h, std::size_t n) {
  if (b == Backend::cpu)
    d.borrow(const_cast<T*>(h), n);
  else
    d.upload(h, n);
}
template <class T>
void place(Backend b, DeviceArray<T>& d, const std::vector<T>& h) {
  place(b, d, h.data(), h.size());
}

/// The second copy of a double-buffered array, n elements, the loop's own. On the cpu backend a
/// swap can have left it borrowing the host's array, which the first copy borrows again at an
/// upload: the pass would then read and write one array.
template <class T>
void own_copy(DeviceArray<T>& second, std::size_t n) {
  if (second.borrowed()) second.release();
  second.resize(n);
}

/// The passes' clock: each lap adds the time since the last to a column of DeviceTimes. With
/// `timing` on it waits for the device first, so that a pass's column holds its own time.
template <class Exec>
struct PassClock {
  using Clock = std::chrono::steady_clock;
  bool timing = false;
  Clock::time_point t0 = Clock::now();
  void restart() { t0 = Clock::now(); }
  void lap(double& into) {
    if (timing) Exec::synchronize();
    const auto t1 = Clock::now();
    into += std::chrono::duration<double>(t1 - t0).count();
    t0 = t1;
  }
};

}  // namespace fdem
