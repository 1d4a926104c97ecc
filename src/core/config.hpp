#pragma once
// Host/device annotation and the floating-point type of the solver state.
#if defined(__CUDACC__)
#define FDEM_HD __host__ __device__ inline
#define FDEM_HD_INLINE __host__ __device__ __forceinline__
#else
#define FDEM_HD inline
// Where the host compiler would call a small hot function out of line: always inlined.
#define FDEM_HD_INLINE inline __attribute__((always_inline))
#endif

namespace fdem {
using real = double;  // SI units throughout: m, kg, s, Pa, J
}  // namespace fdem
