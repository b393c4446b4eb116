#!/usr/bin/env bash
# Formats ecmor's C++ sources with clang-format 14 (Debian 12) and the repository's .clang-format
# (Google base, 100 columns): the files git tracks under core/, interop/, strategies/, plugins/,
# apps/, python/, tests/, bench/, fuzz/ and examples/.
# Usage: scripts/format.sh          reformat in place
#        scripts/format.sh --check  change nothing; list the files that differ, exit 1 if any
# The check runs as the test `format_check` (label unit); the build target `format` applies it.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=apply
if [ "${1:-}" = "--check" ]; then mode=check; fi
tool=${CLANG_FORMAT:-clang-format-14}
if ! command -v "$tool" >/dev/null 2>&1; then
  echo "format: $tool not found (bash scripts/setup.sh installs clang-format-14)" >&2
  exit 2
fi
folders=(core interop strategies plugins apps python tests bench fuzz examples)
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  specs=()  # git pathspecs (quoted: the shell must not expand them)
  for d in "${folders[@]}"; do specs+=("$d/*.cpp" "$d/*.hpp"); done
  mapfile -t files < <(git ls-files -- "${specs[@]}")
else
  # An exported tree (no git, or no .git): every source in the same folders.
  mapfile -t files < <(find "${folders[@]}" -type f \( -name '*.cpp' -o -name '*.hpp' \) | sort)
fi
if [ ${#files[@]} -eq 0 ]; then
  echo "format: no C++ sources found under ${folders[*]}" >&2
  exit 2
fi
if [ "$mode" = apply ]; then
  "$tool" -i --style=file "${files[@]}"
  exit 0
fi
differ=()
for f in "${files[@]}"; do
  if ! "$tool" --dry-run --Werror --style=file "$f" >/dev/null 2>&1; then differ+=("$f"); fi
done
if [ ${#differ[@]} -gt 0 ]; then
  echo "format: ${#differ[@]} of ${#files[@]} files are not formatted (run bash scripts/format.sh):" >&2
  printf '  %s\n' "${differ[@]}" >&2
  exit 1
fi
echo "format: all ${#files[@]} files formatted"
