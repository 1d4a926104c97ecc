// HostExec (core/forall.hpp), the debug backend's stand-in for the GPU: each launch's iterations
// run in a scrambled order, every index exactly once, while sums come out as in index order. A
// body that depends on the order of its iterations (a race on a GPU) then gives another result
// than in index order, which is what the debug backend's bit-for-bit tests against the CPU
// backend (tests/regression/test_backends.cpp) rely on.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/forall.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

using namespace fdem;

namespace {

/// Sets the order for one test and puts the previous one back. One thread, as the debug
/// backend's tests run, so that the order seen is the order run.
struct OrderScope {
  explicit OrderScope(HostOrder o) : saved(host_order()) {
    set_host_order(o);
#ifdef _OPENMP
    omp_set_num_threads(1);
#endif
  }
  ~OrderScope() {
    set_host_order(saved);
  }
  HostOrder saved;
};

/// The indices of one forall launch of n, in the order they ran.
std::vector<int> visit_order(int n) {
  std::vector<int> seen;
  HostExec::forall(n, [&](int i) { seen.push_back(i); });
  return seen;
}

}  // namespace

TEST(HostExec, ScrambledLaunchesRunEveryIndexOnceAndNotInIndexOrder) {
  OrderScope scope(HostOrder::scrambled);
  // Primes, powers of two and sizes with many divisors (a must be coprime to each).
  for (int n : {2, 3, 7, 64, 97, 360, 1024, 5040, 100003}) {
    for (int launch = 0; launch < 3; ++launch) {
      const std::vector<int> seen = visit_order(n);
      ASSERT_EQ(int(seen.size()), n);
      std::vector<int> count(n, 0);
      for (int i : seen) {
        ASSERT_GE(i, 0);
        ASSERT_LT(i, n);
        ++count[i];
      }
      for (int i = 0; i < n; ++i) ASSERT_EQ(count[i], 1) << "index " << i << " of " << n;
      if (n >= 64) {
        // Neighbouring indices mostly run far apart: fewer than 1 % of the steps are +1.
        int ascending = 0;
        for (int k = 1; k < n; ++k) ascending += seen[k] == seen[k - 1] + 1;
        EXPECT_LE(ascending, n / 100 + 1) << "n = " << n;
      }
    }
  }
  // Successive launches of one size start elsewhere.
  EXPECT_NE(visit_order(360), visit_order(360));
}

TEST(HostExec, ForwardOrderRunsIndicesInOrder) {
  OrderScope scope(HostOrder::forward);
  const std::vector<int> seen = visit_order(1000);
  for (int i = 0; i < 1000; ++i) ASSERT_EQ(seen[i], i);
}

TEST(HostExec, ScrambledSumsEqualIndexOrderSumsBitForBit) {
  // Terms of very different size, so that another order of addition would round differently.
  const int n = 5000;
  std::vector<real> terms(n);
  for (int i = 0; i < n; ++i) terms[i] = std::pow(10.0, (i * 37) % 17 - 8) * (1 + 1e-3 * i) * ((i % 3) ? 1 : -1);
  const real* t = terms.data();
  auto body = [=](int i, real* acc) {
    acc[0] += t[i];
    acc[1] += t[i] * t[i];
  };
  std::array<real, 2> forward, scrambled;
  {
    OrderScope scope(HostOrder::forward);
    forward = HostExec::sum<2>(n, body);
  }
  {
    OrderScope scope(HostOrder::scrambled);
    scrambled = HostExec::sum<2>(n, body);
  }
  real serial[2] = {0, 0};
  for (int i = 0; i < n; ++i) serial[0] += t[i], serial[1] += t[i] * t[i];
  EXPECT_EQ(forward[0], serial[0]);
  EXPECT_EQ(scrambled[0], serial[0]);
  EXPECT_EQ(scrambled[1], serial[1]);
  // The same terms added in the scrambled order do round differently: the check above is not
  // one that any order would pass.
  real other = 0;
  const HostPermutation p = {long(0.6180339887 * n) + 1, 17, n};
  for (int k = 0; k < n; ++k) other += t[p(k)];
  EXPECT_NE(other, serial[0]);
}

