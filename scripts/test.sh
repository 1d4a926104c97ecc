#!/usr/bin/env bash
# Quick start 2: build fdem and run every test (labels unit, regression, stability, mpi; gpu where nvcc built them).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/build.sh"
cd "$root/build"
# One test at a time: the solver tests use every core through OpenMP, and two of them side
# by side spin against each other at every colour barrier (measured: 34 s serial against
# minutes with -j2 on 2 cores).
ctest --output-on-failure "$@"
