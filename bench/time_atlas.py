#!/usr/bin/env python3
"""The atlas of time (issue 46 item 4): every reducer x strategy pair, shipped models and solids.

    python3 bench/time_atlas.py [--ecmor build/bin/ecmor] [--models build/bin/ecmor_bench_models]
                                [--out out/time_atlas] [--cases SUB,SUB] [--meshes 40x4x3,56x5x4]
                                [--pairs krylov/greedy_points,...,portfolio] [--time-limit 600]
                                [--resume] [--list]

Cases: one per distinct (model, band, tolerance, norm) among configs/*.yaml (a portfolio config
gives its model, band and target, not its members; a case is named after its first config and
lists them all), then the clamped solids of bench/solid.cpp written by `ecmor_bench_models solid NX
NY NZ DIR` into OUT/models/ (band 10-3000 Hz, tolerance 1e-3, spectral). `--cases` keeps the cases
whose name, model or one of whose configs contains one of the comma-separated substrings;
`--meshes none` leaves the solids out.

Pairs (default): krylov/greedy_points, krylov/grow_order, modal/grow_order, modal/mixed_basis,
balanced/grow_order, irka/grow_order, and `portfolio` (`strategy: {name: portfolio}`, its default
members). Every run takes the case's model, band and target and the defaults of the reducer and
strategy, except `max_order` of grow_order: 300, or the largest one the case's grow_order configs
(portfolio members included) set when that is more; the portfolio's members keep their own
defaults; `compress` is left at its default. A pair the model cannot take is still run: ecmor's
refusal (exit 1, `ecmor: error: ...`) is its outcome.

Each run is `ecmor reduce OUT/configs/CASE__PAIR.yaml -o OUT/runs/CASE__PAIR --quiet --no-plot`
(log in OUT/logs/) from the project root, with `strategy.time_limit_s` = --time-limit, an
RLIMIT_CPU of --cpu-limit CPU seconds (default: cores x time limit + 60, the guard for a run that
does not honour the time limit) and a wall-clock guard at 1.5 x the time limit + 60 s (SIGTERM,
then SIGKILL 60 s later). The seconds are the process's wall time; order, band error (as reported,
checked against the full model), termination and message, full-model factorisations
(`counters.factorizations`) and peak memory come from RUNDIR/summary.json. The ratio is a run's
seconds over those of the fastest pair that met the case's target (over the fastest run when none
met it). A stop is *named* when the run met the target, ended `max_order_reached`,
`reducer_exhausted`, `stagnated` or `failed`, or was refused with an error message; a run ended by
the time limit, a signal or a resource limit is not.

OUT/time_atlas.md (a table per case, then the worst ratio per case and whether any is above 10x)
and OUT/time_atlas.json (every row) are rewritten after every run. `--resume` keeps the rows of
OUT/time_atlas.json that were measured with the same time limit and runs only the others (give it
the same selection: the files are rewritten with the selected cases only). Runs
take the machine's cores; run nothing else beside a full atlas (several hours with the default
time limit).
"""
import argparse
import datetime
import glob
import json
import os
import pathlib
import platform
import resource
import shutil
import signal
import subprocess
import sys
import threading
import time

import yaml

ROOT = pathlib.Path(__file__).resolve().parents[1]
DEFAULT_PAIRS = ["krylov/greedy_points", "krylov/grow_order", "modal/grow_order", "modal/mixed_basis",
                 "balanced/grow_order", "irka/grow_order", "portfolio"]
DEFAULT_MESHES = ["40x4x3", "56x5x4"]
SOLID_BAND = (10.0, 3000.0)
SOLID_TOLERANCE = 1e-3
GROW_ORDER_MAX = 300
NAMED_STOPS = {"converged", "max_order_reached", "reducer_exhausted", "stagnated", "failed"}
RATIO_LIMIT = 10.0


