#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz, clang + ASan/UBSan) in ./build-fuzz and runs each for a
# bounded time from its seed corpus, PLANECELL_JOBS targets at a time. Fails when a target crashes,
# leaks, times out on an input or runs out of memory; the reproducer is left in
# build-fuzz/findings/<target>/.
# Env: PLANECELL_FUZZ_SECONDS (per target, default 20), PLANECELL_FUZZ_TARGETS (space-separated
#      subset, default all), PLANECELL_FUZZ_BUILD_DIR (default build-fuzz), PLANECELL_JOBS,
#      PLANECELL_FUZZ_SEED (libFuzzer -seed, default 1: CI replays the same mutation sequence, so a
#      red run is reproducible; set 0 for a random seed when hunting locally).
# Reproduce a finding: build-fuzz/tests/fuzz/fuzz_<target> build-fuzz/findings/<target>/crash-*
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
BUILD_DIR=${PLANECELL_FUZZ_BUILD_DIR:-build-fuzz}
SECONDS_EACH=${PLANECELL_FUZZ_SECONDS:-20}
SEED=${PLANECELL_FUZZ_SEED:-1}
JOBS=${PLANECELL_JOBS:-$(nproc)}
TARGETS=${PLANECELL_FUZZ_TARGETS:-"pfm kitti_disparity_png kitti_text euroc config planecell_codec map_store lcm extraction_cache"}
CXX_BIN=${PLANECELL_FUZZ_CXX:-$(command -v clang++-14 || command -v clang++)}
LAUNCHER=()
if command -v ccache >/dev/null 2>&1; then LAUNCHER=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi

source scripts/generator.sh && planecell_generator "$BUILD_DIR"
cmake -S . -B "$BUILD_DIR" "${PLANECELL_GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1" \
  -DCMAKE_CXX_COMPILER="$CXX_BIN" -DPLANECELL_FUZZ=ON -DPLANECELL_BUILD_TESTS=OFF \
  -DPLANECELL_BUILD_BENCHMARKS=OFF "${LAUNCHER[@]}" >/dev/null
SECONDS=0
cmake --build "$BUILD_DIR" -j "$JOBS" --target planecell_fuzz
echo "[fuzz] build took ${SECONDS}s"

BIN="$BUILD_DIR/tests/fuzz"
SEEDS="$BUILD_DIR/seeds"
"$BIN/fuzz_make_seeds" "$SEEDS"
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$ROOT/tests/sanitizers/ubsan.supp"
export LSAN_OPTIONS="suppressions=$ROOT/tests/sanitizers/lsan.supp:print_suppressions=0"
# One target: runs it, prints its stats line, or its log's tail and returns 1 on a finding.
fuzz_one() {
  local target=$1
  local work="$BUILD_DIR/corpus/$target"          # grows across runs (libFuzzer writes new inputs here)
  local findings="$BUILD_DIR/findings/$target"
  mkdir -p "$work" "$findings" "$SEEDS/$target"
  local committed="tests/fuzz/corpus/$target"
  [ -d "$committed" ] || committed=""
  # -rss_limit_mb/-malloc_limit_mb: a reader that allocates > 1 GiB for a tiny input is a finding
  # (resource limits are checked before allocating). -timeout: one input taking > 10 s is a hang.
  if ! "$BIN/fuzz_$target" -max_total_time="$SECONDS_EACH" -seed="$SEED" -timeout=10 -rss_limit_mb=2048 \
      -malloc_limit_mb=1024 -max_len=65536 -print_final_stats=1 -artifact_prefix="$findings/" \
      "$work" "$SEEDS/$target" $committed > "$BUILD_DIR/fuzz_$target.log" 2>&1; then
    echo "[fuzz] $target FAILED: see $BUILD_DIR/fuzz_$target.log and $findings/" >&2
    tail -40 "$BUILD_DIR/fuzz_$target.log" >&2
    return 1
  fi
  grep -E "stat::number_of_executed_units|stat::new_units_added" "$BUILD_DIR/fuzz_$target.log" |
    tr '\n' ' ' | sed "s/^/[fuzz] $target: /"; echo
}

# The targets run $JOBS at a time (each fuzzer is single-threaded): same seed and time per target.
echo "[fuzz] $(echo $TARGETS | wc -w) targets, ${SECONDS_EACH}s each, $JOBS at a time"
status=0
running=0
for target in $TARGETS; do
  if [ "$running" -ge "$JOBS" ]; then
    wait -n || status=1
    running=$((running - 1))
  fi
  fuzz_one "$target" &
  running=$((running + 1))
done
while [ "$running" -gt 0 ]; do
  wait -n || status=1
  running=$((running - 1))
done
exit $status
