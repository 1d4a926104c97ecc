#!/usr/bin/env bash
# Install the Debian 12 packages fdem needs, only those that are missing.
# Usage: scripts/setup.sh [more packages] (scripts/fuzz.sh adds clang's).
set -euo pipefail
packages=(build-essential cmake pkg-config git
  libopenmpi-dev openmpi-bin libhdf5-openmpi-dev libmetis-dev petsc-dev
  libeigen3-dev libgtest-dev libgmsh-dev libyaml-cpp-dev libcli11-dev
  python3 python3-matplotlib procps "$@")  # procps: pkill in the multi-rank tests
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "fdem setup: installing ${missing[*]}"
  sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null; then
      echo "fdem setup: missing packages: ${missing[*]}" >&2
      echo "fdem setup: run as root (or install sudo), or install them yourself with apt-get" >&2
      exit 1
    fi
    sudo="sudo"
  fi
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
