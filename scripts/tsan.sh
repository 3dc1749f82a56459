#!/usr/bin/env bash
# ThreadSanitizer run of the threaded pipeline's test: builds only services_test_pipeline with
# -fsanitize=thread (PLANECELL_SANITIZE=thread) in its own build directory and runs it.
# Usage: ./scripts/tsan.sh   (build dir: $PLANECELL_TSAN_BUILD_DIR, default build-tsan)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${PLANECELL_TSAN_BUILD_DIR:-build-tsan}
LAUNCHER=()
if command -v ccache >/dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi
# -O1 -g1 as in sanitize.sh: TSan needs optimisation off only for exact stacks, line tables suffice.
source scripts/generator.sh && planecell_generator "$BUILD_DIR"
cmake -S . -B "$BUILD_DIR" "${PLANECELL_GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" -DPLANECELL_SANITIZE=thread \
  -DPLANECELL_BUILD_BENCHMARKS=OFF "${LAUNCHER[@]}" >/dev/null
CCACHE_BASEDIR=${CCACHE_BASEDIR:-$PWD} cmake --build "$BUILD_DIR" -j "$(nproc)" --target services_test_pipeline
# halt_on_error: the first race fails the run; second_deadlock_stack: both stacks of a lock cycle.
TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$PWD/scripts/tsan.supp ${TSAN_OPTIONS:-}" \
  "$BUILD_DIR/tests/services_test_pipeline" --gtest_brief=1
