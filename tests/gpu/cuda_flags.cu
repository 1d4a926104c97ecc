// raise_flag (core/forall.hpp) run on the GPU for tests/gpu/test_cuda_backend.cpp: there it is
// an atomicOr on the aligned 4-byte word that holds the byte, a path the host never takes.
#include "cuda/cuda_exec.cuh"
#include "cuda_flags.hpp"

namespace fdem::test {

long raise_flags_on_cuda(std::vector<std::uint8_t>& flags, int iterations) {
  DeviceArray<std::uint8_t> d(Backend::cuda);
  d.upload(flags);
  std::uint8_t* p = d.data();
  const int n = int(flags.size());
  const std::array<real, 1> raised = CudaExec::sum<1>(iterations, [=] FDEM_LAMBDA(int i, real* acc) {
    const int j = int((7L * i) % n);
    if (raised_by_rule(j) && raise_flag(p + j)) acc[0] += 1;
  });
  d.download(flags);
  return long(raised[0]);
}

void raise_long_flags_on_cuda(std::vector<long>& flags, int iterations) {
  DeviceArray<long> d(Backend::cuda);
  d.upload(flags);
  long* p = d.data();
  const int n = int(flags.size());
  CudaExec::forall(iterations, [=] FDEM_LAMBDA(int i) {
    const int j = int((7L * i) % n);
    if (raised_by_rule(j)) raise_flag(p + j);
  });
  d.download(flags);
}

}  // namespace fdem::test
