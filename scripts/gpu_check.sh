#!/usr/bin/env bash
# shellcheck disable=SC2317  # (the functions the sourced phases call)
# The GPU machine's checks in one call of the device tool (at most 10 minutes a call, 15 minutes
# of device time a session, the machine's start included). Nothing is compiled there: the
# programs come in deps/, built here.
#
#   bash scripts/gpu_check.sh --prepare            here: fill the ignored deps/ (carry it there)
#   bash scripts/gpu_check.sh                      there, the first call (timeout_s 590)
#   bash scripts/gpu_check.sh second               there, the second call, if time is left
#   bash scripts/gpu_check.sh PHASE...             there, the phases named, in the order below
#   bash scripts/gpu_check.sh --dry-run [PHASE...] here: every phase on the debug backend, small
#
# The first call's phases, most wanted first:
#   facts     nvidia-smi's clocks and power, and which of ncu, compute-sanitizer and xz exist;
#   tests     the GPU tests (CUDA = CPU) with XML; a failing test is run again at once under
#             compute-sanitizer's memcheck, waiting for each kernel (FDEM_CUDA_SYNC=1);
#   bench     bench_device at 10k, 100k, 700k and 2M tets, then 700k with every schedule and
#             one and two blocks per multiprocessor;
#   profile   ncu on the fused pass, the contact pairs, the platens and the powers (time, warps
#             active, DRAM throughput, local-memory traffic), if ncu is there;
#   paper     the paper-size UCS model on the GPU for N1 and N2 steps (the step time and the
#             projected wall time to the post-peak stage) and N1 on the CPU (CPU = GPU);
#   ucs       the default scene on the GPU against the CPU: peak within 1 %, broken CE6 within 5 %;
#   memcheck  compute-sanitizer's memcheck on one fracturing test;
#   ranks     the 1-rank and 2-rank CUDA tests.
# The second call's phases (`second`):
#   contact   bench_contact on the GPU, adaptive against full contact activation;
#   fmad      bench_device built with nvcc's fused multiply-adds: what the CPU's bits cost;
#   fields    bench_fields at 2 and 8 ranks on the machine's cores: one shared fields.h5 against
#             a file per rank.
# On request: build (build there, when the bundle cannot run; it needs that machine's packages).
#
# What comes back, under $OUT, at most 6 files (the tool brings back 8): summary.txt (a line for
# each step, then the verdict), machine.txt, logs.tar.gz (every log, the tests' XML; packed
# again after each step, so a call cut short still brings back the logs so far), and the tables
# bench_device.md, bench_blocks.md, profile.csv (first call) or bench_contact.md, bench_fmad.md,
# bench_fields.md.
#
# Each step has its own time limit, cut to what is left of FDEM_GPU_BUDGET seconds (default
# 520); a step with under 20 s left is not started. A step ends passed, FAILED (its exit code,
# or its limit), not started (no time left: run its phase in another call), or skipped (a tool
# missing, or there but refused by this machine, such as ncu without counters). The verdict is
# PASSED (exit 0), FAILED (exit 1: a step or a comparison failed), or INCOMPLETE (exit 3:
# nothing failed, some steps did not start). Exit 2: bad arguments or no deps/. A summary with no
# verdict line is a call cut short by the tool.
#
# The dry run runs the same steps here on the debug backend with small sizes and the programs
# of FDEM_BUILD_DIR (default build/; FDEM_GPU_PROGRAMS=bundle takes deps/bundle's), so a broken
# script fails here, not there. It unpacks with Python's lzma, as a machine without xz would.
# Measured on the 2-core development machine without a GPU: see docs/benchmarks.md.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
DEPS=$PWD/deps
FIRST=(facts tests bench profile paper ucs memcheck ranks)
SECOND=(contact fmad fields)
CONTACT_SIZES=0.003,0.002,0.0015  # m: bench_contact's cylinders there (2,474 to 17,809 tets)
source scripts/gpu_check_steps.sh
if [[ "${1:-}" == "--kernels" ]]; then  # (gpu_bundle.sh) the mangled names of BIN's kernels
  kernel_names "$2"
  exit
fi

