#!/usr/bin/env bash
# The device loop's passes run on the host (the debug backend) under a sanitizer, so that what a
# GPU would not report stops the run here with its line. Builds fdem without CUDA, with gcc, then
# runs the debug backend's tests (test_backends: one rank, against the CPU backend) and the
# multi-rank tests (test_ranks, at 1 and 2 ranks through mpiexec).
#   (default)  AddressSanitizer and UndefinedBehaviorSanitizer, into ./build-asan: an index out of
#              bounds (on a GPU it reads or writes some other array there). Leaks are not
#              reported (MPI's own are many).
#   --thread   ThreadSanitizer, into ./build-tsan, with each launch of the debug backend on 4
#              threads of its own (FDEM_HOST_RACE_THREADS, core/forall.hpp): two iterations of one
#              launch that touch the same memory, one writing (on a GPU, a race), reported
#              whether or not the result changes. The CPU backend's OpenMP runs on one thread
#              (OMP_NUM_THREADS=1: libgomp is not instrumented, its threads would be reported).
# Any report fails the test that made it. Exit 1 when a test fails or a sanitizer reports.
# Usage: scripts/sanitize.sh [--thread]
# About 10 minutes to build and 5 to run on 2 cores (2026-12-02, default).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode=address
if (($# == 1)) && [[ $1 == --thread ]]; then
  mode=thread
elif (($# > 0)); then
  echo "usage: scripts/sanitize.sh [--thread]" >&2
  exit 2
fi
bash "$root/scripts/setup.sh"

jobs="$(nproc 2>/dev/null || echo 2)"
if [[ $mode == address ]]; then
  build="$root/build-asan"
  sanitizers=address,undefined
  flags="-fsanitize=$sanitizers -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
  reports="runtime error|ERROR: AddressSanitizer"
  export ASAN_OPTIONS="detect_leaks=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
  export UBSAN_OPTIONS="print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
else
  build="$root/build-tsan"
  sanitizers=thread
  flags="-fsanitize=thread -fno-omit-frame-pointer -DFDEM_HOST_RACE_THREADS=4"
  reports="WARNING: ThreadSanitizer"
  export TSAN_OPTIONS="second_deadlock_stack=1${TSAN_OPTIONS:+:$TSAN_OPTIONS}"
  export OMP_NUM_THREADS=1
fi
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFDEM_ENABLE_CUDA=OFF -DFDEM_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=$sanitizers" >/dev/null
cmake --build "$build" -j "$jobs" --target fdem test_backends test_ranks

mpiexec=(mpiexec)
if [[ $(id -u) == 0 ]]; then mpiexec+=(--allow-run-as-root); fi
failed=0
run() {  # name, command...: the log under the build folder, a line for each
  local name="$1" log="$build/sanitize_$1.log"
  shift
  if "$@" >"$log" 2>&1 && ! grep -qE "$reports" "$log"; then
    echo "fdem sanitize: $name: passed, no sanitizer report"
  else
    echo "fdem sanitize: $name: FAILED (log $log)"
    grep -m 5 -E "$reports|FAILED" "$log" || true
    failed=1
  fi
}
# --thread: of the multi-rank tests, those that run the debug backend (the CPU backend's OpenMP
# runs on one thread there, so the others check nothing more, and take long under the sanitizer).
ranks_filter='*'
[[ $mode == thread ]] && ranks_filter='*RanksDevice.*:*Fragments*:*ReachGuard*:*CopiesToTheHost*:*GpuAware*'
cd "$build"
run backends ./tests/test_backends
for n in 1 2; do
  run "ranks_$n" "${mpiexec[@]}" --oversubscribe -np "$n" ./tests/test_ranks --gtest_filter="$ranks_filter"
done
exit "$failed"
