#!/usr/bin/env bash
# Configure and build isowrench in ./build with 2 jobs.
#   bash scripts/build.sh                       library, CLI, tests and benchmarks
#   bash scripts/build.sh --target isowrench_cli   only the library and the CLI
# Extra arguments before an optional `--target ...` go to the configure step; CMAKE_BUILD_TYPE
# (default Release), ISOWRENCH_BUILD_DIR and ISOWRENCH_JOBS are read from the environment.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
JOBS=${ISOWRENCH_JOBS:-2}
# Ninja when it is installed (a new build tree only; an existing one keeps its generator): it
# compiles a target's sources while the libraries it links are still building, so both cores
# stay busy (docs/performance.md "Build time"). CMAKE_GENERATOR set by the caller wins.
if [ -z "${CMAKE_GENERATOR:-}" ] && command -v ninja >/dev/null 2>&1; then export CMAKE_GENERATOR=Ninja; fi
configure=()
build=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--target" ]; then build+=("$1" "$2"); shift 2; else configure+=("$1"); shift; fi
done
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} "${configure[@]}" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS" "${build[@]}"
