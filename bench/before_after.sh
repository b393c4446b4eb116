#!/usr/bin/env bash
# Two builds of ecmor on the same configurations, alternately, in one session: the time, order,
# band error and factorisations of each run, and the ratio of the times (docs/benchmarks.md).
# The "before" build is any earlier commit built into its own tree, for example
#   git worktree add ../ecmor-before COMMIT && cmake -S ../ecmor-before -B ../ecmor-before/build \
#     -G Ninja -DCMAKE_BUILD_TYPE=Release -DECMOR_BUILD_TESTS=OFF -DECMOR_BUILD_BENCH=OFF && \
#   ninja -C ../ecmor-before/build
# An earlier build may not know configuration keys added since: lines starting with one of
# STRIP_KEYS (default "error:") are removed from its copy of each configuration.
#
# Usage: bench/before_after.sh BEFORE_ECMOR AFTER_ECMOR OUT_DIR CONFIG...   (from the project root)
# Environment: TIMEOUT per run in seconds (default 1800), STRIP_KEYS (space-separated prefixes).
set -euo pipefail
before=${1:?usage: bench/before_after.sh BEFORE_ECMOR AFTER_ECMOR OUT_DIR CONFIG...}
after=${2:?usage: bench/before_after.sh BEFORE_ECMOR AFTER_ECMOR OUT_DIR CONFIG...}
out=${3:?usage: bench/before_after.sh BEFORE_ECMOR AFTER_ECMOR OUT_DIR CONFIG...}
shift 3
for exe in "$before" "$after"; do
  [ -x "$exe" ] || { echo "before_after.sh: $exe is not an executable" >&2; exit 1; }
done
mkdir -p "$out/configs"
table="$out/before_after.md"
{
  echo "| config | N | order before / after | band error before / after | factorisations before / after | time before s | time after s | speed-up |"
  echo "|---|---|---|---|---|---|---|---|"
} > "$table"
strip_pattern=$(printf '%s\n' ${STRIP_KEYS:-error:} | sed 's/^/^/' | paste -sd'|')
for config in "$@"; do
  name=$(basename "$config" .yaml)
  grep -Ev "$strip_pattern" "$config" > "$out/configs/${name}_before.yaml"
  cp "$config" "$out/configs/${name}_after.yaml"
  for side in before after; do
    exe=$before
    [ "$side" = after ] && exe=$after
    rc=0
    timeout "${TIMEOUT:-1800}" "$exe" reduce "$out/configs/${name}_$side.yaml" -o "$out/$side/$name" \
      --no-plot -q > "$out/$side.$name.log" 2>&1 || rc=$?
    echo "$name $side: exit $rc"
  done
  python3 - "$out" "$name" >> "$table" <<'PY'
import json, sys
out, name = sys.argv[1:]
def load(side):
    try:
        with open(f"{out}/{side}/{name}/summary.json") as f:
            return json.load(f)
    except OSError:
        return None
b, a = load("before"), load("after")
def pair(fmt):
    return " / ".join(fmt(j) if j else "-" for j in (b, a))
n = next((j["model"]["N"] for j in (b, a) if j), "-")
secs = lambda j: format(j["seconds"]["total"], ".2f") if j else "-"
ratio = f"{b['seconds']['total'] / a['seconds']['total']:.1f}x" if b and a else "-"
print(f"| {name} | {n} | {pair(lambda j: str(j['final_order']))} "
      f"| {pair(lambda j: format(j['band_error'], '.2e'))} "
      f"| {pair(lambda j: str(j['counters']['factorizations']))} | {secs(b)} | {secs(a)} | {ratio} |")
PY
done
echo "table: $table"
