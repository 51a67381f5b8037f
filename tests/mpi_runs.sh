#!/usr/bin/env bash
# The apps across two MPI ranks answer as one process does: the same JSON, wall-clock times aside, for the Pendubot's
# and a 3-joint arm's design and for a Monte Carlo campaign (docs/cluster.md). Usage: mpi_runs.sh APP_DIR SOURCE_DIR
set -euo pipefail
apps=$1
root=$2
# mpirun refuses root unless told (CI runs as root).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

same_json() {
  /usr/bin/python3 - "$1" "$2" <<'PY'
import json, sys
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if k not in ("seconds", "wall_seconds", "threads")}
    return [strip(x) for x in v] if isinstance(v, list) else v
one, two = (json.load(open(path)) for path in sys.argv[1:3])
if strip(one) != strip(two):
    sys.exit(f"{sys.argv[2]} differs from {sys.argv[1]}")
PY
}

check() {
  local name=$1 app=$2
  shift 2
  "$apps/$app" "$@" --quiet --json > "$scratch/$name.one.json"
  mpirun -np 2 --oversubscribe "$apps/$app" "$@" --quiet --json > "$scratch/$name.two.json"
  same_json "$scratch/$name.one.json" "$scratch/$name.two.json"
  echo "ok   $name: 2 ranks = 1 process"
}

check pendubot design-gains --robot pendubot --gamma 1.27
check arm3 design-gains --robot "$root/examples/arm3.urdf" --gamma 5 --bound-budget 1.5
check monte-carlo monte-carlo --robot pendubot --gamma 1.27 --trials 40 --seed 7
# Rank 1 prints nothing: one table, not two.
tables=$(mpirun -np 2 --oversubscribe "$apps/design-gains" --robot pendubot --gamma 1.27 --quiet | grep -c "^obsgain design for")
[[ $tables -eq 1 ]] || { echo "the table was printed $tables times" >&2; exit 1; }
echo "ok   one table from two ranks"
