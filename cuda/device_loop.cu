// The CUDA backend's device loop: solver/device_loop_impl.hpp compiled with CudaExec, so every
// pass is a kernel launch of the same source the debug backend runs on the host.
#include <utility>

#include "cuda_exec.cuh"
#include "solver/device_loop_impl.hpp"

namespace fdem {

std::unique_ptr<DeviceLoop> make_cuda_device_loop(const LoopParts& parts, bool direct_mpi, FusedPlan plan) {
  return std::make_unique<DeviceLoopImpl<CudaExec>>(Backend::cuda, parts, direct_mpi, std::move(plan));
}

}  // namespace fdem
