#!/usr/bin/env bash
# Format the C++ sources with the repository's .clang-format (Google style, 100 columns).
#   bash scripts/format.sh              reformat every tracked .cpp/.hpp file in place
#   bash scripts/format.sh FILE...      reformat only these files
#   bash scripts/format.sh --check [FILE...]
#                                       change nothing; list the files clang-format would change
#                                       (with the number of differing lines) and exit 1 if any
# CLANG_FORMAT names the binary (default: clang-format, Debian 12: version 14).
set -euo pipefail
cd "$(dirname "$0")/.."
CLANG_FORMAT=${CLANG_FORMAT:-clang-format}
check=0
if [ "${1:-}" = "--check" ]; then check=1; shift; fi
if ! command -v "$CLANG_FORMAT" >/dev/null 2>&1; then
  echo "format.sh: $CLANG_FORMAT not found (Debian package clang-format)" >&2
  exit 1
fi
if [ $# -gt 0 ]; then
  files=("$@")
elif git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  mapfile -t files < <(git ls-files -- '*.cpp' '*.hpp' '*.h' '*.cc')
else
  mapfile -t files < <(find src include tests bench examples fuzz -name '*.cpp' -o -name '*.hpp' 2>/dev/null | sort)
fi

if [ "$check" = 0 ]; then
  [ ${#files[@]} -eq 0 ] || "$CLANG_FORMAT" -i --style=file "${files[@]}"
  exit 0
fi
differ=0
for f in "${files[@]}"; do
  [ -f "$f" ] || continue
  n=$("$CLANG_FORMAT" --style=file "$f" | diff "$f" - | grep -c '^[<>]' || true)
  if [ "$n" -gt 0 ]; then
    echo "format: $f: $n lines differ from .clang-format"
    differ=$((differ + 1))
  fi
done
if [ "$differ" -gt 0 ]; then
  echo "format: $differ of ${#files[@]} files need 'bash scripts/format.sh'"
  exit 1
fi
echo "format: all ${#files[@]} files match .clang-format"
