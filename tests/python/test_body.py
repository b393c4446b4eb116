"""ecmor.export_body: a free-floating truss built here with NumPy, reduced, exported as a SID body.
Its mass invariants are checked against the closed forms for lumped masses (mass, centre and
inertia about the origin are sums over the nodes), independently of ecmor."""
import itertools

import numpy as np
import pytest
import scipy.sparse as sp


def free_truss(nx=6, h=0.1, EA=2.0e7, seed=3):
    """Nodes on an nx x 2 x 2 grid of spacing h, bars along every edge and every face and body
    diagonal of each cell (a rigid truss: six rigid-body modes when free), random lumped masses."""
    pts = [(i * h, j * h, k * h) for i in range(nx) for j in range(2) for k in range(2)]
    x = np.array(pts)
    n = len(pts)
    rng = np.random.default_rng(seed)
    masses = rng.uniform(0.5, 1.5, n)
    rows, cols, vals = [], [], []
    for a, b in itertools.combinations(range(n), 2):
        d = x[b] - x[a]
        length = np.linalg.norm(d)
        if length > np.sqrt(3) * h * 1.0001:
            continue
        e = d / length
        k = EA / length * np.outer(e, e)
        for (p, q, sign) in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
            for r in range(3):
                for c in range(3):
                    rows.append(3 * p + r), cols.append(3 * q + c), vals.append(sign * k[r, c])
    N = 3 * n
    K = sp.coo_matrix((vals, (rows, cols)), shape=(N, N)).tocsc()
    M = sp.diags(np.repeat(masses, 3), format="csc")
    D = (1e-5 * K).tocsc()
    B = np.zeros((N, 1))
    B[3 * (n - 1), 0] = 1.0  # axial force at the last node
    C = np.zeros((1, N))
    C[0, 3 * (n - 1) + 1] = 1.0  # its transverse displacement
    nodes = np.column_stack([np.arange(1, n + 1), x])
    dofs = np.array([(node + 1, direction) for node in range(n) for direction in (1, 2, 3)])
    return M, D, K, B, C, nodes, dofs, masses, x


def test_free_body_has_the_closed_form_invariants(ecmor, tmp_path):
    M, D, K, B, C, nodes, dofs, m, x = free_truss()
    model = ecmor.SecondOrder(M, D, K, B, C)
    result = ecmor.reduce(model, band=(1.0, 2000.0), tol=1e-2, reducer="modal",
                          strategy="grow_order")
    assert result.rom is not None
    body = ecmor.export_body(result, tmp_path / "truss.SID_FEM", nodes, dofs)
    for key in ("sid", "json", "mat"):
        assert (tmp_path / f"truss.{'SID_FEM' if key == 'sid' else key}").exists()
    total = m.sum()
    assert body["mass"] == pytest.approx(total, rel=1e-12)
    np.testing.assert_allclose(body["center"], (m[:, None] * x).sum(0) / total, rtol=1e-12)
    J = sum(mi * (xi @ xi * np.eye(3) - np.outer(xi, xi)) for mi, xi in zip(m, x))
    np.testing.assert_allclose(body["J"], J, rtol=1e-10, atol=1e-12 * np.abs(J).max())
    assert body["free_motions"] == 6
    assert max(body["check"]) <= 1e-10
    assert body["frame_nodes"] == 1  # B and C act at the last node only
    assert body["coordinates"] == body["run_order"] - body["removed"]


def test_export_body_errors_are_named(ecmor, tmp_path):
    M, D, K, B, C, nodes, dofs, m, x = free_truss(nx=3)
    model = ecmor.SecondOrder(M, D, K, B, C)
    result = ecmor.reduce(model, band=(1.0, 2000.0), tol=1e-2, reducer="modal",
                          strategy="grow_order")
    with pytest.raises(ecmor.Error, match=r"ecmor.export_body: dofs has 3 columns: must be 2"):
        ecmor.export_body(result, tmp_path / "b.SID_FEM", nodes, np.column_stack([dofs, dofs[:, 0]]))
    with pytest.raises(ecmor.Error, match=r"ecmor.export_body: nodes: row 2: id = 1.5"):
        bad = nodes.copy()
        bad[1, 0] = 1.5
        ecmor.export_body(result, tmp_path / "b.SID_FEM", bad, dofs)
    with pytest.raises(ecmor.Error, match=r"ecmor.export_body"):
        ecmor.export_body(result, tmp_path / "b.SID_FEM", nodes, dofs[:-3])
