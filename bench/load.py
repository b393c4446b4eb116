#!/usr/bin/env python3
"""ecmor on a busy machine: every shipped config idle and beside CPU load, and the ratio.

    python3 bench/load.py [--ecmor build/bin/ecmor] [--before OTHER_ECMOR] [--busy 2]
                          [--repeat 3] [--repeat-below 2] [CONFIG...]   (default: configs/*.yaml)

For each configuration, in one session: one run on the idle machine, then one run beside BUSY
single-threaded busy loops (`sh -c 'while :; do :; done'`, started before the run and killed after
it). Both with the environment this script was started with, so a variable such as OMP_NUM_THREADS
or ECMOR_THREADS given to it applies to both runs. With --before, a second executable (an earlier
build, copied with its lib/ folder) is timed the same way, config by config, its runs interleaved
with the others' so that both see the same machine: the table then holds both, and the idle time's
change.

A config whose first idle run took less than --repeat-below seconds is timed --repeat times idle
and loaded, and the fastest of each counts: at a tenth of a second, the start-up of one process and
the scheduler's time slices are noise of the same size. Prints a Markdown table (wall seconds idle
and loaded, the ratio, the orders: the load must not change the result much) and at the end the
median and the largest ratio per executable.

The machine must be otherwise idle when this starts: the script reports the load average it found.
"""
import argparse
import glob
import json
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def run(ecmor, config, out):
    """Wall seconds of one `ecmor reduce`, its exit code and its summary (None if it wrote none)."""
    start = time.monotonic()
    rc = subprocess.run([ecmor, "reduce", str(config), "-o", str(out), "--quiet", "--no-plot"],
                        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                        check=False).returncode
    seconds = time.monotonic() - start
    path = out / "summary.json"
    return seconds, rc, (json.loads(path.read_text()) if path.exists() else None)


class BusyLoops:
    """N single-threaded busy loops for the lifetime of the `with` block."""

    def __init__(self, n):
        self.n = n
        self.procs = []

    def __enter__(self):
        self.procs = [subprocess.Popen(["sh", "-c", "while :; do :; done"])
                      for _ in range(self.n)]
        time.sleep(0.2)  # let the scheduler see them before ecmor starts
        return self

    def __exit__(self, *exc):
        for p in self.procs:
            p.kill()
        for p in self.procs:
            p.wait()


def fastest(results):
    return min(results, key=lambda r: r[0])


def order(summary):
    return str(summary["final_order"]) if summary and summary.get("has_model") else "-"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ecmor", default=str(ROOT / "build" / "bin" / "ecmor"))
    parser.add_argument("--before", help="an earlier ecmor executable, timed alongside")
    parser.add_argument("--busy", type=int, default=2, help="busy loops beside the loaded run")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs per timing of a short config (the fastest counts)")
    parser.add_argument("--repeat-below", type=float, default=2.0,
                        help="a config is short when its first idle run takes less (seconds)")
    parser.add_argument("configs", nargs="*")
    args = parser.parse_args()
    if args.busy < 1 or args.repeat < 1:
        sys.exit("load.py: --busy and --repeat must be at least 1")
    executables = [("after", args.ecmor)] + ([("before", args.before)] if args.before else [])
    for _, exe in executables:
        if not os.access(exe, os.X_OK):
            sys.exit(f"load.py: {exe}: not an executable")
    configs = args.configs or sorted(glob.glob(str(ROOT / "configs" / "*.yaml")))
    load = pathlib.Path("/proc/loadavg").read_text().split()[:3]
    threads = {k: os.environ[k] for k in ("OMP_NUM_THREADS", "OMP_WAIT_POLICY", "ECMOR_THREADS",
                                          "OPENBLAS_NUM_THREADS") if k in os.environ}
    print(f"ecmor: {' / '.join(f'{label} {exe}' for label, exe in executables)}; "
          f"{os.cpu_count()} CPUs; load average at start {' '.join(load)}; {args.busy} busy loops; "
          f"environment {threads or 'as is'}\n")
    if args.before:
        print("| config | idle s before / after | idle change | loaded s before / after | "
              "ratio before | ratio after | order idle / loaded (before; after) |")
        print("|---|---|---|---|---|---|---|")
    else:
        print("| config | idle s | loaded s | ratio | order idle / loaded | exit idle / loaded |")
        print("|---|---|---|---|---|---|")
    ratios = {label: [] for label, _ in executables}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for config in configs:
            config = pathlib.Path(config).resolve()
            name = config.stem
            out = lambda label, kind, i: tmp / f"{name}.{label}.{kind}.{i}"
            idle = {label: [run(exe, config, out(label, "idle", 0))] for label, exe in executables}
            short = max(r[0][0] for r in idle.values()) < args.repeat_below
            repeat = args.repeat if short else 1
            for i in range(1, repeat):
                for label, exe in executables:
                    idle[label].append(run(exe, config, out(label, "idle", i)))
            loaded = {label: [] for label, _ in executables}
            for i in range(repeat):
                for label, exe in executables:
                    with BusyLoops(args.busy):
                        loaded[label].append(run(exe, config, out(label, "loaded", i)))
            best = {label: (fastest(idle[label]), fastest(loaded[label])) for label in idle}
            for label, (i, l) in best.items():
                ratios[label].append((l[0] / i[0], name))
            if args.before:
                (ib, lb), (ia, la) = best["before"], best["after"]
                print(f"| {name} | {ib[0]:.2f} / {ia[0]:.2f} | {100 * (ia[0] / ib[0] - 1):+.0f} % | "
                      f"{lb[0]:.2f} / {la[0]:.2f} | {lb[0] / ib[0]:.2f} | {la[0] / ia[0]:.2f} | "
                      f"{order(ib[2])} / {order(lb[2])}; {order(ia[2])} / {order(la[2])} |",
                      flush=True)
            else:
                i, l = best["after"]
                print(f"| {name} | {i[0]:.2f} | {l[0]:.2f} | {l[0] / i[0]:.2f} | "
                      f"{order(i[2])} / {order(l[2])} | {i[1]} / {l[1]} |", flush=True)
    print()
    for label, values in ratios.items():
        if values:
            worst = max(values)
            print(f"{label}: median ratio {statistics.median(r for r, _ in values):.2f}, "
                  f"largest {worst[0]:.2f} ({worst[1]}), {len(values)} configs")


if __name__ == "__main__":
    main()
