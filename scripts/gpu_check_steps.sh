# shellcheck shell=bash disable=SC2154,SC2016  # (the driver sets n1, n2, DRY; bash -c strings)
# The phases of scripts/gpu_check.sh, sourced by it (its header says what each does). Each phase
# is a function phase_NAME; they use the driver's settings (BACKEND, the sizes, TESTS, BENCH,
# FDEM) and its step, skip, say and refused.

# The mangled names of BIN's CUDA kernels, from their host stubs. Every kernel is a sum_kernel or
# a forall_kernel of a lambda; its name holds the lambda's enclosing function, as identifiers of
# the source. nvcc's lambda names are outside the standard mangling (c++filt leaves them as they
# are), so the profile selects kernels by their mangled names too.
kernel_names() {  # kernel_names BIN
  nm "$1" 2> /dev/null | grep -o '__device_stub__Z[A-Za-z0-9_]*' | sed 's/^__device_stub__/_/' | sort -u
}
# The kernels the profile reads: label=regex over their mangled names.
PROFILE_GROUPS=("fused pass=10fused_pass" "contact pairs=13ContactPassesINS_8CudaExecEE5pairs"
  "platens=10PlatenLoad6stored|21platens_and_pressure" "powers=23contact_pressure_powers|11GravityLoad9new_power")
PROFILE_METRICS=gpu__time_duration.sum,sm__warps_active.avg.pct_of_peak_sustained_active,\
dram__throughput.avg.pct_of_peak_sustained_elapsed,l1tex__t_bytes_pipe_lsu_mem_local_op_ld.sum,\
l1tex__t_bytes_pipe_lsu_mem_local_op_st.sum,launch__registers_per_thread