if [[ "${1:-}" == "--prepare" ]]; then
  set -e
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download libmetis5 libmetis-dev libcli11-dev)
  mkdir -p "$DEPS"
  for p in "$tmp"/*.deb; do dpkg -x "$p" "$DEPS"; done
  rm -rf "$tmp"
  bash scripts/gpu_bundle.sh
  # The default UCS scene's model, partitioned for one rank, the paper-size cylinder's mesh (10 MB
  # packed; its rank file would not fit) and bench_contact's cylinders: the programs there are
  # built without gmsh.
  rm -rf "$DEPS/ucs_small_1" "$DEPS/contact"
  if [[ -f build/CMakeCache.txt ]] && cmake --build build --target fdem bench_contact > /dev/null; then
    build/fdem partition scenes/ucs_small.yaml -n 1 -o "$DEPS/ucs_small_1" > /dev/null
    build/fdem check scenes/ucs_paper.yaml --write-mesh "$DEPS/ucs_paper.msh" > /dev/null
    xz -T0 -6 -f "$DEPS/ucs_paper.msh"
    mkdir -p "$DEPS/contact"  # the cylinders of the phase contact
    build/bench/bench_contact --sizes "$CONTACT_SIZES" --write-meshes "$DEPS/contact"
  else
    echo "gpu_check.sh: no build/ here (bash scripts/build.sh makes it): the phases ucs, paper and contact will not run there" >&2
  fi
  tar -C "$DEPS" -cJf "$DEPS/bundle.tar.xz" bundle
  bash scripts/gpu_bundle.sh --check
  rm -rf "$DEPS/bundle"  # only the archive travels
  echo "deps/ is ready ($(du -sh --exclude=bundle "$DEPS" | cut -f1) to carry): carry it with the run (device tool: carry [\"deps\"])"
  exit 0
fi

DRY=0
if [[ "${1:-}" == "--dry-run" ]]; then
  DRY=1
  shift
fi
phases=("$@")
if [[ ${#phases[@]} -eq 0 ]]; then
  phases=("${FIRST[@]}")
  ((DRY)) && phases=("${FIRST[@]}" "${SECOND[@]}")
elif [[ ${phases[*]} == second ]]; then
  phases=("${SECOND[@]}")
fi
for p in "${phases[@]}"; do
  if [[ " ${FIRST[*]} ${SECOND[*]} build " != *" $p "* ]]; then
    echo "gpu_check.sh: unknown phase '$p'. Fix: one or more of ${FIRST[*]} ${SECOND[*]} build; or second; or --prepare, --dry-run" >&2
    exit 2
  fi
done
wanted() { [[ " ${phases[*]} " == *" $1 "* ]]; }
BUDGET=${FDEM_GPU_BUDGET:-520}
if ! [[ $BUDGET =~ ^[0-9]+$ ]]; then
  echo "gpu_check.sh: FDEM_GPU_BUDGET='$BUDGET' is not a whole number of seconds. Fix: e.g. FDEM_GPU_BUDGET=520" >&2
  exit 2
fi
BUDGET=$((10#$BUDGET))  # 0600 is 600 s, not octal

# What the GPU call runs, and the dry run's small stand-ins on the debug backend.
if ((DRY)); then
  BACKEND=debug BENCH_TETS=2000,4000 BENCH_STEPS=4 BLOCK_TETS=4000 PROFILE_TETS=2000 PAPER_STEPS=20,60
  UCS_STEPS=300 CONTACT_SIZES=0.012 CONTACT_ARGS=(--max-steps 200) FMAD_TETS=2000 FIELDS_RANKS=2 FIELDS_TETS=2000
  GPU_TESTS=test_backends TESTS_FILTER='Schedule/DebugSchedule.ElasticBox*:DebugBackend.GravityHydrostatic*'
  MEMCHECK_FILTER='Schedule/DebugSchedule.FracturingBox*/0' RANKS_FILTER='Backend/RanksDevice.*/debug'
else
  BACKEND=cuda BENCH_TETS=10000,100000,700000,2000000 BENCH_STEPS=200 BLOCK_TETS=700000 PROFILE_TETS=700000
  PAPER_STEPS=${FDEM_PAPER_STEPS:-400,10400} UCS_STEPS=0 CONTACT_ARGS=()
  FMAD_TETS=$BENCH_TETS FIELDS_RANKS="2 8" FIELDS_TETS=40000
  GPU_TESTS=test_cuda_backend TESTS_FILTER='*'
  MEMCHECK_FILTER='Schedule/CudaSchedule.FracturingBox*/0' RANKS_FILTER='Backend/RanksDevice.*/cuda*:Ranks.Fragments*'
fi
IFS=, read -r n1 n2 <<< "$PAPER_STEPS"
if ! [[ $n1 =~ ^[1-9][0-9]*$ && $n2 =~ ^[1-9][0-9]*$ ]] || ((n2 <= n1)); then
  echo "gpu_check.sh: FDEM_PAPER_STEPS='$PAPER_STEPS' is not N1,N2 with 0 < N1 < N2. Fix: e.g. FDEM_PAPER_STEPS=400,10400" >&2
  exit 2
fi
if ((!DRY)) && [[ ! -d "$DEPS/usr/include" ]]; then
  echo "gpu_check.sh: deps/ is missing. Fix: run 'bash scripts/gpu_check.sh --prepare' on the Debian machine and carry deps/" >&2
  exit 2
fi

