// core/device_memory.hpp's host memory figures, on which bench_device's "largest model that
// fits" rests: the resident memory grows by what the process writes and falls when it is given
// back, the peak restarts when asked, and the host reports memory available. And the debug
// backend's device memory: poisoned when fresh, as a GPU's holds whatever was there.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
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

TEST(DebugDeviceMemory, FreshMemoryReadsNanMinusOneAnd255NotZero) {
  // A pass that reads an element nothing wrote then gets a value that fails the bit-for-bit
  // tests (a fresh host page would give zeros, which often pass).
  DeviceArray<double> r(Backend::debug);
  DeviceArray<int> i(Backend::debug);
  DeviceArray<std::uint8_t> f(Backend::debug);
  r.resize(1000), i.resize(7), f.resize(3);
  std::vector<double> hr;
  std::vector<int> hi;
  std::vector<std::uint8_t> hf;
  r.download(hr), i.download(hi), f.download(hf);
  for (double v : hr) ASSERT_TRUE(std::isnan(v));
  EXPECT_EQ(hi, std::vector<int>(7, -1));
  EXPECT_EQ(hf, std::vector<std::uint8_t>(3, 255));
  // Grown past its capacity: the new memory is poisoned too, the old contents are not kept.
  r.upload(std::vector<double>(1000, 2.0));
  r.resize(5000);
  r.download(hr);
  for (double v : hr) ASSERT_TRUE(std::isnan(v));
}