find_tool() {  # find_tool NAME: its path (PATH, nvcc's folder, CUDA's and Nsight's), or nothing
  local d
  command -v "$1" && return
  for d in "$(dirname "$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)")" /usr/local/cuda/bin /opt/nvidia/nsight-compute/*; do
    [[ -x $d/$1 ]] && echo "$d/$1" && return
  done
}
need() {  # need NAME PROGRAM: fails the step NAME when PROGRAM is missing
  [[ -x $2 ]] && return 0
  say "$1: FAILED, $2 is missing (Fix: bash scripts/gpu_check.sh --prepare here, and carry deps/)"
  FAILED+=("$1")
  return 1
}
csv_value() {  # csv_value CSV COLUMN: the column of the file's second row
  awk -F, -v col="$2" 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == col) c = i } NR == 2 && c { print $c }' "$1"
}
# A copy of scene SRC for a run of STEPS steps at mass scaling MASS, its mesh read from MESH
# (optional), monitor rows every MONITOR steps, one field frame and no plot.
scene_copy() {  # scene_copy SRC STEPS MASS MONITOR [MESH]
  local drop='solver|output'
  [[ -n ${5:-} ]] && drop='mesh|solver|output'
  awk -v drop="^($drop):" '$0 ~ drop { skip = 1; next } skip && /^[^ #]/ { skip = 0 } !skip' "$1"
  [[ -n ${5:-} ]] && printf 'mesh:\n  file: %s\n' "$5"
  printf 'solver:\n  mass_scaling: %s\n  end:\n    steps: %s\n' "$3" "$2"
  printf 'output:\n  monitor_interval: %s\n  field_interval: %s\n  plot: false\n  peak_frames: false\n' "$4" "$2"
  printf '  checkpoint_wall_interval: 0\n'
}

# The programs: deps/bundle's (built on the Debian machine, with its libraries and Open MPI,
# relocated by OPAL_PREFIX and PMIX_INSTALL_PREFIX), build-gpu/'s (phase build), or in the dry
# run FDEM_BUILD_DIR's.
programs() {
  local from=bundle
  wanted build && from=build-gpu
  ((DRY)) && from=${FDEM_GPU_PROGRAMS:-build}
  export LD_LIBRARY_PATH="$DEPS/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_mpi_yield_when_idle=1
  export GTEST_COLOR=no  # plain logs (through mpiexec GoogleTest would colour them)
  case $from in
    build)
      local b=${FDEM_BUILD_DIR:-build}
      TESTS=$b/tests BENCH=$b/bench FDEM=$b/fdem
      ;;
    build-gpu) TESTS=build-gpu/tests BENCH=build-gpu/bench FDEM=build-gpu/fdem ;;
    bundle) bundle_programs || return 1 ;;
    *)
      echo "gpu_check.sh: FDEM_GPU_PROGRAMS='$from' is not build or bundle" >&2
      exit 2
      ;;
  esac
  PROGRAM_ENV=(env "LD_LIBRARY_PATH=$LD_LIBRARY_PATH")
  echo "programs: $from ($FDEM)" >> "$OUT/machine.txt"
}
bundle_programs() {
  if [[ ! -f $DEPS/bundle.tar.xz ]]; then
    say "gpu_check.sh: deps/bundle.tar.xz is missing. Fix: bash scripts/gpu_check.sh --prepare here, or name the phase build"
    return 1
  fi
  # Built on Debian 12: its libraries need the C library 2.36 or newer (Ubuntu 24.04 has 2.39).
  local glibc
  glibc=$(getconf GNU_LIBC_VERSION | awk '{print $2}')
  if [[ $(printf '%s\n2.36\n' "$glibc" | sort -V | head -1) != 2.36 ]]; then
    say "gpu_check.sh: this machine's C library is $glibc, older than the bundle's 2.36. Fix: name the phase build (it builds here)"
    return 1
  fi
  if ! { rm -rf "$DEPS/bundle" && unxz "$DEPS/bundle.tar.xz" | tar -C "$DEPS" -x; }; then
    say "gpu_check.sh: deps/bundle.tar.xz did not unpack. Fix: bash scripts/gpu_check.sh --prepare here again"
    return 1
  fi
  TESTS=$DEPS/bundle/bin BENCH=$DEPS/bundle/bin FDEM=$DEPS/bundle/bin/fdem
  local mpi=$DEPS/bundle/mpi/usr
  export PATH="$mpi/bin:$PATH" OPAL_PREFIX="$mpi" PMIX_INSTALL_PREFIX="$mpi/lib/x86_64-linux-gnu/pmix2" \
    PMIX_MCA_mca_base_component_path="$mpi/lib/x86_64-linux-gnu/pmix2/lib/pmix" HWLOC_PLUGINS_PATH="$DEPS/bundle/none"
  export LD_LIBRARY_PATH="$DEPS/bundle/lib:$mpi/lib/x86_64-linux-gnu:$mpi/lib/x86_64-linux-gnu/pmix2/lib:$LD_LIBRARY_PATH"
  # Shared memory between the ranks of one machine only: no UCX or libfabric plugins, whose
  # own plugins Open MPI's relocation does not move, and no single-copy by ptrace (containers).
  export OMPI_MCA_pml=ob1 OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none
  # The tests find tests/data under the checkout they were built from.
  local src
  src=$(cat "$DEPS/bundle/SOURCE_DIR")
  if [[ $src != "$PWD" && ! -d $src/tests/data ]]; then mkdir -p "$(dirname "$src")" && ln -sfn "$PWD" "$src"; fi
  [[ -d $src/tests/data ]] || say "gpu_check.sh: $src/tests/data is missing: the tests will not find their data"
}

phase_build() {
  step configure 120 cmake -S . -B build-gpu -DCMAKE_BUILD_TYPE=Release -DFDEM_ENABLE_CUDA=ON -DFDEM_ENABLE_GMSH=OFF \
    -DFDEM_ENABLE_PETSC=OFF -DCMAKE_PREFIX_PATH="$DEPS/usr" -DCMAKE_CUDA_ARCHITECTURES="90-real;90-virtual" \
    -DCMAKE_CUDA_RUNTIME_LIBRARY=Shared &&
    step build 400 cmake --build build-gpu -j "$(nproc)" --target fdem test_cuda_backend test_ranks bench_device bench_contact
}

phase_facts() {
  local t
  {
    date -u
    uname -r
    echo "cores: $(nproc)"
    for t in ncu compute-sanitizer cuobjdump xz python3; do echo "$t: $(find_tool $t || echo missing)"; done
  } >> "$OUT/machine.txt"
  step facts 30 "${TOOL_ENV[@]}" bash -c 'nvidia-smi -L; nvidia-smi -q -d CLOCK,POWER; nvcc --version | tail -2
    for t in ncu compute-sanitizer; do command -v $t > /dev/null && $t --version | tail -1; done; true'
  cat "$LOGS/facts.log" >> "$OUT/machine.txt"
  if ((!DRY)) && ! has_gpu; then
    say "gpu: nvidia-smi lists no GPU, so the GPU tests skip: not a pass"
    FAILED+=(gpu)
  fi
}

# The first test that failed in step NAME's log or, where the step failed (exit RC) with none
# failed, the one a crash or a timeout left running. Only one: after a sticky CUDA error every
# later test fails, and memcheck is slow.
failed_test() {  # failed_test NAME RC
  awk -v rc="$2" '/^\[ RUN      \]/ { running = $4 }
    /^\[ +(OK|FAILED|SKIPPED) +\]/ { name = $4; sub(/,$/, "", name)
      if ($2 == "FAILED" && first == "" && name == running) first = name
      running = "" }
    END { print first != "" ? first : (rc != 0 ? running : "") }' "$LOGS/$1.log" 2> /dev/null
}
memcheck_command() {  # sets MEMCHECK (the dry run: none, no GPU here); false when there is none
  MEMCHECK=()
  ((DRY)) && return 0
  local s
  s=$(find_tool compute-sanitizer) || return 1
  MEMCHECK=("${TOOL_ENV[@]}" "$s" --tool memcheck --error-exitcode 3 "${PROGRAM_ENV[@]}")
}
SANITIZER_REFUSED='Device not supported|error 999'
phase_tests() {
  need tests "$TESTS/$GPU_TESTS" || return
  step tests 150 "$TESTS/$GPU_TESTS" --gtest_filter="$TESTS_FILTER" --gtest_output="xml:$LOGS/tests.xml"
  local rc=$?
  # A GPU that nvidia-smi lists but the tests skipped (a driver older than the runtime) fails.
  skips tests
  local again
  again=$(failed_test tests "$rc")
  if [[ -z $again ]] && ((DRY)); then  # here nothing fails: the first test takes the path
    again=$(grep -o '^\[ RUN      \] [^ ]*' "$LOGS/tests.log" | head -1 | awk '{print $4}')
    say "tests: dry run, $again is run again as a failing test would be"
    [[ -n $again ]] || return 0
  fi
  [[ -n $again ]] || return 0
  if ! memcheck_command; then
    skip tests_memcheck "compute-sanitizer not found: the failing tests were not run again"
    return
  fi
  STEP_COUNTS=0 step tests_memcheck 150 env FDEM_CUDA_SYNC=1 "${MEMCHECK[@]}" "$TESTS/$GPU_TESTS" --gtest_filter="$again"
  refused tests_memcheck "$SANITIZER_REFUSED" "compute-sanitizer refused this machine's GPU" ||
    grep -h 'ERROR SUMMARY' "$LOGS/tests_memcheck.log" | tail -1 | sed 's/^/tests_memcheck: /' | tee -a "$SUMMARY"
}

# bench_device starts MPI: through mpiexec, not as a singleton of the relocated Open MPI.
bench_table() {  # bench_table NAME SECONDS TABLE PROGRAM ARGS...: a step whose log is a table in $OUT
  local name=$1 limit=$2 table=$3 program=$4
  shift 4
  need "$name" "$program" || return
  step "$name" "$limit" mpiexec --bind-to none -n 1 "$program" --backend "$BACKEND" "$@"
  [[ -f $LOGS/$name.log ]] && cp "$LOGS/$name.log" "$OUT/$table"
}
phase_bench() {
  bench_table bench 180 bench_device.md "$BENCH/bench_device" --tets "$BENCH_TETS" --steps "$BENCH_STEPS" --schedule auto
  # The schedules, and the fused pass's kernels for one and for two resident blocks per SM.
  bench_table bench_blocks 120 bench_blocks.md "$BENCH/bench_device" --tets "$BLOCK_TETS" --steps "$BENCH_STEPS" \
    --schedule auto,fused,colour --blocks-per-sm 1,2
}

# ncu on the kernels of PROFILE_GROUPS, on bench_device with every tet a contact candidate (so
# the pairs kernel runs). First the groups are matched against the kernel names the build holds
# (deps/bundle/kernels.txt, or the program's symbols): a renamed pass fails here, also in the
# dry run, not silently there.
phase_profile() {
  local list label re all="" counts="" missing=0 g n
  list=$(cat "$BENCH/kernels.txt" 2> /dev/null || kernel_names "$BENCH/bench_device")
  if [[ -z $list ]]; then
    skip profile_names "no CUDA kernels in $BENCH/bench_device (built without nvcc)"
  else
    for g in "${PROFILE_GROUPS[@]}"; do
      label=${g%%=*} re=${g#*=}
      n=$(grep -c -E "$re" <<< "$list")
      counts+="${counts:+, }$label $n"
      ((n > 0)) || missing=1
    done
    say "profile_names: kernels of the build in each group: $counts"
    ((missing)) && FAILED+=(profile_names)
  fi
  for g in "${PROFILE_GROUPS[@]}"; do all+="${all:+|}${g#*=}"; done
  local ncu
  ncu=$(find_tool ncu)
  if ((DRY)) || [[ -z $ncu ]]; then
    skip profile "${ncu:-ncu not found}${ncu:+ needs a GPU}"
    return
  fi
  step profile 150 mpiexec --bind-to none -n 1 "${TOOL_ENV[@]}" "$ncu" --clock-control none --kernel-name-base mangled -k "regex:$all" \
    --print-kernel-base mangled \
    --launch-skip 20 --launch-count 30 --metrics "$PROFILE_METRICS" --csv --log-file "$LOGS/profile.csv" \
    "${PROGRAM_ENV[@]}" "$BENCH/bench_device" --backend "$BACKEND" --tets "$PROFILE_TETS" --steps 10 --contact full --schedule auto
  refused profile 'LibraryNotLoaded|ERR_NVGPUCTRPERM|not supported on this' "ncu cannot read this machine's counters"
  [[ -f $LOGS/profile.csv ]] && cp "$LOGS/profile.csv" "$OUT/profile.csv"
  if [[ " ${FAILED[*]} ${SKIPPED[*]} ${NOT_STARTED[*]} " != *" profile "* ]] && ! grep -qs gpu__time_duration "$LOGS/profile.csv"; then
    say "profile: FAILED, ncu profiled no kernel (the kernel filter matched none at run time)"
    FAILED+=(profile)
  fi
}

# The last monitor rows of two runs, column by column, each at the scale of its kind in the row
# (energies at the largest energy, stresses at the largest stress, and so on; the energy error,
# a fraction of the external work, at 1): a small residual is not a difference. Prints "equal",
# or the columns that differ by more than TOL of their scale.
compare_last_rows() {  # compare_last_rows CSV_A CSV_B TOL
  if [[ $(head -1 "$1") != "$(head -1 "$2")" ]]; then
    echo "DIFFERENT columns"
    return
  fi
  { head -1 "$1"; tail -1 "$1"; tail -1 "$2"; } | awk -F, -v tol="$3" '
    function abs(x) { return x < 0 ? -x : x }
    function kind(c) {
      if (c ~ /_J$/) return "J"; if (c ~ /_Pa$/) return "Pa"; if (c ~ /_N$/) return "N"
      if (c ~ /strain$/) return "strain"; return c
    }
    NR == 1 { n = split($0, name); next }
    NR == 2 { split($0, a); next }
    { split($0, b)
      if (a[1] != b[1]) { print "DIFFERENT steps (" a[1] " against " b[1] ")"; exit }
      for (i = 1; i <= n; ++i) { k = kind(name[i]); m = abs(a[i]) > abs(b[i]) ? abs(a[i]) : abs(b[i]); if (m > s[k]) s[k] = m }
      s["energy_error"] = 1
      for (i = 1; i <= n; ++i) if (abs(a[i] - b[i]) > tol * s[kind(name[i])]) bad = bad " " name[i] " (" a[i] ", " b[i] ")"
      print bad == "" ? "equal" : "DIFFERENT in" bad }'
}

# The paper's UCS model (scenes/ucs_paper.yaml with the mesh --prepare wrote, at m = 1 as the
# issue's goal): on the device for N1 and N2 steps, whose loop times differ by N2 - N1 steps of
# the real run (contact, platens, monitor rows, two field frames each) without its start. That
# step time times 0.0192 s of loading (docs/validation.md) over the time step is a lower bound
# of the wall time to the post-peak stage: these steps are before the peak. The CPU runs N1
# steps too; its last monitor row must equal the device's to 8 of the 10 digits printed. The dry
# run takes the default scene's mesh instead.
phase_paper() {
  local packed=$DEPS/ucs_paper.msh.xz runs=$WORK/paper
  mkdir -p "$runs"
  if ((DRY)); then
    packed=$runs/small.msh.xz
    "${FDEM_BUILD_DIR:-build}/fdem" check scenes/ucs_small.yaml --write-mesh "$runs/small.msh" > /dev/null &&
      python3 -c 'import lzma, shutil, sys; shutil.copyfileobj(open(sys.argv[1], "rb"), lzma.open(sys.argv[2], "wb"))' \
        "$runs/small.msh" "$packed"
  fi
  if [[ ! -f $packed ]] || ! unxz "$packed" > "$runs/ucs_paper.msh"; then
    say "paper: FAILED, $packed is missing or did not unpack (Fix: bash scripts/gpu_check.sh --prepare here, with build/)"
    FAILED+=(paper)
    return
  fi
  local n r ns=${#NOT_STARTED[@]}
  for n in "$n1" "$n2"; do scene_copy scenes/ucs_paper.yaml "$n" 1 $((n1 < 200 ? n1 : 200)) ucs_paper.msh > "$runs/paper_$n.yaml"; done
  for r in "${BACKEND}_$n1" "${BACKEND}_$n2" "cpu_$n1"; do
    need "paper_$r" "$FDEM" || return
    step "paper_$r" 240 mpiexec --bind-to none -n 1 "$FDEM" run "$runs/paper_${r#*_}.yaml" --backend "${r%_*}" -o "$runs/$r" -q
    mkdir -p "$LOGS/paper_$r" && cp "$runs/$r"/*.csv "$LOGS/paper_$r/" 2> /dev/null
  done
  pack_logs
  ((${#NOT_STARTED[@]} > ns)) && return  # no time left: nothing to compare
  paper_timing
  local m1=$LOGS/paper_${BACKEND}_$n1/monitors.csv m2=$LOGS/paper_cpu_$n1/monitors.csv line
  if [[ -f $m1 && -f $m2 ]]; then
    line=$(compare_last_rows "$m2" "$m1" 1e-8)
    say "paper: last monitor row (step $n1), cpu against $BACKEND: $line"
    [[ $line == equal ]] || FAILED+=(paper_compare)
  else
    say "paper: FAILED, no comparison: a run wrote no monitors.csv (see paper_*.log)"
    FAILED+=(paper_compare)
  fi
}
paper_timing() {
  local a=$LOGS/paper_${BACKEND}_$n1/summary.csv b=$LOGS/paper_${BACKEND}_$n2/summary.csv dt
  dt=$(sed -n 's/^  time step \([0-9.e+-]*\) s.*/\1/p' "$LOGS/paper_${BACKEND}_$n2.log" 2> /dev/null | head -1)
  if [[ ! -f $a || ! -f $b || -z $dt ]]; then
    say "paper: FAILED, no timing: a run wrote no summary.csv or its log no time step (see paper_*.log)"
    FAILED+=(paper_timing)
    return
  fi
  say "$(awk -v w1="$(csv_value "$a" wall_s)" -v w2="$(csv_value "$b" wall_s)" -v s1="$(csv_value "$a" steps)" \
    -v s2="$(csv_value "$b" steps)" -v dt="$dt" -v b="$BACKEND" 'BEGIN {
      us = 1e6 * (w2 - w1) / (s2 - s1); n = 0.0192 / dt
      printf "paper: %s, %d and %d steps in %.1f and %.1f s: %.1f us per step before the peak; time step %.4g s, so %.3g steps to the post-peak stage: at least %.1f min\n", b, s1, s2, w1, w2, us, dt, n, us * n / 6e7
    }')"
}

