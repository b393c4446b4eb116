"""ecmor.reduce: the CLI's run from Python. Its results equal the CLI's, its reduced models are
checked against dense NumPy responses, and it behaves as a Python library (progress, errors,
the GIL, Ctrl-C)."""
import json
import os
import pathlib
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest
import yaml

from conftest import ROOT, dense_response, triple_chain

CONFIGS = ["triplechain_saak09_n451", "iss_greedy", "build_so_greedy"]


@pytest.mark.parametrize("name", CONFIGS)
def test_same_result_as_the_cli(ecmor, cli, tmp_path, name):
    config = ROOT / "configs" / f"{name}.yaml"
    subprocess.run([cli, "reduce", str(config), "-o", str(tmp_path / "cli"), "--quiet",
                    "--no-plot"], check=False, cwd=ROOT, capture_output=True)
    want = json.loads((tmp_path / "cli" / "summary.json").read_text())
    cfg = yaml.safe_load(config.read_text())
    cfg.pop("output")
    cfg["model"]["dir"] = str(ROOT / cfg["model"]["dir"])
    got = ecmor.reduce(cfg)
    assert got.order == want["final_order"]
    assert got.termination == want["termination"]
    for key in ("band_error", "verified_band_error"):
        assert got.summary[key] == pytest.approx(want[key], rel=1e-12, abs=0.0)
    # The in-memory model given directly, with the same configuration minus its model.
    model = ecmor.load(cfg.pop("model")["dir"])
    again = ecmor.reduce(model, cfg)
    assert again.order == want["final_order"]
    assert again.summary["band_error"] == pytest.approx(want["band_error"], rel=1e-12, abs=0.0)
    # save() writes what the CLI wrote: the same files, the same summary apart from timings.
    again.save(tmp_path / "py")
    cli_files = {p.name for p in (tmp_path / "cli").iterdir() if p.suffix in (".mtx", ".csv",
                                                                             ".jsonl", ".json")}
    py_files = {p.name for p in (tmp_path / "py").iterdir()}
    assert py_files == cli_files
    saved = json.loads((tmp_path / "py" / "summary.json").read_text())
    assert saved["final_order"] == want["final_order"]
    assert len((tmp_path / "py" / "history.jsonl").read_text().splitlines()) == len(again.history)


def test_keyword_form_meets_the_target_against_numpy(ecmor):
    M, D, K, B, C = triple_chain(60)
    model = ecmor.SecondOrder(M, D, K, B, C)
    rows = []
    result = ecmor.reduce(model, band=(1e-3, 0.1), tol=1e-3, reducer="krylov",
                          strategy="greedy_points", max_order=60, progress=rows.append)
    assert result.target_met and result.order <= 60
    rom = result.rom
    assert rom.kind == "second order" and rom.order == result.order
    assert result.V.shape == (model.N, result.order)
    # Independent check: dense NumPy responses of the full and the reduced model on a grid.
    f = np.logspace(-3, -1, 301)
    H = dense_response(M, D, K, B, C, f)
    Hr = np.array([rom.C @ np.linalg.solve((2j * np.pi * x) ** 2 * rom.M + 2j * np.pi * x * rom.D
                                           + rom.K, rom.B) for x in f])
    err = np.max(np.abs(H - Hr)[:, 0, 0] / np.abs(H)[:, 0, 0])
    assert err <= 1e-3 * 1.05, err
    # The progress callback saw every iteration once, each row as in the history.
    assert len(rows) == len(result.history) >= 1
    assert [r["iteration"] for r in rows] == list(range(1, len(rows) + 1))
    assert rows == result.history


def test_frequency_response_and_band_error_against_numpy(ecmor):
    M, D, K, B, C = triple_chain(20)
    model = ecmor.SecondOrder(M, D, K, B, C)
    f = np.logspace(-3, 0, 7)
    np.testing.assert_allclose(ecmor.frequency_response(model, f), dense_response(M, D, K, B, C, f),
                               rtol=1e-10)
    result = ecmor.reduce(model, band=(1e-3, 0.05), tol=1e-2, reducer="modal",
                          strategy="grow_order")
    e = ecmor.band_error(model, result, (1e-3, 0.05))
    H = dense_response(M, D, K, B, C, e["f_hz"])
    Hr = ecmor.frequency_response(result.rom, e["f_hz"])
    rel = np.abs(H - Hr)[:, 0, 0] / np.abs(H)[:, 0, 0]
    np.testing.assert_allclose(e["relative"], rel, rtol=1e-6)
    assert e["sup_relative"] == pytest.approx(rel.max(), rel=1e-6)
    assert e["sup_relative"] <= 1e-2


