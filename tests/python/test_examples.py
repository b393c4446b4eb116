"""The README's Python snippet and examples/python run as documented, and the example's model
generator reproduces the shipped model's independent reference response."""
import csv
import os
import re
import subprocess
import sys

import numpy as np

from conftest import ROOT, dense_response, triple_chain


def test_readme_snippet_runs(tmp_path):
    readme = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", readme, flags=re.S)
    assert blocks, "README.md has no ```python block"
    snippet = blocks[0]
    assert len(snippet.strip().splitlines()) <= 10
    out = subprocess.run([sys.executable, "-c", snippet], cwd=tmp_path, capture_output=True,
                         text=True, env=os.environ)
    assert out.returncode == 0, out.stderr
    order, error, iterations = out.stdout.split()
    assert 1 <= int(order) and float(error) <= 1e-3 and int(iterations) >= 1


def test_generator_matches_the_shipped_reference():
    # models/triplechain_saak09_n451/ref_freq_response.csv comes from the original MATLAB
    # example (models/README.md), not from ecmor.
    M, D, K, B, C = triple_chain(150)
    path = ROOT / "models" / "triplechain_saak09_n451" / "ref_freq_response.csv"
    with open(path) as f:
        rows = [r for r in csv.reader(line for line in f if not line.startswith("#"))][1:]
    rows = rows[::20]
    omega = np.array([float(r[0]) for r in rows])
    want = np.array([complex(float(r[2]), float(r[3])) for r in rows])
    got = dense_response(M, D, K, B, C, omega / (2 * np.pi))[:, 0, 0]
    np.testing.assert_allclose(got, want, rtol=1e-8)


def test_example_script_runs(tmp_path):
    out = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "triple_chain.py"),
                          "150", "--plot", str(tmp_path / "sigma.png")], cwd=tmp_path,
                         capture_output=True, text=True, env=os.environ)
    assert out.returncode == 0, out.stderr
    m = re.search(r"N = 451 -> order (\d+), band error (\S+) \(converged\)", out.stdout)
    assert m, out.stdout
    assert float(m.group(2)) <= 1e-3
