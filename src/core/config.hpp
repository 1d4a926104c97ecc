#pragma once
// Host/device annotation and the floating-point type of the solver state.
#if defined(__CUDACC__)
#define FDEM_HD __host__ __device__ inline
#else
#define FDEM_HD inline
#endif

namespace fdem {
using real = double;  // SI units throughout: m, kg, s, Pa, J
}  // namespace fdem
