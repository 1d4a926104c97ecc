#!/usr/bin/env bash
# The GPU machine's checks in one call (the device tool: at most 10 minutes a call and 15 minutes
# of device time a session, the machine's start included): build the CUDA backend, check it
# against the CPU backend, time it. What it reports goes under $OUT, in at most 7 files (the device
# tool brings back 8): summary.txt (each step's exit code and seconds, then the verdict),
# machine.txt, logs.tar.gz (every step's log, the GPU tests' XML; packed again after each step, so
# a call cut short still brings back the logs so far) and the benchmark tables bench_device.md,
# bench_blocks.md, bench_contact_full.md and (phase fmad) bench_fmad.md. The logs themselves are
# written outside $OUT (FDEM_GPU_LOGS, default a new folder under /tmp; its name is in
# summary.txt). Exit code 0 only if every step started, ended with 0, skipped no GPU test where
# nvidia-smi lists a GPU, and the ucs and paper comparisons held; else 1 (2: bad arguments or no deps/).
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
# PHASEs run in this order, most wanted first (default: build tests ucs ranks bench paper sanitizer
# contact, with the bundle all but build): build tests ucs ranks bench paper sanitizer contact fmad. ucs
# runs the default scene (fdem run, outputs included) on the CPU and on the GPU from a rank file
# --prepare writes (deps/ucs_small_1) and compares peak and broken CE6. contact times the step
# with every tet a contact candidate (bench_device --contact full, 67 candidate pairs a tet: the
# narrow phase's cost per pair, a bound for the post-peak stage).
# fmad builds a second tree with FDEM_CUDA_FMAD=ON (nvcc fuses multiply-adds; no longer the CPU
# backend's bits) and times it as bench does (bench_fmad.md): what the bit-for-bit agreement costs.
# paper runs the paper-size UCS model (scenes/ucs_paper.yaml's mesh, which --prepare writes to
# deps/ucs_paper.msh.xz, at m = 1) for 400 and 40,400 steps on the GPU and 400 on the CPU: its
# step time, a lower bound of the wall time to the post-peak stage and CPU = GPU in the monitors
# (about 2 minutes; below): the issue's goal, so before the sanitizer. fmad is on request only.
# The whole call has a budget of FDEM_GPU_BUDGET seconds (default 540, under the tool's 600 s a
# call): each step runs under its own limit (below) cut to what is left of the budget, and a step
# with less than 20 s left is not started, so the call always ends with its summary written and
# the phases left over can go in a second call (build-gpu/ is kept while the machine is warm).
# Measured on the 2-core dev VM without a GPU (2026-12-02; GPU tests skip): the bundle's tests
# ucs ranks in 3 min 27 s (ucs on the CPU 87 s, ranks 66 s + 49 s); 2026-12-01: configure 3 s,
# build 53 s.
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
  # The default UCS scene's model, partitioned for one rank: the phase ucs runs it there, where
  # the programs are built without gmsh (the cylinder's mesh generator). build/fdem has gmsh.
  rm -rf "$DEPS/ucs_small_1"
  if [[ -f build/CMakeCache.txt ]] && cmake --build build --target fdem > /dev/null; then
    build/fdem partition scenes/ucs_small.yaml -n 1 -o "$DEPS/ucs_small_1" > /dev/null
    # The paper-size cylinder's mesh for the phase paper (10 MB packed; its rank file would not fit).
    build/fdem check scenes/ucs_paper.yaml --write-mesh "$DEPS/ucs_paper.msh" > /dev/null
    xz -T0 -6 -f "$DEPS/ucs_paper.msh"
  else
    echo "gpu_check.sh: no build/ here (bash scripts/build.sh makes it): the phases ucs and paper will not run there" >&2
  fi
  tar -C "$DEPS" -cJf "$DEPS/bundle.tar.xz" bundle
  rm -rf "$DEPS/bundle"  # only the archive travels
  echo "deps/ is ready ($(du -sh --exclude=bundle "$DEPS" | cut -f1) to carry): carry it with the run (device tool: carry [\"deps\"])"
  exit 0
fi

