#!/bin/bash
# Build the libFuzzer harnesses (clang++-14, ASan + UBSan) and run each for N seconds
# (default 10) on a copy of the committed seed corpus, with the dictionary fuzz/<corpus>.dict.
# Exit non-zero on any crash, sanitizer report, ASan's "unexpected format specifier" warning
# (input text reached a printf format), leak (except urdfdom's own, fuzz/lsan.supp) or hang
# (-timeout=10 s per input).
#   scripts/fuzz.sh [seconds] [harness...]      harnesses: urdf_fuzzer trial_csv_fuzzer posture_fuzzer
#                                                osim_import_fuzzer
# Environment: FUZZ_BUILD (default build-fuzz), CXX (default clang++-14), FUZZ_RUNS (-runs=N
# instead of a time limit, for campaigns), FUZZ_JOBS (libFuzzer -jobs, default 1 = in process).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-10}
shift || true
harnesses=("$@")
[ ${#harnesses[@]} -eq 0 ] && harnesses=(urdf_fuzzer trial_csv_fuzzer posture_fuzzer osim_import_fuzzer)
build=${FUZZ_BUILD:-build-fuzz}
CXX=${CXX:-clang++-14}
if ! command -v "$CXX" >/dev/null; then
  echo "fuzz.sh: $CXX not found (Debian: apt-get install clang-14 libfuzzer-14-dev)" >&2
  exit 1
fi
CXX=$CXX cmake -S fuzz -B "$build" >/dev/null
cmake --build "$build" -j"${FUZZ_BUILD_JOBS:-2}" --target "${harnesses[@]}"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
export LSAN_OPTIONS="suppressions=$PWD/fuzz/lsan.supp:print_suppressions=0"
status=0
for h in "${harnesses[@]}"; do
  corpus_name=${h%_fuzzer}
  corpus_name=${corpus_name%_import}  # osim_import_fuzzer: fuzz/corpus/osim
  work="$build/corpus/$corpus_name"
  mkdir -p "$work" "$build/findings/$corpus_name"
  cp -n fuzz/corpus/"$corpus_name"/* "$work"/ 2>/dev/null || true
  limit=(-max_total_time="$seconds")
  [ -n "${FUZZ_RUNS:-}" ] && limit=(-runs="$FUZZ_RUNS")
  dict=()
  [ -f fuzz/"$corpus_name".dict ] && dict=(-dict=fuzz/"$corpus_name".dict)
  echo "== $h (${FUZZ_RUNS:+$FUZZ_RUNS runs}${FUZZ_RUNS:-$seconds s})"
  parallel=()
  [ "${FUZZ_JOBS:-1}" -gt 1 ] && parallel=(-jobs="$FUZZ_JOBS" -workers="$FUZZ_JOBS")
  if ! "$build/$h" "${limit[@]}" -timeout=10 -rss_limit_mb=2048 "${parallel[@]}" "${dict[@]}" \
      -artifact_prefix="$build/findings/$corpus_name/" -print_final_stats=1 "$work" fuzz/corpus/"$corpus_name" \
      2>&1 | tee "$build/$h.log" | grep -E "^(==|#[0-9]+ *DONE|stat::number_of_executed_units|stat::peak_rss_mb|SUMMARY|ERROR|INFO: a leak)" ; then
    :
  fi
  if grep -qE "ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|SUMMARY: UndefinedBehaviorSanitizer|Test unit written|unexpected format specifier" "$build/$h.log"; then
    echo "fuzz.sh: $h found a problem: see $build/$h.log and $build/findings/$corpus_name/" >&2
    status=1
  fi
done
exit $status