def test_options_are_checked_by_the_same_specs(ecmor):
    M, D, K, B, C = triple_chain(5)
    model = ecmor.SecondOrder(M, D, K, B, C)
    with pytest.raises(ecmor.Error, match=r"^ecmor.reduce: target.tolerance = -1: must be in"):
        ecmor.reduce(model, band=(1e-3, 0.1), tol=-1)
    with pytest.raises(ecmor.Error, match=r"unknown option 'max_ordr' \(did you mean 'max_order'"):
        ecmor.reduce(model, band=(1e-3, 0.1), max_ordr=5)
    with pytest.raises(ecmor.Error, match=r"band.f_max_hz = 0.001: must be > f_min_hz = 0.001"):
        ecmor.reduce(model, band=(1e-3, 1e-3))
    with pytest.raises(ecmor.Error, match=r"unknown key 'tolerence' in 'target'.*did you mean"):
        ecmor.reduce(model, {"band": {"f_min_hz": 1e-3, "f_max_hz": 0.1},
                             "target": {"tolerence": 1e-3}, "reducer": {"name": "modal"}})
    with pytest.raises(ecmor.Error, match=r"must not name one"):
        ecmor.reduce(model, {"model": {"dir": "x"}, "band": {"f_min_hz": 1e-3, "f_max_hz": 0.1},
                             "target": {"tolerance": 1e-3}, "reducer": {"name": "modal"}})
    with pytest.raises(ecmor.Error, match=r"reducer 'nosuch'"):
        ecmor.reduce(model, band=(1e-3, 0.1), reducer="nosuch")


def test_plugins_lists_the_bundled_reducers(ecmor):
    names = {p["name"] for p in ecmor.plugins()}
    assert {"modal", "krylov", "irka", "balanced"} <= names
    assert "greedy_points" in ecmor.strategies()


def test_the_gil_is_released_while_ecmor_computes(ecmor):
    M, D, K, B, C = triple_chain(1500)
    model = ecmor.SecondOrder(M, D, K, B, C)
    ticks = 0
    done = threading.Event()

    def run():
        ecmor.reduce(model, band=(1e-4, 1.0), tol=1e-10, reducer="krylov",
                     strategy="greedy_points", max_order=120)
        done.set()

    worker = threading.Thread(target=run)
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    # With the GIL held for the whole run the loop would tick only before and after it.
    assert elapsed > 0.2, "the run was too short to tell"
    assert ticks > 0.2 * elapsed / 0.001


def test_ctrl_c_gives_keyboard_interrupt_with_the_partial_history(tmp_path):
    script = textwrap.dedent(f"""
        import sys, json
        sys.path.insert(0, {str(ROOT / "tests" / "python")!r})
        import ecmor
        from conftest import triple_chain
        model = ecmor.SecondOrder(*triple_chain(1500))
        def progress(row):
            print("iteration", row["iteration"], flush=True)
        try:
            ecmor.reduce(model, band=(1e-4, 1.0), tol=1e-14, reducer="krylov",
                         strategy="greedy_points", max_order=2000, progress=progress)
            print(json.dumps({{"finished": True}}))
        except KeyboardInterrupt as e:
            print(json.dumps({{"interrupted": type(e).__name__,
                               "history": len(e.result.history),
                               "termination": e.result.termination}}))
    """)
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                             env=os.environ)
    first = child.stdout.readline()
    assert first.startswith("iteration"), first
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    out, _ = child.communicate(timeout=120)
    waited = time.monotonic() - sent
    report = json.loads(out.strip().splitlines()[-1])
    assert report.get("interrupted") == "Interrupted", report
    assert report["history"] >= 1 and report["termination"] == "interrupted"
    assert child.returncode == 0
    print(f"stopped {waited:.2f} s after SIGINT")