TEST(HostExec, ABodyReadingWhatItsLaunchWritesGivesAnotherResultScrambled) {
  // y[i] = y[i - 1] + 1 within one launch: a race on a GPU, a running count in index order.
  auto run = [](HostOrder o) {
    OrderScope scope(o);
    std::vector<int> y(500, 0);
    int* p = y.data();
    HostExec::forall(499, [=](int i) { p[i + 1] = p[i] + 1; });
    return y;
  };
  const std::vector<int> forward = run(HostOrder::forward), scrambled = run(HostOrder::scrambled);
  EXPECT_EQ(forward[499], 499);
  EXPECT_NE(scrambled, forward);
  // A body writing only its own index gives the same result in any order.
  auto own = [](HostOrder o) {
    OrderScope scope(o);
    std::vector<int> y(500, 0);
    int* p = y.data();
    HostExec::forall(500, [=](int i) { p[i] = 3 * i + 1; });
    return y;
  };
  EXPECT_EQ(own(HostOrder::forward), own(HostOrder::scrambled));
}

TEST(HostExec, MaximaDoNotDependOnTheOrder) {
  OrderScope scope(HostOrder::scrambled);
  const auto m = HostExec::max<2>(1000, [](int i, real* acc) {
    acc[0] = std::max(acc[0], real((i * 7919) % 1000));
    acc[1] = std::max(acc[1], -real(i));
  });
  EXPECT_EQ(m[0], 999);
  EXPECT_EQ(m[1], 0);
}

TEST(HostExec, SortingEqualKeysIsAnErrorWhenScrambled) {
  // The GPU's sort may order elements that compare equal differently from std::sort.
  OrderScope scope(HostOrder::scrambled);
  std::vector<int> distinct = {5, 3, 9, 1};
  HostExec::sort(distinct.data(), long(distinct.size()), [](int a, int b) { return a < b; });
  EXPECT_EQ(distinct, (std::vector<int>{1, 3, 5, 9}));
  std::vector<int> ties = {5, 3, 5, 1};
  EXPECT_THROW(HostExec::sort(ties.data(), long(ties.size()), [](int a, int b) { return a < b; }), std::logic_error);
}

TEST(HostExec, SumToRunsBeforeAddOnceJustBeforeTheSumsAreAddedEvenOverNoIndices) {
  // (CudaExec: the reduction's last block, in the same launch.)
  for (int n : {0, 5}) {
    real out[2] = {7, 7};
    int calls = 0;
    device::reset_traffic();
    HostExec::sum_to<2>(
        n,
        [](int i, real* acc) {
          acc[0] += 1;
          acc[1] += i;
        },
        out,
        [&] {
          ++calls;
          out[0] = out[1] = 100;  // what the sums are added to
        });
    EXPECT_EQ(calls, 1) << n;
    EXPECT_EQ(out[0], 100 + n) << n;
    EXPECT_EQ(out[1], 100 + n * (n - 1) / 2) << n;
    EXPECT_EQ(device::traffic().launches, 1) << n;
  }
  // Without it, no indices launch nothing.
  device::reset_traffic();
  real out[1] = {3};
  HostExec::sum_to<1>(
      0, [](int, real* acc) { acc[0] += 1; }, out);
  EXPECT_EQ(out[0], 3);
  EXPECT_EQ(device::traffic().launches, 0);
}

TEST(HostExec, ARaisedFlagIsCountedOnceHoweverManyIterationsRaiseIt) {
  // Many iterations of one launch raising the same few flags, on several threads: each flag that
  // was 0 counts once, one already raised never (on a GPU, a plain "if (!f) f = 1, ++count"
  // counts a flag as often as the threads that read it before the first write).
#ifdef _OPENMP
  const int threads = omp_get_max_threads();
  omp_set_num_threads(4);
#endif
  std::vector<std::uint8_t> flags(41, 0);
  flags[3] = flags[40] = 1;
  std::uint8_t* f = flags.data();
  const int n = 100000;
  const auto raised = HostExec::sum<1>(n, [=](int i, real* acc) {
    if (raise_flag(f + (i * 7) % 41)) acc[0] += 1;
  });
#ifdef _OPENMP
  omp_set_num_threads(threads);
#endif
  EXPECT_EQ(raised[0], 39);
  for (std::size_t k = 0; k < flags.size(); ++k) EXPECT_EQ(flags[k], 1) << "flag " << k;
  // The byte is raised alone: its neighbours in the word keep their values.
  std::uint8_t word[4] = {0, 0, 0, 0};
  EXPECT_TRUE(raise_flag(word + 2));
  EXPECT_FALSE(raise_flag(word + 2));
  EXPECT_EQ(word[0] + word[1] + word[3], 0);
  EXPECT_EQ(word[2], 1);
  // And in a long (the scans' input).
  std::vector<long> node(5, 0);
  long* q = node.data();
  HostExec::forall(1000, [=](int i) { raise_flag(q + 1 + i % 3); });
  EXPECT_EQ(node, (std::vector<long>{0, 1, 1, 1, 0}));
}
