#!/usr/bin/env bash
# Quick start, command 2: install what is missing, build, and run the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "${ISOWRENCH_JOBS:-2}"
