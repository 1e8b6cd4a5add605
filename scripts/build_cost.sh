#!/usr/bin/env bash
# The build cost of issue 16 as a machine-independent ratio:
#   CPU seconds (user + sys) of a fresh, ccache-disabled build of what scripts/run.sh builds
#   (configure + the library and the CLI, Release, -j2)
#   / CPU seconds of compiling scripts/build_cost_reference.cpp at -O2 (one function running
#   Eigen's JacobiSVD and SelfAdjointEigenSolver on a MatrixXd; median of 3 compiles).
# CPU time, not wall time: other jobs on the machine slow the wall clock, not the CPU count.
# Environment: CXX (default g++), ISOWRENCH_JOBS (2), ISOWRENCH_BUILD_COST_TARGET
# (isowrench_cli; "all" measures the whole build with tests). Takes minutes; prints 3 lines.
set -euo pipefail
cd "$(dirname "$0")/.."
CXX=${CXX:-g++}
JOBS=${ISOWRENCH_JOBS:-2}
TARGET=${ISOWRENCH_BUILD_COST_TARGET:-isowrench_cli}
WORK=$(mktemp -d "${TMPDIR:-/tmp}/isowrench-build-cost.XXXXXX")
trap 'rm -rf "$WORK"' EXIT
export CCACHE_DISABLE=1

# cpu_seconds CMD...: run CMD (output to $WORK/log), print its user + sys CPU seconds.
cpu_seconds() {
  local TIMEFORMAT='%3U %3S'
  { time "$@" >"$WORK/log" 2>&1; } 2>"$WORK/time" || { cat "$WORK/log" >&2; exit 1; }
  awk '{printf "%.1f", $1 + $2}' "$WORK/time"
}

eigen_cflags=$(pkg-config --cflags eigen3 2>/dev/null || echo "-I/usr/include/eigen3")
refs=()
for i in 1 2 3; do
  # shellcheck disable=SC2086
  refs+=("$(cpu_seconds "$CXX" -std=c++17 -O2 $eigen_cflags -c scripts/build_cost_reference.cpp -o "$WORK/reference.o")")
done
ref=$(printf '%s\n' "${refs[@]}" | sort -g | sed -n 2p)

configure=$(cpu_seconds cmake -S . -B "$WORK/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER="$CXX" \
             -DISOWRENCH_BUILD_BENCHMARKS=OFF)
build=$(cpu_seconds cmake --build "$WORK/build" -j "$JOBS" --target "$TARGET")

echo "reference: $ref s CPU (scripts/build_cost_reference.cpp at -O2, median of ${refs[*]})"
echo "build:     $(awk -v c="$configure" -v b="$build" 'BEGIN {printf "%.1f", c + b}') s CPU (configure $configure + build $build; $CXX, fresh folder, ccache off, -j$JOBS, target $TARGET)"
awk -v c="$configure" -v b="$build" -v r="$ref" 'BEGIN {printf "ratio:     %.1fx (target <= 20x)\n", (c + b) / r}'
