#!/usr/bin/env bash
# Quick start 1: build fdem and run the default scene (a small UCS test of the reference
# limestone). Outputs go to out/ucs_small: monitors.csv, stress_strain.png, fields.xdmf.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$root/scripts/build.sh"
cd "$root"
exec ./build/fdem run scenes/ucs_small.yaml "$@"
