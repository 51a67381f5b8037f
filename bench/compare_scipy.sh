#!/usr/bin/env bash
# Prints the time of one paper-scenario trajectory in obsgain and in SciPy (solve_ivp RK45, same tolerances)
# and their ratio (target >= 300), and the 2-thread Monte Carlo speed-up (target >= 1.8).
# Usage: bench/compare_scipy.sh [BUILD_DIR]   (needs python3-scipy: scripts/install-deps.sh --with-bench)
set -euo pipefail
build=${1:-build}
json=$(mktemp)
"$build/bench/bench_simulation" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
  --benchmark_format=json >"$json"
scipy=$(mktemp)
/usr/bin/python3 "$(dirname "$0")/scipy_paper_trajectory.py" >"$scipy"
/usr/bin/python3 - "$json" "$scipy" <<'PY'
import json, sys
bench = json.load(open(sys.argv[1]))["benchmarks"]
runs = {b["run_name"]: b for b in bench if b.get("aggregate_name") == "median"}
ours = runs["PaperTrajectory/real_time"]["real_time"]
steps = runs["PaperTrajectory/real_time"].get("steps", 0)
print(f"paper trajectory, 1 s horizon, one thread: obsgain {ours:.0f} us ({steps:.0f} steps)")
for line in open(sys.argv[2]):
    name, us, scipy_steps = line.split()
    per_step = (float(us) / int(scipy_steps)) / (ours / steps)
    print(f"  SciPy RK45, {name:5s} formulation: {float(us):.0f} us ({scipy_steps} steps): ratio {float(us) / ours:.0f}x "
          f"per trajectory, {per_step:.0f}x per step")
print("  (target >= 300x; 'same' is the like-for-like comparison, see bench/scipy_paper_trajectory.py)")
one, two = runs["MonteCarlo200/1/real_time"]["real_time"], runs["MonteCarlo200/2/real_time"]["real_time"]
print(f"monte-carlo 200 trials: 1 thread {one:.0f} ms, 2 threads {two:.0f} ms: speed-up {one / two:.2f}x (target >= 1.8x)")
PY
rm -f "$json" "$scipy"