def emit(value):
    """A YAML 1.2 flow value (ecmor's parser): plain keys, JSON strings, shortest round-trip floats."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {emit(v)}" for k, v in value.items()) + "}"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    return json.dumps(str(value))


def absolute_model(model):
    out = {}
    for key, value in model.items():
        out[key] = str((ROOT / value).resolve()) if key in ("dir", "file") else value
    return out


def max_orders(strategy):
    """Every grow_order max_order a config's strategy section sets (a portfolio's members included)."""
    if strategy is None:
        strategy = {}
    found = []
    if strategy.get("name", "grow_order") == "grow_order" and "max_order" in strategy:
        found.append(int(float(strategy["max_order"])))
    for member in strategy.get("members") or []:
        found += max_orders((member or {}).get("strategy"))
    return found


def config_cases():
    cases = {}
    for path in sorted(glob.glob(str(ROOT / "configs" / "*.yaml"))):
        cfg = yaml.safe_load(pathlib.Path(path).read_text())
        model = absolute_model(cfg["model"])
        band = (float(cfg["band"]["f_min_hz"]), float(cfg["band"]["f_max_hz"]))
        target = cfg["target"]
        tolerance = float(target["tolerance"])
        norm = target.get("norm", "spectral")
        key = (json.dumps(model, sort_keys=True), band, tolerance, norm)
        stem = pathlib.Path(path).stem
        if key not in cases:
            name = pathlib.Path(model.get("dir") or model.get("file")).name
            cases[key] = {"case": stem, "model_name": name, "model": model, "band": band,
                          "tolerance": tolerance, "norm": norm, "configs": [], "max_order": GROW_ORDER_MAX}
        case = cases[key]
        case["configs"].append(stem)
        case["max_order"] = max([case["max_order"]] + max_orders(cfg.get("strategy")))
    return list(cases.values())


def solid_cases(out, meshes):
    cases = []
    for mesh in meshes:
        directory = out / "models" / f"solid_{mesh}"
        cases.append({"case": f"solid_{mesh}", "model_name": f"solid_{mesh}", "mesh": mesh,
                      "model": {"dir": str(directory.resolve())}, "band": SOLID_BAND,
                      "tolerance": SOLID_TOLERANCE, "norm": "spectral", "configs": [],
                      "max_order": GROW_ORDER_MAX})
    return cases


def make_solid(models_exe, case):
    directory = pathlib.Path(case["model"]["dir"])
    if (directory / "K.mtx").exists() or (directory / "K.mtx.gz").exists():
        return
    nx, ny, nz = case["mesh"].split("x")
    directory.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([models_exe, "solid", nx, ny, nz, str(directory)], cwd=ROOT, check=True,
                   stdout=subprocess.DEVNULL)


def selected(case, filters):
    if not filters:
        return True
    names = [case["case"], case["model_name"]] + case["configs"]
    return any(f in name for f in filters for name in names)


def config_text(case, pair, time_limit, rundir):
    lines = [f"# time_atlas: case {case['case']}, pair {pair}",
             f"model:    {emit(case['model'])}",
             f"band:     {emit({'f_min_hz': case['band'][0], 'f_max_hz': case['band'][1]})}",
             f"target:   {emit({'tolerance': case['tolerance'], 'norm': case['norm']})}"]
    if pair == "portfolio":
        lines.append(f"strategy: {emit({'name': 'portfolio', 'time_limit_s': float(time_limit)})}")
    else:
        reducer, strategy = pair.split("/")
        params = {"name": strategy}
        if strategy == "grow_order":
            params["max_order"] = case["max_order"]
        params["time_limit_s"] = float(time_limit)
        lines.append(f"reducer:  {emit({'name': reducer})}")
        lines.append(f"strategy: {emit(params)}")
    lines.append(f"output:   {emit({'dir': str(rundir)})}")
    return "\n".join(lines) + "\n"


def run_ecmor(ecmor, config, rundir, log, time_limit, cpu_limit):
    """Runs one reduction; returns (exit code or -signal, wall seconds, cpu seconds, maxrss MiB, guard)."""
    def limit_cpu():
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_limit, cpu_limit + 10))

    guard = []

    def stop(sig):
        guard.append(signal.Signals(sig).name)
        try:
            os.kill(proc.pid, sig)
        except ProcessLookupError:
            pass

    with open(log, "w") as log_file:
        start = time.monotonic()
        proc = subprocess.Popen([ecmor, "reduce", str(config), "-o", str(rundir), "--quiet", "--no-plot"],
                                cwd=ROOT, stdout=log_file, stderr=subprocess.STDOUT, preexec_fn=limit_cpu)
        wall_guard = 1.5 * time_limit + 60
        timers = [threading.Timer(wall_guard, stop, (signal.SIGTERM,)),
                  threading.Timer(wall_guard + 60, stop, (signal.SIGKILL,))]
        for timer in timers:
            timer.start()
        _, status, usage = os.wait4(proc.pid, 0)
        seconds = time.monotonic() - start
        for timer in timers:
            timer.cancel()
    proc.returncode = os.waitstatus_to_exitcode(status)
    return (proc.returncode, seconds, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0,
            guard[0] if guard else None)


def error_line(log):
    try:
        lines = pathlib.Path(log).read_text(errors="replace").splitlines()
    except OSError:
        return ""
    for line in lines:
        if "error:" in line:
            return line.split("error:", 1)[1].strip()
    return lines[-1].strip() if lines else ""


def short(text, width=80):
    text = " ".join(str(text).split())
    return text if len(text) <= width else text[:width - 3] + "..."


def make_row(case, pair, rc, seconds, cpu, maxrss, guard, rundir, log, time_limit, cpu_limit):
    row = {"case": case["case"], "model": case["model_name"], "pair": pair, "exit_code": rc,
           "seconds": seconds, "cpu_seconds": cpu, "peak_memory_mb": maxrss, "time_limit_s": time_limit,
           "cpu_limit_s": cpu_limit, "load_before": case.get("_load"), "run_dir": str(rundir),
           "log": str(log), "summary": False}
    path = rundir / "summary.json"
    summary = None
    if path.exists():
        try:
            summary = json.loads(path.read_text())
        except ValueError:
            summary = None
    if summary is not None:
        counters = summary.get("counters", {})
        row.update(summary=True, termination=summary.get("termination"), message=summary.get("message", ""),
                   target_met=bool(summary.get("target_met")), has_model=bool(summary.get("has_model")),
                   order=summary.get("final_order") if summary.get("has_model") else None,
                   band_error=summary.get("band_error") if summary.get("has_model") else None,
                   verified_band_error=summary.get("verified_band_error"),
                   ecmor_seconds=summary.get("seconds", {}).get("total"),
                   reducer_seconds=summary.get("seconds", {}).get("reducer"),
                   factorizations=counters.get("factorizations"), solves=counters.get("solves"),
                   full_evaluations=summary.get("full_evaluations"),
                   peak_memory_mb=summary.get("peak_memory_mb", maxrss),
                   model_kind=summary.get("model", {}).get("kind"), N=summary.get("model", {}).get("N"),
                   iterations=summary.get("iterations"))
        if "portfolio" in summary:
            p = summary["portfolio"]
            row["winner"] = p.get("winner")
            row["members"] = [{k: m.get(k) for k in ("reducer", "strategy", "termination", "order",
                                                     "band_error", "seconds", "target_met", "message")}
                              for m in p.get("members", [])]
        termination = row["termination"]
        if row["target_met"]:
            row["outcome"] = "met" + (f" ({row['winner']})" if row.get("winner") else "")
            row["named"] = True
        else:
            row["outcome"] = f"{termination}: {short(row['message'])}"
            row["named"] = termination in NAMED_STOPS and "time limit" not in row["message"]
    elif rc == 1:
        row.update(termination="error", message=error_line(log), target_met=False, has_model=False,
                   order=None, band_error=None, factorizations=None)
        row["outcome"] = f"error: {short(row['message'])}"
        row["named"] = bool(row["message"])
    else:
        reason = (f"signal {signal.Signals(-rc).name}" if rc < 0 else f"exit {rc}")
        if guard:
            reason += f" (wall guard {guard})"
        elif rc == -signal.SIGXCPU or rc == -signal.SIGKILL:
            reason += f" (CPU limit {cpu_limit} s)"
        row.update(termination="killed", message=reason + "; " + error_line(log), target_met=False,
                   has_model=False, order=None, band_error=None, factorizations=None)
        row["outcome"] = f"killed: {short(reason)}"
        row["named"] = False
    return row


def model_facts(case):
    """N and kind when no run wrote a summary: the model's info.json, or the solid's formula."""
    if "mesh" in case:
        nx, ny, nz = (int(x) for x in case["mesh"].split("x"))
        return {"N": 3 * nx * (ny + 1) * (nz + 1), "model_kind": "second order"}
    try:
        info = json.loads((pathlib.Path(case["model"]["dir"]) / "info.json").read_text())
        return {"N": info.get("N"), "model_kind": {"first": "descriptor", "second": "second order"}
                .get(info.get("kind"), info.get("kind"))}
    except (KeyError, OSError, ValueError):
        return {}


def baseline(rows):
    """(seconds, pair, met) of the fastest pair that met the target, else of the fastest run."""
    met = [r for r in rows if r.get("target_met")]
    pool = met or [r for r in rows if r.get("seconds") is not None]
    if not pool:
        return None
    best = min(pool, key=lambda r: r["seconds"])
    return best["seconds"], best["pair"], bool(met)


def fmt(value, spec, empty="-"):
    return empty if value is None else format(value, spec)


def render(cases, rows, args, started, header):
    by_case = {}
    for row in rows:
        by_case.setdefault(row["case"], []).append(row)
    out = [f"# Atlas of time ({started})", "",
           f"`{header['command']}`", "",
           f"{header['version']} (`{header['ecmor']}`), {header['machine']}, load average "
           f"{header['load']} at the start; time limit {args.time_limit:g} s "
           f"(`strategy.time_limit_s`), CPU limit {header['cpu_limit']} s per run. "
           "Seconds are wall time of the `ecmor reduce` process on a machine that may be shared; "
           "factorisations (full model, the whole run) and orders are exact. Ratio: seconds over "
           "those of the fastest pair that met the target in the same case (marked `*` when none "
           "met it: over the fastest run). \"named\": the run met the target or stopped with a named "
           "reason (not the time limit, a signal or a resource limit).", ""]
    worst = []
    for case in cases:
        crows = by_case.get(case["case"])
        if not crows:
            continue
        first = next((r for r in crows if r.get("N")), None) or model_facts(case)
        configs = ", ".join(case["configs"]) or f"`ecmor_bench_models solid {' '.join(case['mesh'].split('x'))}`"
        out += [f"### {case['case']}", "",
                f"Model {case['model_name']} ({first.get('model_kind', '?')}, N = {first.get('N', '?')}), "
                f"band {case['band'][0]:g}-{case['band'][1]:g} Hz, tolerance {case['tolerance']:g} "
                f"({case['norm']}), grow_order max_order {case['max_order']}; configs: {configs}.", "",
                "| pair | outcome | order | band error | seconds | ratio | factorisations | peak MiB | named |",
                "|---|---|---|---|---|---|---|---|---|"]
        base = baseline(crows)
        for r in crows:
            ratio = None if base is None or base[0] <= 0 else r["seconds"] / base[0]
            r["ratio"] = ratio
            mark = "" if base is None or base[2] else "*"
            outcome = r["outcome"].replace("|", "\\|")
            out.append(f"| {r['pair']} | {outcome} | {fmt(r.get('order'), 'd')} | "
                       f"{fmt(r.get('band_error'), '.2e')} | {r['seconds']:.2f} | "
                       f"{fmt(ratio, '.1f')}{mark} | {fmt(r.get('factorizations'), 'd')} | "
                       f"{fmt(r.get('peak_memory_mb'), '.0f')} | {'yes' if r.get('named') else '**no**'} |")
        out.append("")
        if base is not None:
            top = max(crows, key=lambda r: r["ratio"] or 0.0)
            unnamed = [r["pair"] for r in crows if not r.get("named")]
            worst.append((case["case"], base, top, unnamed))
    if worst:
        out += ["## Worst ratio per case", "",
                "| case | fastest pair (met) | seconds | slowest pair | its outcome | ratio | > 10x | not named |",
                "|---|---|---|---|---|---|---|---|"]
        above = []
        for name, base, top, unnamed in worst:
            over = (top["ratio"] or 0.0) > RATIO_LIMIT
            if over:
                above.append(f"{name} ({top['pair']}, {top['ratio']:.1f}x)")
            outcome = short(top["outcome"], 40).replace("|", "\\|")
            out.append(f"| {name} | {base[1]}{'' if base[2] else ' (none met)'} | {base[0]:.2f} | "
                       f"{top['pair']} | {outcome} | {fmt(top['ratio'], '.1f')} | "
                       f"{'**yes**' if over else 'no'} | {', '.join(unnamed) or '-'} |")
        out.append("")
        unnamed_all = sum(len(w[3]) for w in worst)
        out.append(f"**Summary:** {len(worst)} cases, {len(rows)} runs; "
                   + (f"{len(above)} case(s) with a pair above {RATIO_LIMIT:g}x the fastest: "
                      + "; ".join(above) if above else f"no pair above {RATIO_LIMIT:g}x the fastest")
                   + f"; {unnamed_all} run(s) without a named stop.")
        out.append("")
    return "\n".join(out)


def write_atomic(path, text):
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ecmor", default=str(ROOT / "build" / "bin" / "ecmor"))
    parser.add_argument("--models", default=str(ROOT / "build" / "bin" / "ecmor_bench_models"),
                        help="the ecmor_bench_models executable (writes the solids)")
    parser.add_argument("--out", default=str(ROOT / "out" / "time_atlas"))
    parser.add_argument("--cases", default="", help="comma-separated substrings of case, model or config names")
    parser.add_argument("--meshes", default=",".join(DEFAULT_MESHES),
                        help="solid meshes NXxNYxNZ, comma-separated, or 'none'")
    parser.add_argument("--pairs", default=",".join(DEFAULT_PAIRS),
                        help="reducer/strategy pairs and 'portfolio', comma-separated")
    parser.add_argument("--time-limit", type=float, default=600.0, help="strategy.time_limit_s per run")
    parser.add_argument("--cpu-limit", type=int, default=None,
                        help="RLIMIT_CPU per run in CPU seconds (default cores x time limit + 60)")
    parser.add_argument("--resume", action="store_true", help="keep the rows of OUT/time_atlas.json")
    parser.add_argument("--list", action="store_true", help="print the cases and pairs, run nothing")
    args = parser.parse_args()

    out = pathlib.Path(args.out).resolve()
    filters = [f for f in args.cases.split(",") if f]
    meshes = [] if args.meshes in ("", "none") else args.meshes.split(",")
    pairs = [p for p in args.pairs.split(",") if p]
    for pair in pairs:
        if pair != "portfolio" and pair.count("/") != 1:
            parser.error(f"pair '{pair}': expected reducer/strategy or portfolio")
    cpu_limit = args.cpu_limit or int((os.cpu_count() or 1) * args.time_limit + 60)
    cases = [c for c in config_cases() + solid_cases(out, meshes) if selected(c, filters)]
    if not cases:
        parser.error("no case selected")
    if args.list:
        for c in cases:
            print(f"{c['case']}: {c['model_name']} {c['band'][0]:g}-{c['band'][1]:g} Hz "
                  f"{c['tolerance']:g} {c['norm']}, max_order {c['max_order']}; configs {', '.join(c['configs'])}")
        print(f"{len(cases)} cases x {len(pairs)} pairs = {len(cases) * len(pairs)} runs")
        return
    for sub in ("configs", "runs", "logs"):
        (out / sub).mkdir(parents=True, exist_ok=True)

    version = subprocess.run([args.ecmor, "--version"], capture_output=True, text=True,
                             check=True).stdout.strip()
    header = {"command": "python3 bench/time_atlas.py " + " ".join(sys.argv[1:]), "version": version,
              "ecmor": args.ecmor, "cpu_limit": cpu_limit,
              "machine": f"{platform.node()} ({os.cpu_count()} cores, {platform.machine()})",
              "load": " / ".join(f"{x:.2f}" for x in os.getloadavg())}
    started = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
    json_path, md_path = out / "time_atlas.json", out / "time_atlas.md"
    kept = {}
    if args.resume and json_path.exists():
        for row in json.loads(json_path.read_text()).get("rows", []):
            if row.get("time_limit_s") == args.time_limit:
                kept[(row["case"], row["pair"])] = row

    rows = []
    total, k = len(cases) * len(pairs), 0
    for case in cases:
        if "mesh" in case:
            make_solid(args.models, case)
        for pair in pairs:
            k += 1
            if (case["case"], pair) in kept:
                rows.append(kept[(case["case"], pair)])
                print(f"[{k}/{total}] {case['case']} {pair}: kept from {json_path.name}", flush=True)
                continue
            name = f"{case['case']}__{pair.replace('/', '_')}"
            config, rundir, log = out / "configs" / f"{name}.yaml", out / "runs" / name, out / "logs" / f"{name}.log"
            shutil.rmtree(rundir, ignore_errors=True)
            config.write_text(config_text(case, pair, args.time_limit, rundir))
            case["_load"] = os.getloadavg()[0]
            rc, seconds, cpu, maxrss, guard = run_ecmor(args.ecmor, config, rundir, log, args.time_limit, cpu_limit)
            row = make_row(case, pair, rc, seconds, cpu, maxrss, guard, rundir, log, args.time_limit, cpu_limit)
            rows.append(row)
            print(f"[{k}/{total}] {case['case']} {pair}: {short(row['outcome'], 90)}, order "
                  f"{fmt(row.get('order'), 'd')}, error {fmt(row.get('band_error'), '.2e')}, "
                  f"{seconds:.2f} s", flush=True)
            text = render(cases, rows, args, started, header)
            write_atomic(md_path, text)
            write_atomic(json_path, json.dumps({"header": header, "started": started,
                                                "time_limit_s": args.time_limit, "rows": rows}, indent=1))
    text = render(cases, rows, args, started, header)
    write_atomic(md_path, text)
    write_atomic(json_path, json.dumps({"header": header, "started": started,
                                        "time_limit_s": args.time_limit, "rows": rows}, indent=1))
    print(f"\n{md_path}\n{json_path}")


if __name__ == "__main__":
    main()
