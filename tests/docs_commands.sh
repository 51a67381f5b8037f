#!/usr/bin/env bash
# Runs every command that README.md and docs/*.md show in their fenced blocks (lines starting with build/), in
# order, from a scratch directory that sees the repository's examples/, with the apps of BUILD_DIR. Long runs
# are shortened: certified bounds of arms get a 2.5 s budget, Monte Carlo at most 50 trials. Fails on any
# non-zero exit. Usage: docs_commands.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
root=$1
build=$2
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
ln -s "$root/examples" "$scratch/examples"
cd "$scratch"
count=0
failed=0
while IFS= read -r line; do
  command=${line%%#*}  # drop the trailing comment
  command=${command/#build\//$build/}
  command=$(sed -E 's/--trials [0-9]{3,}/--trials 50/' <<<"$command")
  if [[ $command == *.urdf* && $command != *"--bounds numeric"* && $command != *--bound-budget* ]]; then
    command+=" --bound-budget 2.5"
  fi
  count=$((count + 1))
  if ! eval "$command" >/dev/null 2>"$scratch/err"; then
    echo "FAILED: $line" >&2
    head -3 "$scratch/err" >&2
    failed=$((failed + 1))
  fi
done < <(cd "$root" && awk '/^```/ { fenced = !fenced; next } fenced && /^build\// && !/\[/' README.md docs/*.md)
echo "$((count - failed)) passed, $failed failed"
[[ $failed -eq 0 && $count -gt 10 ]]
