#!/usr/bin/env bash
# Configure and build isowrench (library, CLI, tests, benchmarks) in ./build with 2 jobs.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
JOBS=${ISOWRENCH_JOBS:-2}
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=${CMAKE_BUILD_TYPE:-Release} "$@" >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
