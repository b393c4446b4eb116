"""Models from memory: every input format gives the same model, every bad input a named error,
and ecmor keeps one copy of the matrices, which it shows without copying again."""
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
import scipy.sparse as sp

from conftest import triple_chain


def test_every_format_gives_the_same_matrices(ecmor):
    M, D, K, B, C = triple_chain(5)
    reference = ecmor.SecondOrder(M, D, K, B, C)
    for convert in (sp.csc_matrix, sp.csr_matrix, sp.coo_matrix, sp.lil_matrix, sp.dok_matrix,
                    sp.bsr_matrix, lambda a: a.toarray(), lambda a: np.asfortranarray(a.toarray())):
        model = ecmor.SecondOrder(convert(M), convert(D), convert(K), B, C)
        for name in ("M", "D", "K"):
            got, want = getattr(model, name), getattr(reference, name)
            assert got.format == "csc"
            np.testing.assert_array_equal(got.toarray(), want.toarray())
            np.testing.assert_array_equal(got.toarray(), {"M": M, "D": D, "K": K}[name].toarray())
        np.testing.assert_array_equal(model.B, B)
        np.testing.assert_array_equal(model.C, C)
    assert reference.N == 16 and reference.inputs == 1 and reference.outputs == 1
    assert reference.kind == "second order" and reference.Cv is None


def test_duplicates_are_summed_and_columns_sorted(ecmor):
    # COO with a duplicate and unsorted entries: scipy's own sum is the reference.
    rows = np.array([2, 0, 1, 0, 2, 1])
    cols = np.array([0, 0, 1, 0, 2, 1])
    vals = np.array([1.0, 4.0, 5.0, -1.0, 6.0, 0.5])
    A = sp.coo_matrix((vals, (rows, cols)), shape=(3, 3))
    I = sp.identity(3, format="csc")
    model = ecmor.SecondOrder(I, I, A, np.ones((3, 1)), np.ones((1, 3)))
    np.testing.assert_array_equal(model.K.toarray(), A.toarray())
    K = model.K
    for j in range(3):
        col = K.indices[K.indptr[j]:K.indptr[j + 1]]
        assert list(col) == sorted(set(col))


def test_integer_and_float32_values_are_exact(ecmor):
    M, D, K, B, C = triple_chain(3)
    model = ecmor.SecondOrder(M.astype(np.float32), D, K.astype(np.int64), B.astype(np.int32), C)
    np.testing.assert_array_equal(model.M.toarray(), M.astype(np.float32).toarray())
    np.testing.assert_array_equal(model.K.toarray(), K.toarray())


def bad(ecmor, match, **changes):
    M, D, K, B, C = triple_chain(3)
    args = dict(M=M, D=D, K=K, B=B, C=C)
    args.update(changes)
    with pytest.raises(ecmor.Error, match=match) as info:
        ecmor.SecondOrder(**args)
    assert isinstance(info.value, ValueError)
    return str(info.value)


def test_named_errors_for_bad_input(ecmor):
    N = 10
    # wrong shapes: the rule and the matrix are named (validate's messages, as for files)
    bad(ecmor, r"ecmor.SecondOrder: M is 10 x 9: must be square", M=sp.identity(N).tocsc()[:, :9])
    bad(ecmor, r"B has 9 rows: must equal N = 10", B=np.ones((9, 1)))
    bad(ecmor, r"C .*10", C=np.ones((1, 9)))
    bad(ecmor, r"ecmor.SecondOrder: B: a 1-D array: must be 2-D", B=np.ones(N))
    # dtypes: never a silent cast
    bad(ecmor, r"K: data has dtype complex128: ecmor's models are real",
        K=sp.identity(N, dtype=complex, format="csc"))
    bad(ecmor, r"B: the matrix has dtype complex128", B=np.ones((N, 1), dtype=complex))
    bad(ecmor, r"C: the matrix has dtype object", C=np.array([[None] * N], dtype=object))
    bad(ecmor, r"B: the matrix has dtype bool", B=np.ones((N, 1), dtype=bool))
    bad(ecmor, r"B: the matrix has dtype <U1", B=np.full((N, 1), "a"))
    # non-finite values: the matrix and the position (1-based)
    K = sp.identity(N, format="csc")
    K.data[3] = np.nan
    bad(ecmor, r"K has a non-finite value \(NaN\) at \(4, 4\)", K=K)
    B = np.ones((N, 1))
    B[2, 0] = np.inf
    bad(ecmor, r"B has a non-finite value \(Inf\) at \(3, 1\)", B=B)
    # broken sparse arrays
    K = sp.identity(N, format="csc")
    K.indices[2] = 40
    bad(ecmor, r"K: indices\[2\] = 40: must be in \[0, 9\]", K=K)
    K = sp.identity(N, format="csc")
    K.indptr[5] = 2
    bad(ecmor, r"K: indptr\[5\] = 2 < indptr\[4\] = 4: must not decrease", K=K)
    bad(ecmor, r"M: missing \(None\)", M=None)


