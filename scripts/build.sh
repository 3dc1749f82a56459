#!/usr/bin/env bash
# Configures and builds planecell (Release) into ./build. Extra arguments go to CMake's configure.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${PLANECELL_BUILD_DIR:-build}
JOBS=${PLANECELL_JOBS:-$(nproc)}
source scripts/generator.sh && planecell_generator "$BUILD_DIR"
cmake -S . -B "$BUILD_DIR" "${PLANECELL_GENERATOR[@]}" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
