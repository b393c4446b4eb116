#!/usr/bin/env bash
# The compression after acceptance on the solid family (issue 51): clamped 3-D hexahedral solids of
# bench/solid.cpp (4 inputs, 6 outputs, Rayleigh damping), band 10-3000 Hz, tolerance 1e-3; each
# reducer / strategy pair with `compress: false` and `compress: true`. Writes OUT/solid_compression.md:
# per solid and pair the order, band error, seconds (of them the compression's) and full-model
# factorisations off and on, and per solid the smallest order any pair reached.
#
# Usage: bench/solid_compression.sh OUT [NXxNYxNZ ...]   (run from the project root, after a build)
# Default meshes: 40x4x3 (N = 2 400), 56x5x4 (5 040), 100x10x5 (19 800), 140x14x7 (50 400).
# Environment: ECMOR (default build/bin/ecmor), MODELS (default build/bin/ecmor_bench_models),
# METHODS (reducer:strategy pairs, default "modal:grow_order modal:mixed_basis krylov:greedy_points"),
# TOLERANCE (1e-3), F_MIN / F_MAX (10 / 3000 Hz), CPU_LIMIT per run in CPU seconds (default 1800).
set -euo pipefail
out=${1:?usage: bench/solid_compression.sh OUT [NXxNYxNZ ...]}
shift
[ $# -gt 0 ] || set -- 40x4x3 56x5x4 100x10x5 140x14x7
ecmor=${ECMOR:-build/bin/ecmor}
models=${MODELS:-build/bin/ecmor_bench_models}
methods=${METHODS:-"modal:grow_order modal:mixed_basis krylov:greedy_points"}
tol=${TOLERANCE:-1e-3}
mkdir -p "$out/models" "$out/configs" "$out/logs" "$out/runs"
for mesh in "$@"; do
  IFS=x read -r nx ny nz <<< "$mesh"
  dir="$out/models/solid_$mesh"
  [ -f "$dir/K.mtx" ] || [ -f "$dir/K.mtx.gz" ] || "$models" solid "$nx" "$ny" "$nz" "$dir" > /dev/null
  for method in $methods; do
    reducer=${method%%:*}
    strategy=${method##*:}
    for compress in false true; do
      name="solid_${mesh}_${reducer}_${strategy}_${compress}"
      cat > "$out/configs/$name.yaml" <<EOF
model:    {dir: $dir}
band:     {f_min_hz: ${F_MIN:-10}, f_max_hz: ${F_MAX:-3000}}
target:   {tolerance: $tol}
reducer:  {name: $reducer}
strategy: {name: $strategy, max_order: 300}
output:   {dir: $out/runs/$name}
compress: $compress
EOF
      rc=0
      ( ulimit -t "${CPU_LIMIT:-1800}"; exec "$ecmor" reduce "$out/configs/$name.yaml" --no-plot -q ) \
        > "$out/logs/$name.log" 2>&1 || rc=$?
      echo "$name: exit $rc"
    done
  done
done
python3 - "$out" "$methods" "$@" > "$out/solid_compression.md" <<'PY'
import json, sys
out, methods, meshes = sys.argv[1], sys.argv[2].split(), sys.argv[3:]

def load(name):
    try:
        with open(f"{out}/runs/{name}/summary.json") as f:
            return json.load(f)
    except (OSError, ValueError):
        return None

print("| solid (N) | reducer / strategy | order off -> on | band error off / on | seconds off / on "
      "(compression) | factorisations off / on (compression) | compression |")
print("|---|---|---|---|---|---|---|")
for mesh in meshes:
    smallest = None
    for method in methods:
        reducer, strategy = method.split(":")
        base = f"solid_{mesh}_{reducer}_{strategy}"
        off, on = load(base + "_false"), load(base + "_true")
        if off is None or on is None:
            print(f"| {mesh} | {reducer} / {strategy} | no summary (see logs) | | | | |")
            continue
        def order(s):
            return f"{s['final_order']}" + ("" if s.get("target_met") else " (missed)")
        c = on.get("compression", {})
        if on.get("target_met"):
            smallest = min(smallest or on["final_order"], on["final_order"])
        print(f"| {mesh} ({off['model']['N']}) | {reducer} / {strategy} | {order(off)} -> {order(on)} | "
              f"{off['band_error']:.2e} / {on['band_error']:.2e} | "
              f"{off['seconds']['total']:.1f} / {on['seconds']['total']:.1f} ({c.get('seconds', 0):.2f}) | "
              f"{off['counters']['factorizations']} / {on['counters']['factorizations']} "
              f"({c.get('factorizations', 0)}) | {c.get('note', '')} |")
    print(f"| {mesh} | smallest order met (compress on) | {smallest} | | | | |")
PY
cat "$out/solid_compression.md"