# The default scene end to end, fdem run with its outputs, on the CPU (all cores: --bind-to
# none, or Open MPI binds the one rank to one core) and on the device from the same rank file:
# the fracturing criteria, peak within 1 % and broken CE6 within 5 %, and each run's wall time.
# The dry run partitions the scene here and stops it after UCS_STEPS steps.
phase_ucs() {
  local parts=$DEPS/ucs_small_1 scene=scenes/ucs_small.yaml b
  if ((DRY)); then
    parts=$WORK/ucs_small_1 scene=$WORK/ucs_small.yaml
    "${FDEM_BUILD_DIR:-build}/fdem" partition scenes/ucs_small.yaml -n 1 -o "$parts" > /dev/null
    scene_copy scenes/ucs_small.yaml "$UCS_STEPS" 5 50 > "$scene"
  fi
  if [[ ! -f $parts/rank_0.fdp ]]; then
    say "ucs: FAILED, $parts is missing (Fix: bash scripts/gpu_check.sh --prepare here, with build/)"
    FAILED+=(ucs)
    return
  fi
  local ns=${#NOT_STARTED[@]}
  for b in cpu "$BACKEND"; do
    need "ucs_$b" "$FDEM" || return
    step "ucs_$b" 150 mpiexec --bind-to none -n 1 "$FDEM" run "$scene" --partitioned "$parts" --backend "$b" \
      -o "$WORK/ucs_$b" -q
    mkdir -p "$LOGS/ucs_$b" && cp "$WORK/ucs_$b"/*.csv "$LOGS/ucs_$b/" 2> /dev/null
  done
  pack_logs
  ((${#NOT_STARTED[@]} > ns)) && return  # no time left: nothing to compare
  local a=$LOGS/ucs_cpu/summary.csv g=$LOGS/ucs_$BACKEND/summary.csv line
  if [[ ! -f $a || ! -f $g ]]; then
    say "ucs: FAILED, no comparison: a run wrote no summary.csv (see its log)"
    FAILED+=(ucs_compare)
    return
  fi
  line=$(awk -v pa="$(csv_value "$a" peak_stress_Pa)" -v pg="$(csv_value "$g" peak_stress_Pa)" \
    -v ba="$(csv_value "$a" broken_ce6)" -v bg="$(csv_value "$g" broken_ce6)" -v b="$BACKEND" \
    -v wa="$(csv_value "$a" wall_s)" -v wg="$(csv_value "$g" wall_s)" -v n="$(csv_value "$g" steps)" 'BEGIN {
      dp = (pg - pa) / pa; db = ba > 0 ? (bg - ba) / ba : (bg == ba ? 0 : 1)
      ok = (dp <= 0.01 && dp >= -0.01 && db <= 0.05 && db >= -0.05) ? "within" : "OUTSIDE"
      printf "ucs: peak cpu %.6g Pa, %s %.6g Pa (%+.3f %%); broken CE6 cpu %d, %s %d (%+.2f %%): %s the criteria; wall cpu %.1f s, %s %.1f s (%d steps)\n", pa, b, pg, 100 * dp, ba, b, bg, 100 * db, ok, wa, b, wg, n
    }')
  say "$line"
  [[ $line == *" within the criteria"* ]] || FAILED+=(ucs_compare)
}

# Under compute-sanitizer's memcheck, waiting for each kernel (FDEM_CUDA_SYNC=1): accesses out of
# bounds or misaligned, on one fracturing test (contact included).
phase_memcheck() {
  need memcheck "$TESTS/$GPU_TESTS" || return
  if ! memcheck_command; then
    skip memcheck "compute-sanitizer not found"
    return
  fi
  ((DRY)) && say "memcheck: dry run, without compute-sanitizer (no GPU here)"
  step memcheck 150 env FDEM_CUDA_SYNC=1 "${MEMCHECK[@]}" "$TESTS/$GPU_TESTS" --gtest_filter="$MEMCHECK_FILTER"
  local rc=$?
  refused memcheck "$SANITIZER_REFUSED" "compute-sanitizer refused this machine's GPU" && return
  # Stopped at its limit with no error found so far: slow under memcheck, not a fault found.
  if ((rc == 124 || rc == 137)) && ! grep -qE '^========= (Invalid|Program hit|Error)' "$LOGS/memcheck.log"; then
    not_failed memcheck "memcheck did not finish in its time, no error found before (see memcheck.log)"
    return
  fi
  skips memcheck
}

# The 1-vs-2-rank device tests (the ranks share the GPU). The bundle's Open MPI is not
# CUDA-aware, so the device-buffer halo (cuda+mpi) skips there.
phase_ranks() {
  local np
  for np in 1 2; do
    need "ranks_$np" "$TESTS/test_ranks" || return
    step "ranks_$np" 120 mpiexec --oversubscribe -n $np "$TESTS/test_ranks" --gtest_filter="$RANKS_FILTER"
    skips "ranks_$np" 'cuda_mpi'
  done
}

# bench_contact on the device, adaptive against full activation, to the post-peak stage. Its
# cylinders come meshed from here (deps/contact; the dry run writes its own).
phase_contact() {
  local meshes=$DEPS/contact
  need contact "$BENCH/bench_contact" || return
  if ((DRY)); then
    meshes=$WORK/contact
    mkdir -p "$meshes" && "${FDEM_BUILD_DIR:-build}/bench/bench_contact" --sizes "$CONTACT_SIZES" --write-meshes "$meshes"
  fi
  step contact 300 "$BENCH/bench_contact" --backend "$BACKEND" --sizes "$CONTACT_SIZES" --meshes "$meshes" \
    "${CONTACT_ARGS[@]}"
  [[ -f $LOGS/contact.log ]] && cp "$LOGS/contact.log" "$OUT/bench_contact.md"
}

# bench_device built with FDEM_CUDA_FMAD=ON (nvcc fuses multiply-adds; no longer the CPU
# backend's bits), timed as the phase bench does: what the bit-for-bit agreement costs.
phase_fmad() {
  local program=$BENCH/bench_device_fmad
  if ((DRY)) && [[ ! -x $program ]]; then
    program=$BENCH/bench_device
    say "fmad: dry run, bench_device stands in for bench_device_fmad (deps/bundle has it)"
  fi
  bench_table fmad 300 bench_fmad.md "$program" --tets "$FMAD_TETS" --steps "$BENCH_STEPS"
}

# bench_fields on the GPU machine's cores, one rank a core: one fields.h5 through MPI-IO
# against a file per rank (issue 37's goal at 8 ranks; the 2-core dev VM can only oversubscribe).
phase_fields() {
  local np dir=$WORK/fields
  need fields "$BENCH/bench_fields" || return
  : > "$OUT/bench_fields.md"
  for np in $FIELDS_RANKS; do
    mkdir -p "$dir"
    step "fields_$np" 120 mpiexec --bind-to none -n "$np" -x OMP_NUM_THREADS=1 "$BENCH/bench_fields" \
      --tets "$FIELDS_TETS" --frames 3 --repeats 5 --dir "$dir"
    [[ -f $LOGS/fields_$np.log ]] && cat "$LOGS/fields_$np.log" >> "$OUT/bench_fields.md"
    rm -rf "$dir"
  done
}

verdict() {
  local v rc=0
  if ((${#FAILED[@]})); then
    v="FAILED: ${FAILED[*]}" rc=1
  elif ((${#NOT_STARTED[@]})); then
    v="INCOMPLETE, nothing failed" rc=3
  else
    v=PASSED
  fi
  ((${#NOT_STARTED[@]})) && v+="; not started: ${NOT_STARTED[*]} (run their phases in another call)"
  ((${#SKIPPED[@]})) && v+="; skipped: ${SKIPPED[*]}"
  say "verdict: $v"
  pack_logs
  return $rc
}
