#!/usr/bin/env bash
# Opens verify-bounds' report.html in headless Chromium, takes a screenshot, and checks it is not blank:
# the report's screenshot must be far larger (as PNG) than a screenshot of an empty page of the same size.
# Usage: tests/screenshot_report.sh BUILD_DIR
set -euo pipefail
build=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
browser=$(command -v chromium || command -v chromium-browser || true)
if [[ -z "$browser" ]]; then
  echo "chromium is not installed (scripts/install-deps.sh --with-browser installs it)" >&2
  exit 1
fi
"$build/verify-bounds" --robot pendubot --gamma 1.27 --trials 20 --out "$work/report" >/dev/null
printf '<!DOCTYPE html><html><body></body></html>\n' >"$work/blank.html"
shoot() {
  timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-background-networking --no-first-run \
    --disable-component-update --disable-sync --user-data-dir="$work/profile-$2" --window-size=1200,3800 \
    --screenshot="$work/$2.png" "file://$1" >/dev/null 2>&1
  test -s "$work/$2.png"
}
shoot "$work/report/report.html" report
shoot "$work/blank.html" blank
report_size=$(stat -c %s "$work/report.png")
blank_size=$(stat -c %s "$work/blank.png")
echo "screenshot: report $report_size bytes, blank page $blank_size bytes"
if ((report_size < 20 * blank_size)); then
  echo "the report's screenshot looks blank" >&2
  exit 1
fi
