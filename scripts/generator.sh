#!/usr/bin/env bash
# Sourced by the build scripts. planecell_generator BUILD_DIR sets the array PLANECELL_GENERATOR to
# the CMake generator arguments for BUILD_DIR: Ninja (schedules the 2-core CI build better than
# make) for a new build directory when ninja is installed, nothing for an existing one (CMake
# refuses to switch the generator of a configured directory).
planecell_generator() {
  PLANECELL_GENERATOR=()
  if [ ! -f "$1/CMakeCache.txt" ] && command -v ninja >/dev/null 2>&1; then
    PLANECELL_GENERATOR=(-G Ninja)
  fi
}
