"""Shared fixtures of the Python module's tests: the package (imported from the build tree, see
python/CMakeLists.txt), the CLI beside it, the triple chain of examples/python (built with
scipy.sparse) and dense NumPy responses as the independent reference."""
import os
import pathlib
import sys

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
# The example's generator (scipy.sparse, independent of ecmor's C++ generators); the test
# test_generator_matches_the_shipped_reference checks it against an independent response.
sys.path.insert(0, str(ROOT / "examples" / "python"))
from triple_chain import triple_chain  # noqa: E402,F401


def dense_response(M, D, K, B, C, f_hz):
    """H(i 2 pi f) = C (s^2 M + s D + K)^-1 B by dense NumPy solves: the independent reference."""
    out = []
    for f in np.atleast_1d(f_hz):
        s = 2j * np.pi * f
        P = (s * s) * M.toarray() + s * D.toarray() + K.toarray()
        out.append(C @ np.linalg.solve(P, B))
    return np.array(out)


@pytest.fixture(scope="session")
def ecmor():
    import ecmor as module
    return module


@pytest.fixture(scope="session")
def cli():
    """The ecmor executable of the same build (ECMOR_EXECUTABLE, set by CTest)."""
    path = os.environ.get("ECMOR_EXECUTABLE")
    if not path or not os.path.exists(path):
        pytest.fail("ECMOR_EXECUTABLE must name the ecmor executable of this build (ctest sets it)")
    return path
