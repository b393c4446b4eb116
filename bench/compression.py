#!/usr/bin/env python3
"""The compression of accepted models (compress: true, the default) on every shipped config, off and on.

    python3 bench/compression.py [--ecmor build/bin/ecmor] [CONFIG...]   (default: configs/*.yaml)

Runs each configuration twice with the CLI, in one session: with `compress: false` and with
`compress: true` appended, each into a temporary output directory. Prints a Markdown
table: order, band error (the reported, full-model checked one), seconds and factorisations of both
runs, what the compression did, and the ratio of its seconds to the run's.
"""
import argparse
import glob
import json
import os
import pathlib
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parents[1]


def run(ecmor, config, out):
    subprocess.run([ecmor, "reduce", str(config), "-o", str(out), "--quiet", "--no-plot"],
                   cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
    path = out / "summary.json"
    return json.loads(path.read_text()) if path.exists() else None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ecmor", default=str(ROOT / "build" / "bin" / "ecmor"))
    parser.add_argument("configs", nargs="*")
    args = parser.parse_args()
    configs = args.configs or sorted(glob.glob(str(ROOT / "configs" / "*.yaml")))
    print("| config | reducer / strategy | order off -> on | band error off / on | tolerance | "
          "seconds off / on (compression) | factorisations off / on | compression |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for config in configs:
            name = pathlib.Path(config).stem
            text = pathlib.Path(config).read_text()
            if "\ncompress:" in text:
                continue
            on_config = tmp / f"{name}.yaml"
            on_config.write_text(text + "\ncompress: true\n")
            off_config = tmp / f"{name}.off.yaml"
            off_config.write_text(text + "\ncompress: false\n")
            off = run(args.ecmor, off_config, tmp / f"{name}.off")
            on = run(args.ecmor, on_config, tmp / f"{name}.on")
            if off is None or on is None or not off.get("has_model") or not on.get("has_model"):
                print(f"| {name} | | no model | | | | | |")
                continue
            c = on.get("compression", {})
            what = c.get("note", "")
            print(f"| {name} | {off['reducer']} / {off['strategy']} | {off['final_order']} -> "
                  f"{on['final_order']} | {off['band_error']:.2e} / {on['band_error']:.2e} | "
                  f"{off['tolerance']:g} | {off['seconds']['total']:.2f} / "
                  f"{on['seconds']['total']:.2f} ({c.get('seconds', 0.0):.2f}) | "
                  f"{off['counters']['factorizations']} / {on['counters']['factorizations']} "
                  f"({c.get('factorizations', 0)}) | {what} |", flush=True)


if __name__ == "__main__":
    main()
