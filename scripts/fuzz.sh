#!/usr/bin/env bash
# Fuzz the .msh reader and the scene parser (tests/fuzz) for a fixed time each: build the two
# libFuzzer targets with clang (ASan + UBSan) into ./build-fuzz and run them one after the other
# on a scratch copy of tests/fuzz/corpus (which is not modified).
# Usage: scripts/fuzz.sh [seconds per target, default 60]. Exit 1 on any finding (crash,
# sanitizer report, uncaught exception, timeout, out-of-memory, leak); the reproducer is kept
# under build-fuzz/findings/ and its path printed.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
if ! [[ "$seconds" =~ ^[0-9]+$ ]] || ((seconds < 1)); then
  echo "usage: scripts/fuzz.sh [seconds per target, a whole number >= 1; default 60]" >&2
  exit 2
fi

# clang, its libFuzzer and sanitizer runtimes (only recommended by clang, so not installed with
# --no-install-recommends), OpenMP for clang, and llvm-symbolizer for readable stack traces.
bash "$root/scripts/setup.sh" clang-14 libclang-rt-14-dev libomp-14-dev llvm-14

build="$root/build-fuzz"
jobs="$(nproc 2>/dev/null || echo 2)"
start=$SECONDS
cmake -S "$root" -B "$build" -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFDEM_BUILD_FUZZ=ON -DFDEM_BUILD_TESTS=OFF -DFDEM_BUILD_BENCH=OFF \
  -DFDEM_ENABLE_CUDA=OFF -DFDEM_ENABLE_PETSC=OFF >/dev/null
cmake --build "$build" -j "$jobs" --target fuzz_mesh fuzz_scene
echo "fdem fuzz: configured and built in $((SECONDS - start)) s"

export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
export UBSAN_OPTIONS="print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
findings="$build/findings"
mkdir -p "$findings"
scratch="$(mktemp -d "${TMPDIR:-/tmp}/fdem-fuzz.XXXXXX")"
trap 'rm -rf "$scratch"' EXIT
failed=0
for target in mesh scene; do
  corpus="$scratch/$target"
  mkdir -p "$corpus"
  cp -R "$root/tests/fuzz/corpus/$target/." "$corpus/"
  log="$build/fuzz_$target.log"
  echo "fdem fuzz: fuzz_$target for $seconds s (log $log)"
  rc=0
  (cd "$scratch" && "$build/tests/fuzz/fuzz_$target" -max_total_time="$seconds" -rss_limit_mb=2048 -timeout=10 \
    -dict="$root/tests/fuzz/$target.dict" -artifact_prefix="$findings/fuzz_$target-" -print_final_stats=1 \
    "$corpus") >"$log" 2>&1 || rc=$?
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log")"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log")"
  cov="$(grep -o 'cov: [0-9]*' "$log" | tail -n 1 || true)"
  if ((rc == 0)); then
    echo "fdem fuzz: fuzz_$target: no findings; ${runs:-?} inputs, ${rate:-?} per second, ${cov:-cov: ?} edges"
    continue
  fi
  failed=1
  echo "fdem fuzz: fuzz_$target FAILED (exit $rc); the end of its log:" >&2
  grep -v '^"' "$log" | tail -n 60 >&2
  reproducer="$(sed -n 's/.*Test unit written to //p' "$log" | tail -n 1)"
  if [ -n "$reproducer" ]; then
    echo "fdem fuzz: reproducer: $reproducer" >&2
    echo "fdem fuzz: replay it with: $build/tests/fuzz/fuzz_$target $reproducer" >&2
  else
    echo "fdem fuzz: no reproducer was written; see $log" >&2
  fi
done
exit "$failed"
