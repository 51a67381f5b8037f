#!/usr/bin/env bash
# One command: install what is missing, build, and design certified gains for the built-in Pendubot.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh
./build/design-gains --robot pendubot --gamma 1.27
