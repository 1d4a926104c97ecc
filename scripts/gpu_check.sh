#!/usr/bin/env bash
# The GPU machine's checks in one call (the device tool: at most 10 minutes a call and 15 minutes
# of device time a session, the machine's start included): build the CUDA backend, check it
# against the CPU backend, time it. Everything it reports goes under $OUT (summary.txt first).
#
#   bash scripts/gpu_check.sh --prepare      here, on the Debian machine: fill the ignored deps/
#   bash scripts/gpu_check.sh [PHASE...]     there, with deps/ carried
#
# --prepare also builds the programs here (nvcc is here too) and packs them with every library
# they load and Debian's Open MPI into deps/bundle.tar.xz (scripts/gpu_bundle.sh; about 14 MB):
# there the checks then run those programs, so they need neither a build nor that machine's MPI,
# HDF5, yaml-cpp or GoogleTest, which its image may lack. Name the phase build to build there
# instead (that needs those packages there).
#
# PHASEs run in this order, most wanted first (default: build tests bench ranks sanitizer contact,
# with the bundle tests bench ranks sanitizer contact): build tests bench ranks sanitizer contact
# fmad. contact times the step with every tet a contact candidate (bench_device --contact full,
# 67 candidate pairs a tet: the narrow phase's cost per pair, a bound for the post-peak stage). fmad builds a second tree with FDEM_CUDA_FMAD=ON (nvcc fuses multiply-adds; no
# longer the CPU backend's bits) and times it as bench does: what the bit-for-bit agreement costs.
# The whole call has a budget of FDEM_GPU_BUDGET seconds (default 540, under the tool's 600 s a
# call): each step runs under its own limit (below) cut to what is left of the budget, and a step
# with less than 20 s left is not started, so the call always ends with its summary written and
# the phases left over can go in a second call (build-gpu/ is kept while the machine is warm).
# Measured on the 2-core dev VM without a GPU (2026-12-01; GPU tests skip): configure 3 s,
# build 53 s, backend tests 14 s, ranks 33 s + 27 s.
#
# The GPU machine (Ubuntu 24.04, CUDA 13, Open MPI 4.1.6, serial HDF5, yaml-cpp, GoogleTest,
# Eigen) has no gmsh, METIS or CLI11 and no network: --prepare downloads the Debian packages of
# METIS and CLI11 and unpacks them into deps/ (never into /), which the build finds through
# CMAKE_PREFIX_PATH. Without gmsh (FDEM_ENABLE_GMSH=OFF) the checks and the benchmark use
# structured meshes.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
DEPS=$PWD/deps

