#!/usr/bin/env bash
# One call on the GPU machine (the device tool): build the CUDA backend, check it against the
# CPU backend, and time it; everything it reports goes under $OUT.
#   bash scripts/gpu_check.sh            (with deps/ carried: see below)
# The GPU machine (Ubuntu 24.04, CUDA 13, Open MPI 4.1.6, serial HDF5, yaml-cpp, GoogleTest,
# Eigen) has no gmsh, METIS or CLI11. Prepare them on a Debian machine, into the ignored deps/:
#   (cd /tmp && apt-get download libmetis5 libmetis-dev libcli11-dev) &&
#   for p in /tmp/libmetis5_*.deb /tmp/libmetis-dev_*.deb /tmp/libcli11-dev_*.deb; do dpkg -x "$p" deps; done
# and carry deps/ with the run. The build has no gmsh (FDEM_ENABLE_GMSH=OFF): the checks and the
# benchmark use structured meshes.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
OUT=${OUT:-out/gpu_check}
mkdir -p "$OUT"
DEPS=$PWD/deps
export LD_LIBRARY_PATH="$DEPS/usr/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
{
  date -u
  nvidia-smi || true
  nvcc --version | tail -2
} > "$OUT/machine.txt" 2>&1

step() {  # step NAME COMMAND...: run, log to $OUT/NAME.log, record the exit code
  local name=$1
  shift
  local t0=$SECONDS
  "$@" > "$OUT/$name.log" 2>&1
  local rc=$?
  echo "$name: exit $rc in $((SECONDS - t0)) s" | tee -a "$OUT/summary.txt"
  return $rc
}

step configure cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON -DFDEM_ENABLE_GMSH=OFF \
  -DFDEM_ENABLE_PETSC=OFF -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" || exit 1
step build cmake --build build-gpu -j "$(nproc)" --target fdem test_cuda_backend test_backends test_ranks \
  bench_device || exit 1
# CPU = CUDA on one rank (tests/gpu), the debug backend as everywhere, and the 1-vs-2-rank device
# check with both backends (the ranks share the GPU).
step gpu_tests build-gpu/tests/test_cuda_backend --gtest_output="xml:$OUT/gpu_tests.xml"
# A GPU that nvidia-smi lists but the tests skipped (a driver older than the CUDA runtime, for
# one) is a failure here, not a green run.
if nvidia-smi -L 2>/dev/null | grep -q GPU && grep -q 'SKIPPED' "$OUT/gpu_tests.log"; then
  echo "gpu_tests: nvidia-smi lists a GPU but the tests skipped (see gpu_tests.log)" | tee -a "$OUT/summary.txt"
fi
# The same tests under compute-sanitizer (out-of-bounds and misaligned device accesses), where
# the toolkit has it; the kernels are waited for after each launch (FDEM_CUDA_SYNC=1).
if command -v compute-sanitizer >/dev/null; then
  FDEM_CUDA_SYNC=1 step sanitizer compute-sanitizer --tool memcheck --error-exitcode 3 \
    build-gpu/tests/test_cuda_backend --gtest_filter='*Elastic*:*Gravity*'
fi
step backend_tests build-gpu/tests/test_backends --gtest_filter='-*Cli*'
for np in 1 2; do
  step "ranks_$np" mpiexec --oversubscribe -n $np build-gpu/tests/test_ranks --gtest_filter='*Device*:*GpuAware*:*Fragments*'
done
step bench build-gpu/bench/bench_device --tets 10000,100000,700000,2000000 --steps 200
cp "$OUT/bench.log" "$OUT/bench_device.md"
