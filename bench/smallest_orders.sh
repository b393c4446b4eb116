#!/usr/bin/env bash
# The smallest order each bundled reducer reaches on every benchmark model (docs/benchmarks.md,
# "Smallest order per benchmark model"): for each model of models/, on the band of its
# reference response (info.json, omega_min..omega_max converted to Hz), each tolerance is asked of
# modal (grow_order), krylov (greedy_points), balanced (grow_order) and irka (grow_order).
# Writes OUT_DIR/smallest_orders.md: per model and tolerance the smallest order that met it and
# which reducer reached it, then every run (order or termination, and wall seconds).
#
# Usage: bench/smallest_orders.sh OUT_DIR [MODEL...]   (run from the project root, after a build)
# Environment: ECMOR (default build/bin/ecmor), CPU_LIMIT per run in CPU seconds (default 300),
# TOLERANCES (default "1e-2 1e-3"), METHODS (reducer:strategy pairs, default the four above, e.g.
# "modal:grow_order modal:mixed_basis"), REDUCER_OPTIONS (", key: value" pairs for every reducer).
set -euo pipefail
out=${1:?usage: bench/smallest_orders.sh OUT_DIR [MODEL...]}
shift
ecmor=${ECMOR:-build/bin/ecmor}
models_dir=models
if [ $# -eq 0 ]; then
  set -- $(cd "$models_dir" && for d in */; do [ -f "$d/info.json" ] && echo "${d%/}"; done)
fi
methods=${METHODS:-"modal:grow_order krylov:greedy_points balanced:grow_order irka:grow_order"}
mkdir -p "$out/configs" "$out/logs"
for model in "$@"; do
  band=$(python3 -c "
import json, math
r = json.load(open('$models_dir/$model/info.json'))['reference']
print(r['omega_min'] / (2 * math.pi), r['omega_max'] / (2 * math.pi))")
  read -r f_min f_max <<< "$band"
  for tol in ${TOLERANCES:-1e-2 1e-3}; do
    for method in $methods; do
      reducer=${method%%:*}
      strategy=${method##*:}
      name="${model}_${reducer}_${strategy}_${tol}"
      cat > "$out/configs/$name.yaml" <<EOF
model:    {dir: $models_dir/$model}
band:     {f_min_hz: $f_min, f_max_hz: $f_max}
target:   {tolerance: $tol}
reducer:  {name: $reducer${REDUCER_OPTIONS:-}}
strategy: {name: $strategy}
output:   {dir: $out/runs/$name}
EOF
      rc=0
      start=$(date +%s.%N)
      # A CPU-time limit, not a wall-clock one: the table must not depend on the machine's load.
      ( ulimit -t "${CPU_LIMIT:-300}"; exec "$ecmor" reduce "$out/configs/$name.yaml" --no-plot -q ) \
        > "$out/logs/$name.log" 2>&1 || rc=$?
      echo "$name: exit $rc ($(python3 -c "print(f'{$(date +%s.%N) - $start:.1f}')") s)"
      echo "$rc" > "$out/logs/$name.rc"
    done
  done
done
python3 - "$out" "${TOLERANCES:-1e-2 1e-3}" "$methods" "$@" > "$out/smallest_orders.md" <<'PY'
import json, sys
out, tols, methods, models = sys.argv[1], sys.argv[2].split(), sys.argv[3].split(), sys.argv[4:]
reducers = [m.replace(":", "/") for m in methods]

def run(model, reducer, tol):
    name = f"{model}_{reducer.replace('/', '_')}_{tol}"
    try:
        with open(f"{out}/runs/{name}/summary.json") as f:
            return json.load(f)
    except OSError:
        rc = open(f"{out}/logs/{name}.rc").read().strip()
        log = open(f"{out}/logs/{name}.log").read().strip().splitlines()
        return {"rc": rc, "log": log[-1] if log else ""}

def cell(j):
    if "rc" in j:
        return "CPU limit" if j["rc"] in ("137", "152") else f"error (exit {j['rc']})"
    cpu = j["seconds"]["total"]
    if j.get("target_met"):
        return f"**{j['final_order']}** ({cpu:.1f} s)"
    return f"{j['termination']} ({j['final_order']}, {j['band_error']:.1e}; {cpu:.1f} s)"

print("| model | N | band Hz | " + " | ".join(f"smallest for {t}" for t in tols) + " | " +
      " | ".join(f"{r} {t}" for t in tols for r in reducers) + " |")
print("|---|---|---|" + "---|" * len(tols) + "---|" * (len(tols) * len(reducers)))
for model in models:
    info = json.load(open(f"models/{model}/info.json"))
    ref = info["reference"]
    import math
    band = f"{ref['omega_min'] / (2 * math.pi):.3g}..{ref['omega_max'] / (2 * math.pi):.3g}"
    runs = {(r, t): run(model, r, t) for t in tols for r in reducers}
    best = []
    for t in tols:
        met = [(j["final_order"], r) for (r, tt), j in runs.items()
               if tt == t and "rc" not in j and j.get("target_met")]
        smallest = min((o for o, _ in met), default=None)
        who = ", ".join(r for r in reducers if (smallest, r) in met)
        best.append(f"{smallest} ({who})" if met else "none")
    cells = [cell(runs[(r, t)]) for t in tols for r in reducers]
    print(f"| {model} | {info['N']} | {band} | " + " | ".join(best) + " | " + " | ".join(cells) + " |")
PY
cat "$out/smallest_orders.md"