if [[ "${1:-}" == "--prepare" ]]; then
  set -e
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download libmetis5 libmetis-dev libcli11-dev)
  mkdir -p "$DEPS"
  for p in "$tmp"/*.deb; do dpkg -x "$p" "$DEPS"; done
  rm -rf "$tmp"
  bash scripts/gpu_bundle.sh
  tar -C "$DEPS" -cJf "$DEPS/bundle.tar.xz" bundle
  rm -rf "$DEPS/bundle"  # only the archive travels
  echo "deps/ is ready ($(du -sh --exclude=bundle "$DEPS" | cut -f1) to carry): carry it with the run (device tool: carry [\"deps\"])"
  exit 0
fi

phases=("$@")
if [[ ${#phases[@]} -eq 0 ]]; then
  phases=(build tests bench ranks sanitizer contact)
  [[ -f $DEPS/bundle.tar.xz ]] && phases=(tests bench ranks sanitizer contact)
fi
for p in "${phases[@]}"; do
  case $p in
    build | tests | sanitizer | ranks | bench | contact | fmad) ;;
    *)
      echo "gpu_check.sh: unknown phase '$p'. Fix: one or more of build tests bench ranks sanitizer contact fmad, or --prepare" >&2
      exit 2
      ;;
  esac
done
wanted() { [[ " ${phases[*]} " == *" $1 "* ]]; }
BUDGET=${FDEM_GPU_BUDGET:-540}
if ! [[ $BUDGET =~ ^[0-9]+$ ]]; then
  echo "gpu_check.sh: FDEM_GPU_BUDGET='$BUDGET' is not a whole number of seconds. Fix: e.g. FDEM_GPU_BUDGET=540" >&2
  exit 2
fi
BUDGET=$((10#$BUDGET))  # 0600 is 600 s, not octal

if [[ ! -d "$DEPS/usr/include" ]]; then
  echo "gpu_check.sh: deps/ is missing. Fix: run 'bash scripts/gpu_check.sh --prepare' on the Debian machine and carry deps/" >&2
  exit 2
fi
OUT=${OUT:-out/gpu_check}
mkdir -p "$OUT"
export LD_LIBRARY_PATH="$DEPS/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
# The programs: built here (phase build) in build-gpu/, or the bundle's, built on the Debian
# machine, with its libraries and Open MPI (relocated by OPAL_PREFIX and PMIX_INSTALL_PREFIX).
TESTS=build-gpu/tests BENCH=build-gpu/bench
if ! wanted build && [[ -f $DEPS/bundle.tar.xz ]]; then
  # Built on Debian 12: its libraries need the C library 2.36 or newer (Ubuntu 24.04 has 2.39).
  glibc=$(getconf GNU_LIBC_VERSION | awk '{print $2}')
  if [[ $(printf '%s\n2.36\n' "$glibc" | sort -V | head -1) != 2.36 ]]; then
    echo "gpu_check.sh: this machine's C library is $glibc, older than the bundle's 2.36. Fix: name the phase build (it builds here)" |
      tee -a "$OUT/summary.txt"
    exit 1
  fi
  if ! { rm -rf "$DEPS/bundle" && tar -C "$DEPS" -xJf "$DEPS/bundle.tar.xz"; }; then
    echo "gpu_check.sh: deps/bundle.tar.xz did not unpack. Fix: bash scripts/gpu_check.sh --prepare here again" |
      tee -a "$OUT/summary.txt"
    exit 1
  fi
  TESTS=$DEPS/bundle/bin BENCH=$DEPS/bundle/bin
  mpi=$DEPS/bundle/mpi/usr
  export PATH="$mpi/bin:$PATH" OPAL_PREFIX="$mpi" PMIX_INSTALL_PREFIX="$mpi/lib/x86_64-linux-gnu/pmix2" \
    PMIX_MCA_mca_base_component_path="$mpi/lib/x86_64-linux-gnu/pmix2/lib/pmix" HWLOC_PLUGINS_PATH="$DEPS/bundle/none"
  export LD_LIBRARY_PATH="$DEPS/bundle/lib:$mpi/lib/x86_64-linux-gnu:$mpi/lib/x86_64-linux-gnu/pmix2/lib:$LD_LIBRARY_PATH"
  # Shared memory between the ranks of one machine only: no UCX or libfabric plugins, whose
  # own plugins Open MPI's relocation does not move, and no single-copy by ptrace (containers).
  export OMPI_MCA_pml=ob1 OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
  # The tests find tests/data under the checkout they were built from.
  src=$(cat "$DEPS/bundle/SOURCE_DIR")
  if [[ $src != "$PWD" && ! -d $src/tests/data ]]; then mkdir -p "$(dirname "$src")" && ln -sfn "$PWD" "$src"; fi
  [[ -d $src/tests/data ]] || echo "gpu_check.sh: $src/tests/data is missing: the tests will not find their data" |
    tee -a "$OUT/summary.txt"
  echo "programs: deps/bundle ($(cat "$DEPS/bundle/SOURCE_DIR"))" >> "$OUT/machine.txt"
fi
{
  date -u
  nvidia-smi || true
  nvcc --version | tail -2
  echo "phases: ${phases[*]}"
} >> "$OUT/machine.txt" 2>&1

step() {  # step NAME SECONDS COMMAND...: run with a time limit, log to $OUT/NAME.log, record the exit code
  local name=$1 limit=$2
  shift 2
  local left=$((BUDGET - SECONDS - 20))  # timeout's 10 s to kill, 10 s for the summary and the copy back
  if ((left < 20)); then
    echo "$name: not started, $((BUDGET - SECONDS)) s of the ${BUDGET} s budget left (run its phase in another call)" |
      tee -a "$OUT/summary.txt"
    return 125
  fi
  ((limit > left)) && limit=$left
  local t0=$SECONDS
  timeout --kill-after=10 "$limit" "$@" > "$OUT/$name.log" 2>&1
  local rc=$?
  local why=""
  [[ $rc -eq 124 || $rc -eq 137 ]] && why=" (stopped at its limit of $limit s)"
  echo "$name: exit $rc in $((SECONDS - t0)) s$why" | tee -a "$OUT/summary.txt"
  return $rc
}

if wanted build; then
  step configure 120 cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON -DFDEM_ENABLE_GMSH=OFF \
    -DFDEM_ENABLE_PETSC=OFF -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" || exit 1
  step build 400 cmake --build build-gpu -j "$(nproc)" --target fdem test_cuda_backend test_backends test_ranks \
    bench_device || exit 1
fi
if wanted tests || wanted sanitizer || wanted ranks || wanted bench || wanted contact; then
  if [[ ! -x $TESTS/test_cuda_backend ]]; then
    echo "gpu_check.sh: $TESTS has no test programs. Fix: run the build phase first (in this call or a warm earlier one), or carry deps/ with its bundle (--prepare)" |
      tee -a "$OUT/summary.txt"
    exit 1
  fi
fi
# CPU = CUDA on one rank (tests/gpu) and the debug backend as everywhere.
if wanted tests; then
  step gpu_tests 180 "$TESTS/test_cuda_backend" --gtest_output="xml:$OUT/gpu_tests.xml"
  # A GPU that nvidia-smi lists but the tests skipped (a driver older than the CUDA runtime, for
  # one) is a failure here, not a green run.
  if nvidia-smi -L 2>/dev/null | grep -q GPU && grep -q 'SKIPPED' "$OUT/gpu_tests.log"; then
    echo "gpu_tests: nvidia-smi lists a GPU but the tests skipped (see gpu_tests.log)" | tee -a "$OUT/summary.txt"
  fi
  step backend_tests 120 "$TESTS/test_backends" --gtest_filter='-*Cli*'
fi
if wanted bench; then
  step bench 300 "$BENCH/bench_device" --tets 10000,100000,700000,2000000 --steps 200 --schedule auto,fused,colour
  [[ -f "$OUT/bench.log" ]] && cp "$OUT/bench.log" "$OUT/bench_device.md"
  # The fused pass's kernels for one and for two resident blocks per multiprocessor.
  step bench_blocks 120 "$BENCH/bench_device" --tets 100000,700000 --steps 200 --schedule auto,fused \
    --blocks-per-sm 1,2
  [[ -f "$OUT/bench_blocks.log" ]] && cp "$OUT/bench_blocks.log" "$OUT/bench_blocks.md"
fi
# The 1-vs-2-rank device checks with both device backends (the ranks share the GPU).
if wanted ranks; then
  for np in 1 2; do
    step "ranks_$np" 150 mpiexec --oversubscribe -n $np "$TESTS/test_ranks" \
      --gtest_filter='*Device*:*GpuAware*:*Fragments*'
  done
fi
# The elastic tests under compute-sanitizer (out-of-bounds and misaligned device accesses), where
# the toolkit has it; the kernels are waited for after each launch (FDEM_CUDA_SYNC=1).
if wanted sanitizer && command -v compute-sanitizer > /dev/null; then
  FDEM_CUDA_SYNC=1 step sanitizer 180 compute-sanitizer --tool memcheck --error-exitcode 3 \
    "$TESTS/test_cuda_backend" --gtest_filter='*Elastic*:*Gravity*'
fi
if wanted contact; then
  step contact 150 "$BENCH/bench_device" --tets 10000,100000 --steps 50 --contact full
  [[ -f "$OUT/contact.log" ]] && cp "$OUT/contact.log" "$OUT/bench_contact_full.md"
fi
if wanted fmad; then
  step fmad_configure 120 cmake -S . -B build-gpu-fmad -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON \
    -DFDEM_CUDA_FMAD=ON -DFDEM_BUILD_TESTS=OFF -DFDEM_ENABLE_GMSH=OFF -DFDEM_ENABLE_PETSC=OFF \
    -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" &&
    step fmad_build 400 cmake --build build-gpu-fmad -j "$(nproc)" --target bench_device &&
    step fmad_bench 300 build-gpu-fmad/bench/bench_device --tets 10000,100000,700000,2000000 --steps 200
fi
