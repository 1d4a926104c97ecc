#!/usr/bin/env bash
# The device loop's passes run on the host (the debug backend) under AddressSanitizer and
# UndefinedBehaviorSanitizer: an index out of bounds that a GPU would not report (it reads or
# writes some other array there) stops the run here with the line. Builds fdem without CUDA,
# with gcc, -fsanitize=address,undefined, into ./build-asan, then runs the debug backend's
# tests (test_backends: one rank, against the CPU backend) and the multi-rank tests
# (test_ranks, at 1 and 2 ranks through mpiexec). Leaks are not reported (MPI's own are
# many); any other report fails the test that made it.
# Usage: scripts/sanitize.sh. Exit 1 when a test fails or a sanitizer reports.
# About 10 minutes to build and 5 to run on 2 cores (2026-12-02).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if (($# > 0)); then
  echo "usage: scripts/sanitize.sh (no arguments)" >&2
  exit 2
fi
bash "$root/scripts/setup.sh"

build="$root/build-asan"
jobs="$(nproc 2>/dev/null || echo 2)"
flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFDEM_ENABLE_CUDA=OFF -DFDEM_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
cmake --build "$build" -j "$jobs" --target fdem test_backends test_ranks

export ASAN_OPTIONS="detect_leaks=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
mpiexec=(mpiexec)
if [[ $(id -u) == 0 ]]; then mpiexec+=(--allow-run-as-root); fi
failed=0
run() {  # name, command...: the log under build-asan/, a line for each
  local name="$1" log="$build/sanitize_$1.log"
  shift
  if "$@" >"$log" 2>&1 && ! grep -qE "runtime error|ERROR: AddressSanitizer" "$log"; then
    echo "fdem sanitize: $name: passed, no sanitizer report"
  else
    echo "fdem sanitize: $name: FAILED (log $log)"
    grep -m 5 -E "runtime error|ERROR: AddressSanitizer|FAILED" "$log" || true
    failed=1
  fi
}
cd "$build"
run backends ./tests/test_backends
for n in 1 2; do
  run "ranks_$n" "${mpiexec[@]}" --oversubscribe -np "$n" ./tests/test_ranks
done
exit "$failed"
