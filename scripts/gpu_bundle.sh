#!/usr/bin/env bash
# Here, on the Debian machine (called by `gpu_check.sh --prepare`): build the GPU check's
# programs with nvcc (sm_90 and PTX) into build-gpu/, and gather into deps/bundle/ what they need
# to run on the GPU machine without building there or using any of its packages:
#   bin/    fdem, test_cuda_backend, test_ranks, bench_device, bench_contact, bench_fields, and
#           for the dry run test_backends (stripped); bench_device_fmad, the same built with
#           FDEM_CUDA_FMAD=ON in build-gpu-fmad/; kernels.txt, the mangled names of bench_device's
#           kernels (the profile selects kernels by them, and stripping drops them from the program);
#   lib/    every shared library they load that is not the C library's own (glibc, libstdc++ and
#           libgcc_s come with nvcc's host compiler there);
#   mpi/    Debian's Open MPI (mpiexec, its libraries and plugins, PMIx), relocated there with
#           OPAL_PREFIX and PMIX_INSTALL_PREFIX, and the libraries its plugins load;
#   SOURCE_DIR  this checkout's path: the tests find tests/data through it (gpu_check.sh links it
#           to the checkout there when the paths differ).
# The device tool carries at most 64 MiB: the script prints the bundle's size. Debian 12's
# libraries need the C library 2.36 or newer there (gpu_check.sh checks; Ubuntu 24.04 has 2.39).
#
#   bash scripts/gpu_bundle.sh --check   runs three of the bundle's checks here as they run there
#   (the GPU tests, which skip here but for the one without a GPU, in one process that never
#   starts MPI; two ranks and the benchmark through the bundle's mpiexec) and fails if a process
#   loads a library from outside deps/bundle other than the C library's own.
set -euo pipefail
shopt -s nullglob
cd "$(dirname "${BASH_SOURCE[0]}")/.."
DEPS=$PWD/deps
B=$DEPS/bundle
system_lib() { [[ $1 =~ ^(linux-vdso|ld-linux|libc|libm|libdl|libpthread|librt|libutil|libresolv|libgcc_s|libstdc\+\+)[.-] ]]; }

