#!/usr/bin/env bash
# Fresh machine → green tests: installs dependencies if missing, builds, runs the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
SECONDS=0
./scripts/build.sh
echo "[test] build took ${SECONDS}s"
BUILD_DIR=${PLANECELL_BUILD_DIR:-build}
SECONDS=0
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$(nproc)" --timeout 600
echo "[test] tests took ${SECONDS}s"