OUT=${OUT:-out/gpu_check}
mkdir -p "$OUT" || exit 2
LOGS=${FDEM_GPU_LOGS:-$(mktemp -d /tmp/fdem_gpu_check.XXXXXX)} || exit 2
WORK=$(mktemp -d /tmp/fdem_gpu_work.XXXXXX) || exit 2  # run outputs (fields: MB), not packed
mkdir -p "$LOGS" || exit 2
SUMMARY=$OUT/summary.txt
: > "$SUMMARY" && : > "$OUT/machine.txt" || exit 2
say() { echo "$*" | tee -a "$SUMMARY"; }
{
  ((DRY)) && echo "dry run: the debug backend, small sizes, programs of ${FDEM_GPU_PROGRAMS:-build}"
  echo "phases: ${phases[*]}; budget ${BUDGET} s; logs in $LOGS (packed into logs.tar.gz)"
} >> "$SUMMARY"
FAILED=() NOT_STARTED=() SKIPPED=()
pack_logs() {  # written beside in $OUT, then renamed: a call cut short leaves the last whole archive
  if ! { tar -C "$LOGS" -czf "$OUT/.logs.tar.gz.part" . && mv -f "$OUT/.logs.tar.gz.part" "$OUT/logs.tar.gz"; }; then
    echo "logs: packing failed (logs.tar.gz is older than this step)" >> "$SUMMARY"
  fi
}
# step NAME SECONDS COMMAND...: run under a time limit, log to $LOGS/NAME.log, say how it ended.
# STEP_COUNTS=0 before it: its failure is not the verdict's (a rerun for its log).
step() {
  local name=$1 limit=$2
  shift 2
  local left=$((BUDGET - SECONDS - 20))  # timeout's 10 s to kill, 10 s for the summary and the copy back
  if ((left < 20)); then
    say "$name: not started, $((BUDGET - SECONDS)) s of the ${BUDGET} s budget left (run its phase in another call)"
    NOT_STARTED+=("$name")
    return 125
  fi
  ((limit > left)) && limit=$left
  local t0=$SECONDS
  timeout --kill-after=10 "$limit" "$@" > "$LOGS/$name.log" 2>&1
  local rc=$?
  if ((rc == 0)); then
    say "$name: passed in $((SECONDS - t0)) s"
  elif ((rc == 124 || rc == 137)); then
    say "$name: FAILED, stopped at its limit of $limit s"
  else
    say "$name: FAILED, exit $rc in $((SECONDS - t0)) s (see $name.log)"
  fi
  ((rc == 0 || ${STEP_COUNTS:-1} == 0)) || FAILED+=("$name")
  pack_logs
  return "$rc"
}
skip() {  # skip NAME WHY
  say "$1: skipped, $2"
  SKIPPED+=("$1")
}
# A failed step that is no fault of fdem's: skipped, not failed.
not_failed() {  # not_failed NAME WHY
  local kept=() f
  for f in "${FAILED[@]}"; do [[ $f == "$1" ]] || kept+=("$f"); done
  FAILED=("${kept[@]}")
  skip "$1" "$2"
}
# A failed step whose log (or its .csv) shows this machine refusing the tool.
refused() {  # refused NAME REGEX WHY
  [[ " ${FAILED[*]} " == *" $1 "* ]] || return 1
  grep -qsE "$2" "$LOGS/$1.log" "$LOGS/$1.csv" || return 1
  not_failed "$1" "$3 (see $1.log)"
}
has_gpu() { [[ $(nvidia-smi -L 2> /dev/null) == *GPU* ]]; }
# Where nvidia-smi lists a GPU, a test that skipped is a failure; EXPECTED names those that may.
skips() {  # skips NAME [EXPECTED regex]
  has_gpu || return 0
  local names
  names=$(grep -o '\[  SKIPPED \] [^ ]*' "$LOGS/$1.log" 2> /dev/null | awk '$4 !~ /^[0-9]+$/ {print $4}' | sort -u |
    grep -v -E "${2:-^$}" | tr '\n' ' ')
  if [[ -n $names ]]; then
    say "$1: nvidia-smi lists a GPU but these tests skipped: $names(see $1.log)"
    FAILED+=("$1")
  fi
}
# The machine's tools (nvidia-smi, ncu, compute-sanitizer, xz, python3) run with its own library
# path, not the bundle's: TOOL_ENV before a tool, PROGRAM_ENV (set with the programs) after it.
OWN_LD=${LD_LIBRARY_PATH:-}
TOOL_ENV=(env "LD_LIBRARY_PATH=$OWN_LD") PROGRAM_ENV=()
# xz's archives unpacked by xz, or by Python's lzma where xz is missing (and in the dry run).
unxz() {  # unxz FILE: to standard output
  if ((!DRY)) && command -v xz > /dev/null; then
    "${TOOL_ENV[@]}" xz -dc "$1"
  else
    "${TOOL_ENV[@]}" python3 -c 'import lzma, shutil, sys; shutil.copyfileobj(lzma.open(sys.argv[1]), sys.stdout.buffer)' "$1"
  fi
}
# deps/ must stay small enough to carry (64 MiB), and each call unpacks the bundle anew: the
# unpacked bundle goes when the call ends, however it ends.
trap 'rm -rf "$DEPS/bundle"' EXIT
if ! programs; then
  say "verdict: FAILED: the programs could not be set up (the line above says why)"
  pack_logs
  exit 2
fi
for p in build "${FIRST[@]}" "${SECOND[@]}"; do
  wanted "$p" && "phase_$p"
done
rm -rf "$WORK"
verdict
rc=$?
[[ $DRY == 1 && -z ${FDEM_GPU_LOGS:-} ]] && rm -rf "$LOGS"  # (packed in logs.tar.gz)
exit $rc
