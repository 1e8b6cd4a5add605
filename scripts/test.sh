#!/usr/bin/env bash
# Quick start, command 2 (CI runs exactly this): install what is missing, then
#   pass 1: g++, Release, -Werror, in ./build: the whole test suite (benchmarks not built);
#   pass 2: clang++, -O1 with assert() live (no NDEBUG), address + undefined-behaviour
#           sanitizers, -Werror, in ./build-asan: the whole test suite again, plus each libFuzzer
#           harness (fuzz/) for ISOWRENCH_FUZZ_SECONDS (default 5) on its seed corpus.
#   first:  scripts/format.sh --check: every C++ file must match .clang-format (fails the run
#           otherwise; ISOWRENCH_FORMAT_STRICT=0 only reports).
# ISOWRENCH_SANITIZE=0 skips pass 2. Compilers: ISOWRENCH_CXX (g++), ISOWRENCH_SANITIZE_CXX
# (clang++). The sanitizer build leaves out the AVX2 clones of the fast path, so pass 1 tests the
# code AVX2 machines run and pass 2 the baseline x86-64 code older CPUs run.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
JOBS=${ISOWRENCH_JOBS:-2}
# Ninja when it is installed (a new build tree only; an existing one keeps its generator): it
# compiles a target's sources while the libraries it links are still building, so both cores
# stay busy (docs/performance.md "Build time"). CMAKE_GENERATOR set by the caller wins.
if [ -z "${CMAKE_GENERATOR:-}" ] && command -v ninja >/dev/null 2>&1; then export CMAKE_GENERATOR=Ninja; fi

if [ "${ISOWRENCH_FORMAT_STRICT:-1}" = "1" ]; then
  bash scripts/format.sh --check
else
  bash scripts/format.sh --check || echo "isowrench: formatting differs (reported only; ISOWRENCH_FORMAT_STRICT=0)"
fi

BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
echo "isowrench: pass 1 (${ISOWRENCH_CXX:-g++}, Release, -Werror) in $BUILD_DIR"
cmake -S . -B "$BUILD_DIR" -DCMAKE_CXX_COMPILER="${ISOWRENCH_CXX:-g++}" -DCMAKE_BUILD_TYPE=Release \
      -DISOWRENCH_WERROR=ON -DISOWRENCH_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build "$BUILD_DIR" -j "$JOBS"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS"
# Python module (docs/python.md): pytest against $BUILD_DIR/python with the interpreter it was built for.
[ ! -d "$BUILD_DIR/python/isowrench" ] || PYTHONPATH="$BUILD_DIR/python" ISOWRENCH_CLI="$BUILD_DIR/isowrench" "$(sed -n 's/^_\{0,1\}Python3_EXECUTABLE:[A-Z]*=//p' "$BUILD_DIR/CMakeCache.txt" | head -1)" -m pytest -q python/tests

if [ "${ISOWRENCH_SANITIZE:-1}" != "0" ]; then
  ASAN_DIR=${ISOWRENCH_ASAN_BUILD_DIR:-build-asan}
  echo "isowrench: pass 2 (${ISOWRENCH_SANITIZE_CXX:-clang++}, -O1, asserts, address + undefined) in $ASAN_DIR"
  # Build type "Debug" only to drop NDEBUG; -O1 keeps the suite fast, -g1 gives line numbers.
  cmake -S . -B "$ASAN_DIR" -DCMAKE_CXX_COMPILER="${ISOWRENCH_SANITIZE_CXX:-clang++}" \
        -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O1 -g1" -DISOWRENCH_WERROR=ON \
        -DISOWRENCH_SANITIZE=ON -DISOWRENCH_BUILD_BENCHMARKS=OFF -DISOWRENCH_SIMD_CLONES=OFF \
        -DISOWRENCH_FUZZ_SMOKE=ON "-DISOWRENCH_FUZZ_SMOKE_SECONDS=${ISOWRENCH_FUZZ_SECONDS:-5}" >/dev/null
  cmake --build "$ASAN_DIR" -j "$JOBS"
  # Any sanitizer report fails the test that triggered it.
  export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=0:halt_on_error=1:detect_leaks=1:strict_string_checks=1}
  export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
  ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS"
fi
