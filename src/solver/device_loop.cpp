// The debug backend's device loop (HostExec) and the choice of backend.
#include "solver/device_loop.hpp"

#include "core/error.hpp"
#include "partition/halo.hpp"
#include "solver/device_loop_impl.hpp"

namespace fdem {

// cuda/device_loop.cu where nvcc is found.
std::unique_ptr<DeviceLoop> make_cuda_device_loop(bool direct_mpi);

#ifndef FDEM_HAVE_CUDA
std::unique_ptr<DeviceLoop> make_cuda_device_loop(bool) {
  throw InputError(
      "solver.backend cuda: this fdem was built without CUDA (nvcc was not found at build time). Fix: build where "
      "nvcc is installed (cmake -DFDEM_ENABLE_CUDA=ON), or run with --backend cpu");
}
#endif

std::unique_ptr<DeviceLoop> make_device_loop(Backend b, const Solver& s) {
  // Read (and checked) here, at the start, on every rank alike.
  const bool direct_mpi = s.decomposition().distributed() && device_buffers_to_mpi(b == Backend::cuda);
  switch (b) {
    case Backend::debug:
      host_order();  // FDEM_DEBUG_ORDER, checked before the run starts
      return std::make_unique<DeviceLoopImpl<HostExec>>(Backend::debug, direct_mpi);
    case Backend::cuda:
      if (cuda_built()) {
        // All ranks decide together, so that none is left waiting in the split below.
        const int visible = cuda_device_count();
        int fewest = visible;
        MPI_Allreduce(&visible, &fewest, 1, MPI_INT, MPI_MIN, s.comm());
        if (fewest == 0)
          throw InputError("solver.backend cuda: no CUDA device is visible" +
                           (visible == 0 ? " (" + cuda_device_count_error() + ")" : std::string(" on another rank")) +
                           ". Fix: run on a machine with an NVIDIA GPU and its driver (check nvidia-smi and "
                           "CUDA_VISIBLE_DEVICES), or run with --backend cpu");
        // Ranks sharing a node take its GPUs in turn.
        MPI_Comm node;
        MPI_Comm_split_type(s.comm(), MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node);
        select_cuda_device(rank_in(node));
        MPI_Comm_free(&node);
      }
      return make_cuda_device_loop(direct_mpi);
    case Backend::cpu:
      break;
  }
  throw InputError("the cpu backend has no device loop");
}

}  // namespace fdem