def test_descriptor_and_its_errors(ecmor):
    E = sp.identity(4, format="csr")
    A = -sp.diags([1.0, 2.0, 3.0, 4.0]).tocoo()
    model = ecmor.Descriptor(E, A, np.ones((4, 2)), np.ones((3, 4)))
    assert model.kind == "descriptor" and (model.N, model.inputs, model.outputs) == (4, 2, 3)
    np.testing.assert_array_equal(model.A.toarray(), A.toarray())
    with pytest.raises(ecmor.Error, match=r"ecmor.Descriptor: E is 4 x 3: must be square"):
        ecmor.Descriptor(np.ones((4, 3)), A, np.ones((4, 1)), np.ones((1, 4)))


def test_matrices_are_views_of_ecmors_copy(ecmor):
    M, D, K, B, C = triple_chain(4)
    model = ecmor.SecondOrder(M, D, K, B, C)
    # Two reads share memory: the attribute is a view of the one copy ecmor holds, not a new copy.
    assert np.shares_memory(model.K.data, model.K.data)
    assert np.shares_memory(model.B, model.B)
    # ... and that copy is not the caller's array: changing the input changes nothing in ecmor.
    assert not np.shares_memory(model.K.data, K.data)
    with pytest.raises(ValueError):
        model.K.data[0] = 1.0  # read-only
    K.data[:] = 7.0
    assert model.K.data[0] != 7.0


def test_one_copy_of_a_large_matrix(tmp_path):
    # The memory ecmor holds after construction is one copy of the matrix (12 bytes per entry in
    # its CSC), not two, whether the input is CSC or CSR; measured in a fresh process as resident
    # memory after malloc_trim (which returns what was freed: ecmor.validate's transient work, the
    # same as the CLI's on loading, is not held).
    script = textwrap.dedent("""
        import ctypes, sys, numpy as np, scipy.sparse as sp, ecmor
        trim = ctypes.CDLL("libc.so.6").malloc_trim
        def rss():
            trim(0)
            with open("/proc/self/statm") as f:
                return int(f.read().split()[1]) * 4096
        n, per_col = 200000, 40
        rng = np.random.default_rng(1)
        rows = rng.integers(0, n, size=n * per_col).astype(np.int32)
        A = sp.csc_matrix((np.ones(n * per_col), rows, np.arange(0, n * per_col + 1, per_col,
                           dtype=np.int32)), shape=(n, n))
        if sys.argv[1] == "csr":
            A = A.T.tocsr().T.tocsr()
        I = sp.identity(n, format="csc")
        nnz = A.nnz
        before = rss()
        model = ecmor.SecondOrder(I, I, A, np.ones((n, 1)), np.ones((1, n)))
        grown = rss() - before
        print(grown / (12.0 * nnz))
    """)
    for layout in ("csc", "csr"):
        out = subprocess.run([sys.executable, "-c", script, layout], check=True,
                             capture_output=True, text=True, env=os.environ).stdout
        copies = float(out.strip())
        assert 0.7 < copies < 1.5, f"{layout}: resident memory grew by {copies:.2f} copies"
