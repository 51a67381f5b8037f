#!/usr/bin/env bash
# One command: install what is missing, build, run the test suite, run it again under
# AddressSanitizer + UndefinedBehaviorSanitizer, and check the command-line contract.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc)
scripts/install-deps.sh --with-browser
scripts/build.sh
ctest --test-dir build --output-on-failure -j"$jobs"

# Sanitizers: the library and tests only (the installed-package test links a plain consumer, the docs'
# commands are checked once, with the plain build, the Python module loads into an interpreter that is not
# sanitised, and OpenMPI's own allocations are not obsgain's to answer for). -O1 without
# debug info builds in about 4 of the suite's 10 minutes on 2 cores; sanitizer reports still name lines.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O1 -g1" -DOBSGAIN_SANITIZE=ON \
  -DOBSGAIN_BUILD_BENCHMARKS=OFF -DOBSGAIN_BUILD_PYTHON=OFF -DOBSGAIN_WITH_MPI=OFF >/dev/null
cmake --build build-asan -j"$jobs"
# Also left to the plain pass: the 1000-trial Monte Carlo (the same code as the shorter ones, 45 s sanitised),
# the browser screenshot (Chromium's time, not obsgain's), the three-joint bracket convergence (50 s sanitised;
# the six-joint bracket test runs the same branch and bound under the sanitizers), the dense vertex grid, and the
# polytopic apps, the polytopic deployment and the polytopic shape search (a minute or more each sanitised; the
# polytope, both SDP objectives and the interval check run sanitised in their unit tests), and
# the resumed searches (30 s sanitised; the same branch and bound runs sanitised in the other bracket tests).
ctest --test-dir build-asan --output-on-failure -j"$jobs" \
  -E "installed_package_consumer|docs_commands_run_as_written|CertifiedDesignPasses1000Trials|report_screenshot_not_blank|ThreeJointArmBracketsContainTheGrid|VertexReductionAgainstDenseGrid|PolytopicApps|APolytopicPChosenForTheFloor|PolytopicShapeSearch|ResumedSearchesEndAs"

if [[ -x ../shared/contract-check ]]; then
  ../shared/contract-check build
else
  echo "test.sh: ../shared/contract-check is not beside this checkout: the command-line contract was not checked" >&2
fi
