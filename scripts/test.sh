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
# debug info builds in about 7 minutes on 2 cores; sanitizer reports still name lines.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=None -DCMAKE_CXX_FLAGS="-O1 -g1" -DOBSGAIN_SANITIZE=ON \
  -DOBSGAIN_BUILD_BENCHMARKS=OFF -DOBSGAIN_BUILD_PYTHON=OFF -DOBSGAIN_WITH_MPI=OFF >/dev/null
cmake --build build-asan -j"$jobs"
# Left to the plain pass: what repeats, at length, code that runs sanitised in shorter tests. The 1000-trial Monte
# Carlo (45 s sanitised), the browser screenshot (Chromium's time, not obsgain's), the dense grids (the three-joint
# bracket convergence, the vertex reduction, the URDF arm's grid, the six- and seven-joint grid of 4ⁿ vertices and
# patterns per point: a minute or more each; the six- and seven-joint brackets themselves run sanitised), the
# determinism runs (1 and 2 threads, twice: two minutes; the same branch and bound runs sanitised on 2 threads in the
# bracket tests), the progress reports and the resumed searches and race (the same branch and bound), the three-joint
# URDF's design and validation (the same app paths run sanitised on the one-joint URDF, the chain dynamics of 3, 6
# and 7 joints against KDL), and the polytopic apps, the polytopic deployment and the polytopic shape search (a
# minute or more each; the polytope, both SDP objectives and the interval check run sanitised in their unit tests),
# the three-joint polytopic proof at half the norm-bound gain (ten minutes sanitised, eleven seconds plain; the search
# and 255 of its proof's boxes run sanitised in AProofPastItsBudgetStopsAtTheSameBoxOnOneCoreAndOnTwo), and the
# three-joint polytopic design by search with its Monte Carlo (the same search and proof), the report's curve from that search and its fall-back past --proof-budget (the
# same search), the six- and seven-joint designs with the scaled certificate named (the same app paths as the
# Pendubot's scaled designs, with another threshold for keeping T), and the seven-joint numeric design whose optimisers
# disagree (150 s sanitised, 9 s plain; the numeric search runs sanitised in TheNumericSearchIsTheSameOnOneCoreAndOnTwo,
# the warnings' path in the apps' other design tests).
plain_only=(installed_package_consumer docs_commands_run_as_written CertifiedDesignPasses1000Trials
  report_screenshot_not_blank ThreeJointArmBracketsContainTheGrid VertexReductionAgainstDenseGrid
  BoundsOfTheThreeJointArmAgainstAGrid SixAndSevenJointArmBracketsContainTheDenseGrid
  TheSameJsonForAnyThreadCountAndOnEveryRun LongSearchesReportProgress ResumedSearchesEndAs ResumedRaceEndsAs
  DesignAndValidateAThreeJointArm
  PolytopicApps APolytopicPChosenForTheFloor PolytopicShapeSearch Arm3DesignIsCertifiedAndHoldsInMonteCarlo
  ThreeJointPolytopicCurveIsTheDesignsSearch APolytopicProofPastItsBudgetFallsBackAndNamesTheBudget
  ProvesArm3AtHalfTheNormBoundGain
  ANamedScaledCertificateKeepsAnySimilarityThatLowersLJoint OptimisersThatDisagreeAreAWarningOnNumericBoundsOnly)
ctest --test-dir build-asan --output-on-failure -j"$jobs" -E "$(IFS='|'; echo "${plain_only[*]}")"

if [[ -x ../shared/contract-check ]]; then
  ../shared/contract-check build
else
  echo "test.sh: ../shared/contract-check is not beside this checkout: the command-line contract was not checked" >&2
fi