if [[ "${1:-}" == "--check" ]]; then
  unpacked=0  # deps/ must stay small enough to carry (64 MiB): an unpacked bundle is removed again
  [[ -d $B/bin ]] || { [[ -f $DEPS/bundle.tar.xz ]] && tar -C "$DEPS" -xJf "$DEPS/bundle.tar.xz" && unpacked=1; }
  ((unpacked)) && trap 'rm -rf "$B"' EXIT
  [[ -d $B/bin ]] || { echo "gpu_bundle.sh: no deps/bundle. Fix: bash scripts/gpu_check.sh --prepare" >&2; exit 2; }
  mpi=$B/mpi/usr
  log=$(mktemp -d)
  # A clean environment, as on the GPU machine: only the bundle's paths.
  run() {
    env -i HOME="$HOME" PATH="$mpi/bin:/usr/bin:/bin" OPAL_PREFIX="$mpi" \
      PMIX_INSTALL_PREFIX="$mpi/lib/x86_64-linux-gnu/pmix2" \
      PMIX_MCA_mca_base_component_path="$mpi/lib/x86_64-linux-gnu/pmix2/lib/pmix" HWLOC_PLUGINS_PATH="$B/none" \
      OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_pml=ob1 OMPI_MCA_btl=self,vader \
      OMPI_MCA_btl_vader_single_copy_mechanism=none \
      OMPI_MCA_mpi_yield_when_idle=1 LD_DEBUG=libs LD_DEBUG_OUTPUT="$log/ld" \
      LD_LIBRARY_PATH="$B/lib:$mpi/lib/x86_64-linux-gnu:$mpi/lib/x86_64-linux-gnu/pmix2/lib" "$@"
  }
  run "$B/bin/test_cuda_backend" > "$log/one.txt" 2>&1 || { cat "$log/one.txt"; exit 1; }
  run "$mpi/bin/mpiexec" --oversubscribe -n 2 "$B/bin/test_ranks" --gtest_filter='*Device*' > "$log/two.txt" 2>&1 ||
    { cat "$log/two.txt"; exit 1; }
  run "$mpi/bin/mpiexec" -n 1 "$B/bin/bench_device" --backend debug --tets 2000 --steps 2 > "$log/bench.txt" 2>&1 ||
    { cat "$log/bench.txt"; exit 1; }
  # A library this machine has too (PMIx looks for its plugins where it was installed first) counts
  # when the bundle holds one of that name: on the GPU machine the bundle's is the one there is
  # (checked once with this machine's PMIx plugins moved away: all from the bundle, tests passed).
  outside=$(cat "$log"/ld.* | sed -n 's/.*calling init: //p' | sort -u | while read -r lib; do
    [[ $lib == "$B"/* ]] && continue
    system_lib "$(basename "$lib")" && continue
    [[ -n $(find "$B" -name "$(basename "$lib")" -print -quit) ]] || echo "$lib"
  done)
  grep -h "PASSED\|FAILED" "$log/one.txt" "$log/two.txt"
  echo "processes: $(ls "$log"/ld.* | wc -l); libraries loaded: $(cat "$log"/ld.* | sed -n 's/.*calling init: //p' | sort -u | wc -l)"
  rm -rf "$log"
  if [[ -n $outside ]]; then
    echo "gpu_bundle.sh: loaded from outside the bundle:" >&2
    echo "$outside" >&2
    exit 1
  fi
  echo "every library came from deps/bundle or the C library's own"
  exit 0
fi
command -v nvcc > /dev/null || [[ -x /usr/local/cuda/bin/nvcc ]] || {
  echo "gpu_bundle.sh: no nvcc here. Fix: install the CUDA toolkit, or let gpu_check.sh build on the GPU machine" >&2
  exit 2
}
configure() {  # configure DIR [CMAKE ARGS...]: one CUDA runtime (the shared one), sm_90
  local dir=$1
  shift
  cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON -DFDEM_ENABLE_GMSH=OFF -DFDEM_ENABLE_PETSC=OFF \
    -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" -DCMAKE_CUDA_RUNTIME_LIBRARY=Shared \
    "$@" > /dev/null
}
configure build-gpu
cmake --build build-gpu -j "$(nproc)" --target fdem test_cuda_backend test_ranks test_backends bench_device \
  bench_contact bench_fields > /dev/null
configure build-gpu-fmad -DFDEM_CUDA_FMAD=ON -DFDEM_BUILD_TESTS=OFF
cmake --build build-gpu-fmad -j "$(nproc)" --target bench_device > /dev/null
rm -rf "$B"
mkdir -p "$B/bin" "$B/lib" "$B/mpi"
bash scripts/gpu_check.sh --kernels build-gpu/bench/bench_device > "$B/bin/kernels.txt"
cp build-gpu-fmad/bench/bench_device "$B/bin/bench_device_fmad"
progs=(build-gpu/fdem build-gpu/tests/test_cuda_backend build-gpu/tests/test_ranks build-gpu/tests/test_backends
  build-gpu/bench/bench_device build-gpu/bench/bench_contact build-gpu/bench/bench_fields)
for p in "${progs[@]}"; do cp "$p" "$B/bin/"; done
for p in "$B"/bin/*; do [[ $p == *.txt ]] || strip --strip-unneeded "$p"; done

# Debian's Open MPI, unpacked (never into /).
tmp=$(mktemp -d)
(cd "$tmp" && apt-get download -q openmpi-bin libopenmpi3 openmpi-common libpmix2 > /dev/null)
for p in "$tmp"/*.deb; do dpkg -x "$p" "$B/mpi"; done
rm -rf "$tmp"
ln -sf orterun "$B/mpi/usr/bin/mpiexec"  # Debian's is mpiexec.openmpi, through its alternatives
M=$B/mpi/usr/lib/x86_64-linux-gnu
MPI_LIBS=$M:$M/pmix2/lib

# Every library the programs, mpiexec and the MPI plugins load, but the C library's own and those
# already in the bundle.
mapfile -t loaders < <(find "$B/bin" -type f ! -name '*.txt'; printf '%s\n' "$B"/mpi/usr/bin/orterun "$B"/mpi/usr/bin/orted \
  "$M"/openmpi/lib/openmpi3/*.so "$M"/pmix2/lib/pmix/*.so)
((${#loaders[@]} > 5)) || { echo "gpu_bundle.sh: Open MPI's plugins are missing from deps/bundle/mpi" >&2; exit 1; }
LD_LIBRARY_PATH=$MPI_LIBS ldd "${loaders[@]}" | awk '$2 == "=>" && $3 ~ /^\// {print $1, $3}' | sort -u |
  while read -r name path; do
    system_lib "$name" && continue
    [[ $path == "$B"/* ]] && continue
    cp -L "$path" "$B/lib/$name"
  done
missing=$(LD_LIBRARY_PATH=$B/lib:$MPI_LIBS ldd "${loaders[@]}" 2> /dev/null | grep -c "not found" || true)
echo "$PWD" > "$B/SOURCE_DIR"
echo "deps/bundle: $(du -sh "$B" | cut -f1) ($(find "$B" -type f | wc -l) files), built from $(git rev-parse --short HEAD); libraries not found: $missing"
