#!/usr/bin/env bash
# Installs the Debian packages obsgain needs, and only those that are missing.
# Usage: scripts/install-deps.sh [--with-bench] [--with-browser]   (root, or sudo available)
#   --with-bench    SciPy, for the reference timings in bench/
# Python 3's headers, pybind11, NumPy, pytest and Matplotlib: the Python module, its tests and examples.
# OpenMPI: the apps across the ranks of a cluster job (docs/cluster.md).
#   --with-browser  Chromium, for the test that screenshots the HTML report
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  libeigen3-dev libnlopt-cxx-dev coinor-libipopt-dev libboost-dev
  libcli11-dev nlohmann-json3-dev libfmt-dev libgtest-dev libbenchmark-dev
  liborocos-kdl-dev libkdl-parser-dev liburdfdom-dev libtinyxml2-dev libconsole-bridge-dev
  gnuplot-nox libdsdp-dev
  python3-dev pybind11-dev python3-pybind11 python3-numpy python3-pytest python3-matplotlib
  libopenmpi-dev openmpi-bin
)
for option in "$@"; do
  case "$option" in
    --with-bench) packages+=(python3-scipy) ;;
    --with-browser) packages+=(chromium) ;;
    *) echo "install-deps: unknown option '$option'" >&2; exit 2 ;;
  esac
done

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
echo "installing: ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
