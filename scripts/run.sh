#!/usr/bin/env bash
# Quick start, command 1: install what is missing, build the library and the CLI (not the tests
# or benchmarks), and run the main job: the paper's Figure 2 wrench table (then Figures 3 and 4)
# computed on the shipped rat hindlimb.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh --target isowrench_cli
BUILD_DIR=${ISOWRENCH_BUILD_DIR:-build}
"$BUILD_DIR/isowrench" paper --figure 2
"$BUILD_DIR/isowrench" paper --figure 3
"$BUILD_DIR/isowrench" paper --figure 4