phases=("$@")
if [[ ${#phases[@]} -eq 0 ]]; then
  phases=(build tests ucs ranks bench paper sanitizer contact)
  [[ -f $DEPS/bundle.tar.xz ]] && phases=(tests ucs ranks bench paper sanitizer contact)
fi
for p in "${phases[@]}"; do
  case $p in
    build | tests | ucs | ranks | bench | sanitizer | contact | fmad | paper) ;;
    *)
      echo "gpu_check.sh: unknown phase '$p'. Fix: one or more of build tests ucs ranks bench paper sanitizer contact fmad, or --prepare" >&2
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
IFS=, read -r n1 n2 <<< "${FDEM_PAPER_STEPS:-400,40400}"
if ! [[ $n1 =~ ^[1-9][0-9]*$ && $n2 =~ ^[1-9][0-9]*$ ]] || ((n2 <= n1)); then
  echo "gpu_check.sh: FDEM_PAPER_STEPS='${FDEM_PAPER_STEPS:-}' is not N1,N2 with 0 < N1 < N2. Fix: e.g. FDEM_PAPER_STEPS=400,40400" >&2
  exit 2
fi
pb=${FDEM_PAPER_BACKEND:-cuda}
if [[ $pb != cuda && $pb != debug ]]; then
  echo "gpu_check.sh: FDEM_PAPER_BACKEND='$pb' is not cuda or debug (the CPU backend is what it is compared with). Fix: unset it, or debug without a GPU" >&2
  exit 2
fi

if [[ ! -d "$DEPS/usr/include" ]]; then
  echo "gpu_check.sh: deps/ is missing. Fix: run 'bash scripts/gpu_check.sh --prepare' on the Debian machine and carry deps/" >&2
  exit 2
fi
OUT=${OUT:-out/gpu_check}
mkdir -p "$OUT"
LOGS=${FDEM_GPU_LOGS:-$(mktemp -d /tmp/fdem_gpu_check.XXXXXX)} || exit 1
mkdir -p "$LOGS" || exit 1
echo "logs: $LOGS (packed into $OUT/logs.tar.gz)" >> "$OUT/summary.txt"
failed=0  # the verdict (the exit code): a step that failed or did not start, a skip, a comparison
pack_logs() {  # written beside in $OUT, then renamed: a call cut short leaves the last whole archive
  if ! { tar -C "$LOGS" -czf "$OUT/.logs.tar.gz.part" . && mv -f "$OUT/.logs.tar.gz.part" "$OUT/logs.tar.gz"; }; then
    echo "logs: packing failed (logs.tar.gz is older than this step)" >> "$OUT/summary.txt"
  fi
}
# Where nvidia-smi lists a GPU, a test that skipped in a step's log is a failure; expected skips
# (the halo through device buffers without a CUDA-aware MPI) are named in EXPECTED_SKIPS.
skips() {  # skips NAME [EXPECTED_SKIPS regex]
  nvidia-smi -L 2>/dev/null | grep GPU > /dev/null || return 0
  local names
  names=$(grep -o '\[  SKIPPED \] [^ ]*' "$LOGS/$1.log" 2>/dev/null | awk '$4 !~ /^[0-9]+$/ {print $4}' | sort -u |
    grep -v -E "${2:-^$}" | tr '\n' ' ')
  if [[ -n $names ]]; then
    echo "$1: nvidia-smi lists a GPU but these tests skipped: $names(see $1.log)" | tee -a "$OUT/summary.txt"
    failed=1
  fi
}
OWN_PATH=$PATH OWN_LD=${LD_LIBRARY_PATH:-}  # the machine's own, for the phase fmad
export LD_LIBRARY_PATH="$DEPS/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
export GTEST_COLOR=no  # plain logs (through mpiexec GoogleTest would colour them)
# The programs: built here (phase build) in build-gpu/, or the bundle's, built on the Debian
# machine, with its libraries and Open MPI (relocated by OPAL_PREFIX and PMIX_INSTALL_PREFIX).
TESTS=build-gpu/tests BENCH=build-gpu/bench FDEM=build-gpu/fdem
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
  TESTS=$DEPS/bundle/bin BENCH=$DEPS/bundle/bin FDEM=$DEPS/bundle/bin/fdem
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
if ! nvidia-smi -L 2>/dev/null | grep GPU > /dev/null; then
  echo "gpu: nvidia-smi lists no GPU, so the GPU tests skip: not a pass (the verdict says FAILED)" |
    tee -a "$OUT/summary.txt"
  failed=1
fi

step() {  # step NAME SECONDS COMMAND...: run with a time limit, log to $LOGS/NAME.log, record the exit code
  local name=$1 limit=$2
  shift 2
  local left=$((BUDGET - SECONDS - 20))  # timeout's 10 s to kill, 10 s for the summary and the copy back
  if ((left < 20)); then
    echo "$name: not started, $((BUDGET - SECONDS)) s of the ${BUDGET} s budget left (run its phase in another call)" |
      tee -a "$OUT/summary.txt"
    failed=1
    return 125
  fi
  ((limit > left)) && limit=$left
  local t0=$SECONDS
  timeout --kill-after=10 "$limit" "$@" > "$LOGS/$name.log" 2>&1
  local rc=$?
  local why=""
  [[ $rc -eq 124 || $rc -eq 137 ]] && why=" (stopped at its limit of $limit s)"
  echo "$name: exit $rc in $((SECONDS - t0)) s$why" | tee -a "$OUT/summary.txt"
  ((rc == 0)) || failed=1
  pack_logs
  return $rc
}

if wanted build; then
  step configure 120 cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON -DFDEM_ENABLE_GMSH=OFF \
    -DFDEM_ENABLE_PETSC=OFF -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" || exit 1
  step build 400 cmake --build build-gpu -j "$(nproc)" --target fdem test_cuda_backend test_ranks bench_device ||
    exit 1
fi
if wanted tests || wanted ucs || wanted sanitizer || wanted ranks || wanted bench || wanted contact || wanted paper; then
  if [[ ! -x $TESTS/test_cuda_backend ]]; then
    echo "gpu_check.sh: $TESTS has no test programs. Fix: run the build phase first (in this call or a warm earlier one), or carry deps/ with its bundle (--prepare)" |
      tee -a "$OUT/summary.txt"
    exit 1
  fi
fi
# CPU = CUDA on one rank (tests/gpu). (The debug backend's tests run on the CPU alone: CI's.)
if wanted tests; then
  step gpu_tests 180 "$TESTS/test_cuda_backend" --gtest_output="xml:$LOGS/gpu_tests.xml"
  # A GPU that nvidia-smi lists but the tests skipped (a driver older than the CUDA runtime, for
  # one) is a failure here, not a green run.
  skips gpu_tests
fi
# The default scene end to end, fdem run with its outputs, on the CPU (all cores: --bind-to none,
# or Open MPI binds the one rank to one core) and on the GPU from the same rank file
# (deps/ucs_small_1, --prepare): the issue's fracturing criteria, peak within 1 % and broken CE6
# within 5 %, and each run's wall time.
ucs_value() {  # ucs_value SUMMARY_CSV COLUMN: the column of the summary's one row
  awk -F, -v col="$2" 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == col) c = i } NR == 2 && c { print $c }' "$1"
}
if wanted ucs; then
  if [[ ! -f $DEPS/ucs_small_1/rank_0.fdp ]]; then
    echo "ucs: not run, deps/ucs_small_1 is missing (bash scripts/gpu_check.sh --prepare here, with build/)" |
      tee -a "$OUT/summary.txt"
    failed=1
  else
    runs=$(mktemp -d /tmp/fdem_gpu_ucs.XXXXXX) || exit 1  # the fields (MB) stay out of the logs' archive
    for b in cpu cuda; do
      step "ucs_$b" 150 mpiexec --bind-to none -n 1 "$FDEM" run scenes/ucs_small.yaml --partitioned "$DEPS/ucs_small_1" \
        --backend $b -o "$runs/$b" -q
      mkdir -p "$LOGS/ucs_$b" && cp "$runs/$b"/*.csv "$LOGS/ucs_$b/" 2>/dev/null
    done
    pack_logs
    a=$LOGS/ucs_cpu/summary.csv g=$LOGS/ucs_cuda/summary.csv
    if [[ -f $a && -f $g ]]; then
      line=$(awk -v pa="$(ucs_value "$a" peak_stress_Pa)" -v pg="$(ucs_value "$g" peak_stress_Pa)" \
        -v ba="$(ucs_value "$a" broken_ce6)" -v bg="$(ucs_value "$g" broken_ce6)" \
        -v wa="$(ucs_value "$a" wall_s)" -v wg="$(ucs_value "$g" wall_s)" -v n="$(ucs_value "$g" steps)" 'BEGIN {
          dp = (pg - pa) / pa; db = ba > 0 ? (bg - ba) / ba : (bg == ba ? 0 : 1)
          ok = (dp <= 0.01 && dp >= -0.01 && db <= 0.05 && db >= -0.05) ? "within" : "OUTSIDE"
          printf "ucs: peak cpu %.6g Pa, cuda %.6g Pa (%+.3f %%); broken CE6 cpu %d, cuda %d (%+.2f %%): %s the criteria; wall cpu %.1f s, cuda %.1f s (%d steps)\n", pa, pg, 100 * dp, ba, bg, 100 * db, ok, wa, wg, n
        }')
      echo "$line" | tee -a "$OUT/summary.txt"
      [[ $line == *" within the criteria"* ]] || failed=1
    else
      echo "ucs: no comparison, a run wrote no summary.csv (see its log)" | tee -a "$OUT/summary.txt"
      failed=1
    fi
  fi
fi
# The 1-vs-2-rank device checks with both device backends (the ranks share the GPU). The
# bundle's Open MPI is not CUDA-aware, so the device-buffer halo (cuda+mpi) skips there.
if wanted ranks; then
  for np in 1 2; do
    step "ranks_$np" 150 mpiexec --oversubscribe -n $np "$TESTS/test_ranks" \
      --gtest_filter='*Device*:*GpuAware*:*Fragments*'
    skips "ranks_$np" 'cuda_mpi'
  done
fi
# bench_device starts MPI: through mpiexec, not as a singleton of the relocated Open MPI.
bench() {  # bench NAME SECONDS TABLE ARGS...: a step whose log is also a table under $OUT
  local name=$1 limit=$2 table=$3
  shift 3
  step "$name" "$limit" mpiexec --bind-to none -n 1 "$BENCH/bench_device" "$@"
  [[ -f "$LOGS/$name.log" ]] && cp "$LOGS/$name.log" "$OUT/$table"
}
if wanted bench; then
  bench bench 300 bench_device.md --tets 10000,100000,700000,2000000 --steps 200 --schedule auto,fused,colour
  # The fused pass's kernels for one and for two resident blocks per multiprocessor.
  bench bench_blocks 120 bench_blocks.md --tets 100000,700000 --steps 200 --schedule auto,fused --blocks-per-sm 1,2
fi
# The paper's UCS model itself (scenes/ucs_paper.yaml's mesh, from deps/ucs_paper.msh.xz, at
# m = 1 as the issue's goal): fdem run on the GPU for N1 and for N2 steps; the difference of the
# two runs' loop times over N2 - N1 steps is the step time of the real run (contact, platens, a
# monitor row every 200 steps as the scene has, and the output of two field frames each), without
# its start. That step time times 0.0192 s of loading (bench_device's figure, docs/validation.md)
# over the run's own time step is a lower bound of the wall time to the post-peak stage: these
# steps are all before the peak, where fracture adds contact pairs. The CPU backend runs N1 steps too
# and its last monitor row must equal the GPU's to the 10 digits monitors.csv prints (8 digits
# here: a last digit may round the other way). FDEM_PAPER_STEPS=N1,N2 (default 400,40400) and
# FDEM_PAPER_BACKEND (default cuda; debug to check this phase on a machine without a GPU).
if wanted paper; then
  if [[ ! -f $DEPS/ucs_paper.msh.xz ]]; then
    echo "paper: not run, deps/ucs_paper.msh.xz is missing (bash scripts/gpu_check.sh --prepare here, with build/)" |
      tee -a "$OUT/summary.txt"
    failed=1
  else
    runs=$(mktemp -d /tmp/fdem_gpu_paper.XXXXXX) || exit 1
    if ! xz -dc "$DEPS/ucs_paper.msh.xz" > "$runs/ucs_paper.msh"; then
      echo "paper: not run, deps/ucs_paper.msh.xz did not unpack (bash scripts/gpu_check.sh --prepare here again)" |
        tee -a "$OUT/summary.txt"
      failed=1
    else
      for n in "$n1" "$n2"; do  # the paper's scene with its mesh from the file, m = 1 and N steps
        {
          awk '/^(mesh|solver|output):/ { skip = 1; next } skip && /^[^ #]/ { skip = 0 } !skip' scenes/ucs_paper.yaml
          printf 'mesh:\n  file: ucs_paper.msh\nsolver:\n  mass_scaling: 1\n  end:\n    steps: %s\n' "$n"
          printf 'output:\n  monitor_interval: %s\n  field_interval: %s\n  plot: false\n  peak_frames: false\n' \
            $((n1 < 200 ? n1 : 200)) "$n"
          printf '  checkpoint_wall_interval: 0\n'
        } > "$runs/paper_$n.yaml"
      done
      for r in "${pb}_$n1" "${pb}_$n2" "cpu_$n1"; do
        step "paper_$r" 240 mpiexec --bind-to none -n 1 "$FDEM" run "$runs/paper_${r#*_}.yaml" --backend "${r%_*}" \
          -o "$runs/$r" -q
        mkdir -p "$LOGS/paper_$r" && cp "$runs/$r"/*.csv "$LOGS/paper_$r/" 2>/dev/null
      done
      pack_logs
      a=$LOGS/paper_${pb}_$n1/summary.csv b=$LOGS/paper_${pb}_$n2/summary.csv
      dt=$(sed -n 's/^  time step \([0-9.e+-]*\) s.*/\1/p' "$LOGS/paper_${pb}_$n2.log" 2>/dev/null | head -1)
      if [[ -f $a && -f $b && -n $dt ]]; then
        line=$(awk -v w1="$(ucs_value "$a" wall_s)" -v w2="$(ucs_value "$b" wall_s)" -v s1="$(ucs_value "$a" steps)" \
          -v s2="$(ucs_value "$b" steps)" -v dt="$dt" -v b="$pb" 'BEGIN {
            us = 1e6 * (w2 - w1) / (s2 - s1); n = 0.0192 / dt
            printf "paper: %s, %d and %d steps in %.1f and %.1f s: %.1f us per step before the peak; time step %.4g s, so %.3g steps to the post-peak stage: at least %.1f min\n", b, s1, s2, w1, w2, us, dt, n, us * n / 6e7
          }')
        echo "$line" | tee -a "$OUT/summary.txt"
      else
        echo "paper: no timing, a run wrote no summary.csv or its log no time step (see paper_*.log)" | tee -a "$OUT/summary.txt"
        failed=1
      fi
      # CPU = device on the paper's model: the last monitor row of the N1-step runs, column by column.
      m1=$LOGS/paper_${pb}_$n1/monitors.csv m2=$LOGS/paper_cpu_$n1/monitors.csv
      if [[ -f $m1 && -f $m2 ]]; then
        line=$(paste -d '\n' <(tail -1 "$m2") <(tail -1 "$m1") | awk -F, -v h="$(head -1 "$m1")" -v b="$pb" -v n="$n1" '
          NR == 1 { nc = split($0, c, ",") } NR == 2 { nh = split(h, name, ",")
            if ($1 != n || c[1] != n || NF != nh || nc != nh) {
              printf "paper: no comparison, the last rows are of step %s (cpu) and %s (%s), not %s\n", c[1], $1, b, n; exit }
            for (i = 1; i <= NF; ++i) { d = $i - c[i]; s = (c[i] < 0 ? -c[i] : c[i]) + ($i < 0 ? -$i : $i)
              if (d != 0 && (d < 0 ? -d : d) > 1e-8 * s) bad = bad " " name[i] " (cpu " c[i] ", " b " " $i ")" }
            printf "paper: last monitor row (step %s), cpu against %s: %s\n", $1, b, bad == "" ? "equal to 8 digits in every column" : "DIFFERENT in" bad }')
        echo "$line" | tee -a "$OUT/summary.txt"
        [[ $line == *"equal to 8 digits"* ]] || failed=1
      else
        echo "paper: no comparison, a run wrote no monitors.csv (see paper_*.log)" | tee -a "$OUT/summary.txt"
        failed=1
      fi
    fi
    rm -rf "$runs"
  fi
fi
# Under compute-sanitizer, where the toolkit has it (on a machine whose runtime lets it see the
# GPU); the kernels are waited for after each launch (FDEM_CUDA_SYNC=1). memcheck (the default
# schedule's elastic and fracturing tests, contact included, and gravity with pressure): accesses
# out of bounds or misaligned; initcheck: device memory read before
# anything wrote it (the debug backend's poison, on the GPU); racecheck: two threads of a block on
# one word of shared memory without a barrier between (the reductions' trees). The last two on
# the test of 300 steps and 3 monitor rows (they are slower).
if wanted sanitizer; then
  sanitizer=$(command -v compute-sanitizer)
  nvcc_dir=$(dirname "$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)")
  for d in "$nvcc_dir" /usr/local/cuda/bin; do
    [[ -z $sanitizer && -x $d/compute-sanitizer ]] && sanitizer=$d/compute-sanitizer
  done
  if [[ -z $sanitizer ]]; then
    echo "sanitizer: not run, compute-sanitizer not found (PATH, nvcc's folder, /usr/local/cuda/bin)" | tee -a "$OUT/summary.txt"
    failed=1
  else
    FDEM_CUDA_SYNC=1 step sanitizer 180 "$sanitizer" --tool memcheck --error-exitcode 3 \
      "$TESTS/test_cuda_backend" --gtest_filter='*ElasticBox*/0:*Fracturing*/0:*Gravity*'
    skips sanitizer  # (the sanitizer's runtime not seeing the GPU: every test skips)
    for tool in initcheck racecheck; do
      FDEM_CUDA_SYNC=1 step "sanitizer_$tool" 90 "$sanitizer" --tool $tool --error-exitcode 3 \
        "$TESTS/test_cuda_backend" --gtest_filter='*CountsTheCopies*'
      skips "sanitizer_$tool"
    done
  fi
fi
if wanted contact; then
  bench contact 150 bench_contact_full.md --tets 10000,100000 --steps 50 --contact full
fi
# fmad builds and runs against the machine's own packages and MPI, without the bundle's paths.
if wanted fmad; then
  own=(env -u OPAL_PREFIX -u PMIX_INSTALL_PREFIX -u PMIX_MCA_mca_base_component_path -u HWLOC_PLUGINS_PATH
    -u OMPI_MCA_pml -u OMPI_MCA_btl -u OMPI_MCA_btl_vader_single_copy_mechanism
    PATH="$OWN_PATH" LD_LIBRARY_PATH="$DEPS/usr/lib/x86_64-linux-gnu${OWN_LD:+:$OWN_LD}")
  step fmad_configure 120 "${own[@]}" cmake -S . -B build-gpu-fmad -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON \
    -DFDEM_CUDA_FMAD=ON -DFDEM_BUILD_TESTS=OFF -DFDEM_ENABLE_GMSH=OFF -DFDEM_ENABLE_PETSC=OFF \
    -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" &&
    step fmad_build 400 "${own[@]}" cmake --build build-gpu-fmad -j "$(nproc)" --target bench_device &&
    step fmad_bench 300 "${own[@]}" mpiexec --bind-to none -n 1 build-gpu-fmad/bench/bench_device \
      --tets 10000,100000,700000,2000000 --steps 200
  [[ -f "$LOGS/fmad_bench.log" ]] && cp "$LOGS/fmad_bench.log" "$OUT/bench_fmad.md"
fi
if ((failed)); then
  echo "verdict: FAILED or incomplete (see the lines above and logs.tar.gz)" | tee -a "$OUT/summary.txt"
else
  echo "verdict: every step passed" | tee -a "$OUT/summary.txt"
fi
exit "$failed"
