#!/usr/bin/env bash
# Prints the time of one paper-scenario trajectory in obsgain and in SciPy (solve_ivp RK45, same tolerances)
# and their ratio (target >= 300), and the 2-thread Monte Carlo speed-up (target >= 1.8).
# Usage: bench/compare_scipy.sh [BUILD_DIR]   (needs python3-scipy: scripts/install-deps.sh --with-bench)
set -euo pipefail
build=${1:-build}
json=$(mktemp)
"$build/bench/bench_simulation" --benchmark_repetitions=5 --benchmark_report_aggregates_only=true \
  --benchmark_format=json >"$json"
read -r scipy_us scipy_steps < <(/usr/bin/python3 "$(dirname "$0")/scipy_paper_trajectory.py")
/usr/bin/python3 - "$json" "$scipy_us" "$scipy_steps" <<'PY'
import json, sys
runs = {b["name"]: b["real_time"] for b in json.load(open(sys.argv[1]))["benchmarks"] if b.get("aggregate_name") == "median"}
ours = runs["PaperTrajectory_median"]
scipy = float(sys.argv[2])
print(f"paper trajectory, 1 s horizon, one thread: obsgain {ours:.1f} us, SciPy RK45 {scipy:.0f} us "
      f"({sys.argv[3]} steps): ratio {scipy / ours:.0f}x (target >= 300x)")
one, two = runs["MonteCarlo200/1_median"], runs["MonteCarlo200/2_median"]
print(f"monte-carlo 200 trials: 1 thread {one:.0f} ms, 2 threads {two:.0f} ms: speed-up {one / two:.2f}x (target >= 1.8x)")
PY
rm -f "$json"
