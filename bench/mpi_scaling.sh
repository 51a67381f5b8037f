#!/usr/bin/env bash
# The speed-up of MPI ranks on this machine (docs/cluster.md): Monte Carlo trials and a 6-joint arm's bound search on
# 1 and 2 ranks of one thread each, against one process of two threads (the per-rank overhead against threads), with
# the per-trial and per-box costs. Usage: bench/mpi_scaling.sh [BUILD_DIR]   (from the repository's root)
set -euo pipefail
build=${1:-build}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# Wall seconds of a command, and its JSON in $scratch/out.json.
timed() {
  local start end
  start=$(date +%s.%N)
  "$@" --quiet --json > "$scratch/out.json"
  end=$(date +%s.%N)
  calc "$end - $start"
}
calc() { /usr/bin/python3 -c "print(round($1, 3))"; }
# Seconds the certified searches took (the JSON's brackets), and their boxes.
searches() {
  /usr/bin/python3 -c "import json; b = json.load(open('$scratch/out.json'))['bounds']['brackets']; \
print(sum(x['seconds'] for x in b.values()), sum(x['boxes'] for x in b.values()))"
}

trials=400
mc=(monte-carlo --robot examples/arm3.urdf --gamma 5 --bounds numeric --trials $trials --seed 1)
one=$(timed mpirun -np 1 "$build/${mc[0]}" "${mc[@]:1}" --threads 1)
two=$(timed mpirun -np 2 "$build/${mc[0]}" "${mc[@]:1}" --threads 1)
threads=$(timed "$build/${mc[0]}" "${mc[@]:1}" --threads 2)
echo "monte-carlo, arm3, $trials trials: 1 rank $one s, 2 ranks $two s (speed-up $(calc "$one / $two")), 1 process of 2 threads $threads s; $(calc "1000 * $one / $trials") ms per trial"

design=(design-gains --robot examples/arm6.urdf --gamma 5 --bound-budget 15)
mpirun -np 1 "$build/${design[0]}" "${design[@]:1}" --threads 1 --quiet --json > "$scratch/out.json"
read -r one boxes < <(searches)
mpirun -np 2 "$build/${design[0]}" "${design[@]:1}" --threads 1 --quiet --json > "$scratch/out.json"
read -r two _ < <(searches)
"$build/${design[0]}" "${design[@]:1}" --threads 2 --quiet --json > "$scratch/out.json"
read -r threads _ < <(searches)
echo "bound search, arm6, budget 15: 1 rank $one s, 2 ranks $two s (speed-up $(calc "$one / $two")), 1 process of 2 threads $threads s; $boxes boxes, $(calc "1000 * $one / $boxes") ms per box"
