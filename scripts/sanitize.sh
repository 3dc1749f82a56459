#!/usr/bin/env bash
# Builds the test suite with AddressSanitizer + UndefinedBehaviorSanitizer (LeakSanitizer on) in
# ./build-asan and runs ctest on it. Any finding fails the run (-fno-sanitize-recover, halt_on_error).
# Env: PLANECELL_ASAN_BUILD_DIR (default build-asan), PLANECELL_JOBS (default nproc),
#      PLANECELL_ASAN_TESTS (ctest -R regex, default: every test).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD_DIR=${PLANECELL_ASAN_BUILD_DIR:-build-asan}
JOBS=${PLANECELL_JOBS:-$(nproc)}
LAUNCHER=()
if command -v ccache >/dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi

# -O1 -g1: sanitizer builds are for finding bugs, not speed; it keeps the compile and the run short
# (-g1 = line tables only: reports keep file:line, the compile is a third faster than with -g).
# Benchmarks are not built (they are not tests).
source scripts/generator.sh && planecell_generator "$BUILD_DIR"
cmake -S . -B "$BUILD_DIR" "${PLANECELL_GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
  -DPLANECELL_SANITIZE=address,undefined -DPLANECELL_BUILD_BENCHMARKS=OFF "${LAUNCHER[@]}" >/dev/null
SECONDS=0
cmake --build "$BUILD_DIR" -j "$JOBS"
echo "[sanitize] build took ${SECONDS}s"

SUPP="$ROOT/tests/sanitizers"
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:check_initialization_order=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$SUPP/ubsan.supp"
export LSAN_OPTIONS="suppressions=$SUPP/lsan.supp:print_suppressions=0"

SECONDS=0
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" --timeout 900 \
  ${PLANECELL_ASAN_TESTS:+-R "$PLANECELL_ASAN_TESTS"}
echo "[sanitize] tests took ${SECONDS}s"
