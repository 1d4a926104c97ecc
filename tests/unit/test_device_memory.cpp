// core/device_memory.hpp's host memory figures, on which bench_device's "largest model that
// fits" rests: the resident memory grows by what the process writes and falls when it is given
// back, the peak restarts when asked, and the host reports memory available.
#include <gtest/gtest.h>

#include <cstddef>
#include <vector>

#include "core/device_memory.hpp"

using namespace fdem;

TEST(HostMemory, ResidentMemoryFollowsWhatIsWrittenAndThePeakRestarts) {
  const std::size_t n = std::size_t(256) << 20;  // 256 MiB
  const std::size_t before = device::host_resident();
  ASSERT_GT(before, 0u) << "VmRSS of /proc/self/status";
  std::vector<char> block(n, 1);  // written, so resident
  const std::size_t during = device::host_resident();
  EXPECT_GE(during, before + n * 9 / 10);
  EXPECT_GE(device::host_peak_resident(), during);
  std::vector<char>().swap(block);  // a block this large goes back to the system at once (glibc's mmap)
  EXPECT_LT(device::host_resident(), during - n / 2);
  if (!device::reset_host_peak()) GTEST_SKIP() << "this kernel refuses /proc/self/clear_refs";
  EXPECT_LT(device::host_peak_resident(), during - n / 2);  // the peak starts again from now
  EXPECT_GT(device::memory_available(Backend::cpu), n);
  EXPECT_GT(device::memory_available(Backend::debug), 0u);
}
