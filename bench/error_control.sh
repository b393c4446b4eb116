#!/usr/bin/env bash
# Error control before and after the estimator (docs/benchmarks.md, "Error control"): every given
# configuration reduced twice in one session, with error.verify: dense (a full-model solve per
# sample, the method before the estimator) and error.verify: estimate, and a Markdown table of
# order, band error, factorisations (all / inside the reducer / full-model responses for the
# error) and wall time, with the time ratio.
#
# Usage: bench/error_control.sh OUT_DIR CONFIG...       (run from the project root, after a build)
# Environment: ECMOR (default build/bin/ecmor), TIMEOUT per run in seconds (default 1800).
set -euo pipefail
out=${1:?usage: bench/error_control.sh OUT_DIR CONFIG...}
shift
ecmor=${ECMOR:-build/bin/ecmor}
mkdir -p "$out/configs"
table="$out/error_control.md"
{
  echo "| config | N | order dense / estimate | band error dense / estimate | factorisations dense (reducer, error) | factorisations estimate (reducer, error) | time dense s | time estimate s | time ratio |"
  echo "|---|---|---|---|---|---|---|---|---|"
} > "$table"
for config in "$@"; do
  name=$(basename "$config" .yaml)
  for mode in dense estimate; do
    # A config may pin the mode in a one-line `error: {verify: X}`; that line is replaced. Any
    # other error section would mix settings into the comparison, so it is refused.
    if grep -q '^error:' "$config" && ! grep -Eq '^error: *\{ *verify: *[a-z]+ *\} *$' "$config"; then
      echo "error_control.sh: $config has an error section other than {verify: X}" >&2
      exit 1
    fi
    grep -Ev '^error: *\{ *verify: *[a-z]+ *\} *$' "$config" > "$out/configs/${name}_$mode.yaml"
    echo "error: {verify: $mode}" >> "$out/configs/${name}_$mode.yaml"
    rc=0
    timeout "${TIMEOUT:-1800}" "$ecmor" reduce "$out/configs/${name}_$mode.yaml" -o "$out/$mode/$name" \
      --no-plot -q > "$out/$mode.$name.log" 2>&1 || rc=$?
    echo "$name $mode: exit $rc"
  done
  python3 - "$out" "$name" >> "$table" <<'PY'
import json, sys
out, name = sys.argv[1:]
def load(mode):
    try:
        with open(f"{out}/{mode}/{name}/summary.json") as f:
            return json.load(f)
    except OSError:
        return None
runs = [load("dense"), load("estimate")]
def pair(fmt):
    return " / ".join(fmt(j) if j else "-" for j in runs)
def facts(j):
    if not j:
        return "-"
    return (f"{j['counters']['factorizations']} ({j['reducer_counters']['factorizations']}, "
            f"{j['full_evaluations']})")
d, e = runs
n = next((j["model"]["N"] for j in runs if j), "-")
ratio = f"{d['seconds']['total'] / e['seconds']['total']:.1f}x" if d and e else "-"
secs = lambda j: format(j["seconds"]["total"], ".2f") if j else "-"
order = pair(lambda j: str(j["final_order"]))
error = pair(lambda j: format(j["band_error"], ".2e"))
print(f"| {name} | {n} | {order} | {error} | {facts(d)} | {facts(e)} | {secs(d)} | {secs(e)} "
      f"| {ratio} |")
PY
done
cat "$table"
