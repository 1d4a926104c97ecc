// bench_math: the time loop's portable log, exp and cbrt (core/portable_math.hpp: the same bits
// on the CPU and the GPU) against the C library's, in ns per call on this host, over the
// arguments the physics meets (J of a tet near 1, softening exponents, tet volumes).
//
// Usage: bench_math [--calls N]   (default 20,000,000 per function)
// Prints Markdown on stdout. A benchmark, not a test: it checks nothing.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "core/portable_math.hpp"

namespace {

/// ns per call of f over n arguments lo, lo + step, ... (summed, so nothing is optimised away).
template <class F>
double ns_per_call(F f, long n, double lo, double step, double& sink) {
  double acc = 0, x = lo;
  const auto t0 = std::chrono::steady_clock::now();
  for (long i = 0; i < n; ++i) acc += f(x), x += step;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  sink += acc;
  return s / double(n) * 1e9;
}

}  // namespace

int main(int argc, char** argv) {
  long n = 20000000;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--calls") && i + 1 < argc && std::atol(argv[i + 1]) > 0) {
      n = std::atol(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--calls N (> 0)]\n", argv[0]);
      return 2;
    }
  }
  double sink = 0;
  struct Row {
    const char* name;
    const char* args;
    double lo, step;
    double (*lib)(double);
    double (*port)(double);
  };
  const Row rows[] = {
      {"log", "J in [0.999, 1.001]", 0.999, 0.002 / double(n), [](double x) { return std::log(x); },
       [](double x) { return fdem::portable_log(x); }},
      {"exp", "x in [-3, 0]", -3, 3 / double(n), [](double x) { return std::exp(x); },
       [](double x) { return fdem::portable_exp(x); }},
      {"cbrt", "V in [1e-12, 1e-9] m^3", 1e-12, 1e-9 / double(n), [](double x) { return std::cbrt(x); },
       [](double x) { return fdem::portable_cbrt(x); }},
  };
  std::printf(
      "# bench_math: %ld calls per function\n\n| function | arguments | C library, ns | portable, ns |\n"
      "|---|---|---|---|\n",
      n);
  for (const Row& r : rows) {
    const double a = ns_per_call(r.lib, n, r.lo, r.step, sink), b = ns_per_call(r.port, n, r.lo, r.step, sink);
    std::printf("| %s | %s | %.2f | %.2f |\n", r.name, r.args, a, b);
  }
  std::fprintf(stderr, "(checksum %g)\n", sink);
  return 0;
}
