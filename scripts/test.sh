#!/usr/bin/env bash
# Fresh machine → green tests: installs dependencies if missing, builds, runs the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
SECONDS=0
./scripts/build.sh
echo "[test] build took ${SECONDS}s"
BUILD_DIR=${PLANECELL_BUILD_DIR:-build}
./scripts/lcm-route.sh  # LCM tests need a multicast route (skip without one)
SECONDS=0
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 600
echo "[test] tests took ${SECONDS}s"
# Reliability checks (docs/RELIABILITY.md): the suite under ASan+UBSan+LSan, then libFuzzer on
# every reader, ThreadSanitizer on the pipeline. PLANECELL_SKIP_SANITIZERS=1 skips all three (quick
# local runs); PLANECELL_SKIP_FUZZ=1 only the fuzzing.
if [ "${PLANECELL_SKIP_SANITIZERS:-0}" != 1 ]; then
  SECONDS=0
  ./scripts/sanitize.sh
  echo "[test] sanitizer build + tests took ${SECONDS}s"
  SECONDS=0
  ./scripts/tsan.sh  # ThreadSanitizer on the threaded pipeline's test
  echo "[test] ThreadSanitizer build + pipeline test took ${SECONDS}s"
  if [ "${PLANECELL_SKIP_FUZZ:-0}" != 1 ]; then
    SECONDS=0
    ./scripts/fuzz.sh
    echo "[test] fuzzing took ${SECONDS}s"
  fi
fi
