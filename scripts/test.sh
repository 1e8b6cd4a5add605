#!/usr/bin/env bash
# Quick start, command 2: install what is missing, build, and run the whole test suite; then
# build the suite again with address + undefined-behaviour sanitizers (build-asan, no
# benchmarks) and run it there too. ISOWRENCH_SANITIZE=0 skips the sanitizer pass.
# The sanitizer build leaves out the AVX2 clones of the fast path, so the first pass tests the
# code AVX2 machines run and the second the baseline x86-64 code older CPUs run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
JOBS=${ISOWRENCH_JOBS:-2}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"

if [ "${ISOWRENCH_SANITIZE:-1}" != "0" ]; then
  ASAN_DIR=${ISOWRENCH_ASAN_BUILD_DIR:-build-asan}
  echo "isowrench: sanitizer pass (address + undefined) in $ASAN_DIR"
  cmake -S . -B "$ASAN_DIR" -DCMAKE_BUILD_TYPE=Release -DISOWRENCH_SANITIZE=ON \
        -DISOWRENCH_BUILD_BENCHMARKS=OFF -DISOWRENCH_SIMD_CLONES=OFF >/dev/null
  cmake --build "$ASAN_DIR" -j "$JOBS"
  # Any sanitizer report fails the test that triggered it.
  export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:halt_on_error=1:detect_leaks=1:strict_string_checks=1}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
  ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS"
fi
