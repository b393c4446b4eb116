#!/usr/bin/env python3
"""What the Python module costs against the CLI, on one model, in one session.

    PYTHONPATH=build/lib/python3.11/dist-packages python3 bench/python_overhead.py [n1] [--repeat R]

The triple chain of examples/python (alpha = beta = 0.002, v = 5: triplechain_mess_n1501's
parameters) with N = 3 n1 + 1 (default n1 = 33333: N = 100 000), band 1e-4..0.01 rad/s, krylov /
greedy_points, tolerance 1e-3, one thread. The model is written once as a model directory; then,
alternating R times, each in a fresh process:
  cli     build/bin/ecmor reduce CONFIG --no-plot (reads the files, writes its outputs)
  python  ecmor.SecondOrder(...) from the SciPy matrices, then ecmor.reduce(...) (writes nothing)
  python, output.dir   the same, writing the CLI's files as it goes (the like-for-like run)
and prints per run: wall time of the whole process, the run's own seconds (summary.json
seconds.total), time outside it, peak resident memory (ru_maxrss), order and band error.
"""
import argparse
import gzip
import json
import os
import pathlib
import resource
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
F_MAX_RAD_S = 0.01  # band 1e-4..0.01 rad/s: the lowest resonances (krylov: order 16)
sys.path.insert(0, str(ROOT / "examples" / "python"))

PY_RUN = r"""
import json, resource, sys, time
sys.path.insert(0, sys.argv[1])
t0 = time.perf_counter()
import ecmor, numpy, scipy.sparse
from triple_chain import triple_chain
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
M, D, K, B, C = triple_chain(int(sys.argv[2]), alpha=0.002, beta=0.002)
t1 = time.perf_counter()
model = ecmor.SecondOrder(M, D, K, B, C)
t2 = time.perf_counter()
F_MAX_RAD_S = float(sys.argv[3])
extra = {"output": {"dir": sys.argv[4]}} if len(sys.argv) > 4 else {}
r = ecmor.reduce(model, band=(1e-4 / 6.283185307179586, F_MAX_RAD_S / 6.283185307179586),
                 tol=1e-3, reducer="krylov", strategy="greedy_points", solver={"threads": 1},
                 **extra)
t3 = time.perf_counter()
print(json.dumps({"generate": t1 - t0, "construct": t2 - t1, "reduce": t3 - t2,
                  "run": r.summary["seconds"]["total"], "order": r.order,
                  "band_error": r.band_error, "interpreter_mb": base,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def write_model(directory, n1):
    import scipy.io
    from triple_chain import triple_chain
    M, D, K, B, C = triple_chain(n1, alpha=0.002, beta=0.002)
    for name, m in (("M", M), ("D", D), ("K", K), ("B", B), ("C", C)):
        with gzip.open(directory / f"{name}.mtx.gz", "wb", compresslevel=1) as f:
            scipy.io.mmwrite(f, m, precision=17)
    return M.nnz + D.nnz + K.nnz


def child_peak_mb():
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n1", type=int, nargs="?", default=33333)
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--ecmor", default=str(ROOT / "build" / "bin" / "ecmor"))
    args = parser.parse_args()
    N = 3 * args.n1 + 1
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "model").mkdir()
        nnz = write_model(tmp / "model", args.n1)
        config = tmp / "run.yaml"
        config.write_text(
            f"model: {{dir: {tmp / 'model'}}}\n"
            f"band: {{f_min_hz: {1e-4 / 6.283185307179586!r}, "
            f"f_max_hz: {F_MAX_RAD_S / 6.283185307179586!r}}}\n"
            "target: {tolerance: 1.0e-3}\nreducer: {name: krylov}\n"
            "strategy: {name: greedy_points}\nsolver: {threads: 1}\n"
            f"output: {{dir: {tmp / 'out'}}}\n")
        env = dict(os.environ, OMP_NUM_THREADS="1")
        print(f"triple chain N = {N}, nnz(M, D, K) = {nnz}; one copy of M, D, K in ecmor: "
              f"{nnz * 12 / 2**20:.1f} MiB (+ B, C: {2 * N * 8 / 2**20:.1f} MiB)")
        # What each kind of process holds before any model: the CLI listing its plugins, and the
        # interpreter with numpy, scipy and ecmor imported (peak resident memory, fresh processes).
        probe = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], "
                 "stdout=subprocess.DEVNULL); "
                 "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024)")
        cli_base = float(subprocess.run([sys.executable, "-c", probe, args.ecmor, "plugins"],
                                        env=env, capture_output=True, text=True).stdout)
        py_base = float(subprocess.run(
            [sys.executable, "-c", probe, sys.executable, "-c",
             "import numpy, scipy.sparse, ecmor"], env=env, capture_output=True, text=True).stdout)
        print(f"process baselines (peak MiB before any model): cli {cli_base:.0f}, python with "
              f"numpy, scipy and ecmor {py_base:.0f}")
        print("| run | process wall [s] | run seconds (summary) | outside the run [s] | "
              "peak MiB | order | band error |")
        print("|---|---|---|---|---|---|---|")
        for k in range(args.repeat):
            # The CLI: a fresh process; its peak is the only child's so far, so run it first.
            start = time.perf_counter()
            subprocess.run([args.ecmor, "reduce", str(config), "--no-plot", "--quiet"], env=env,
                           check=False, stdout=subprocess.DEVNULL)
            wall = time.perf_counter() - start
            s = json.loads((tmp / "out" / "summary.json").read_text())
            print(f"| cli {k + 1} | {wall:.2f} | {s['seconds']['total']:.2f} | "
                  f"{wall - s['seconds']['total']:.2f} | {s['peak_memory_mb']:.0f} "
                  f"({s['peak_memory_mb'] - cli_base:.0f} above the baseline) | "
                  f"{s['final_order']} | {s['band_error']:.3e} |")
            for label, extra in (("python", []), ("python, output.dir", [str(tmp / "out_py")])):
                start = time.perf_counter()
                out = subprocess.run([sys.executable, "-c", PY_RUN,
                                      str(ROOT / "examples" / "python"), str(args.n1),
                                      repr(F_MAX_RAD_S)] + extra,
                                     env=env, check=True, capture_output=True, text=True).stdout
                wall = time.perf_counter() - start
                p = json.loads(out)
                outside = p["construct"] + p["reduce"] - p["run"]
                print(f"| {label} {k + 1} | {wall:.2f} (generate {p['generate']:.2f}, construct "
                      f"{p['construct']:.2f}, reduce {p['reduce']:.2f}) | {p['run']:.2f} | "
                      f"{outside:.2f} (construct + reduce - run) | {p['peak_mb']:.0f} "
                      f"({p['peak_mb'] - py_base:.0f} above the baseline) | "
                      f"{p['order']} | {p['band_error']:.3e} |")

if __name__ == "__main__":
    main()
