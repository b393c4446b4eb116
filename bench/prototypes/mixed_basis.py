#!/usr/bin/env python3
"""Prototype of a mixed reduction basis (issue 29, item 2): a block of undamped modes ranked by
dominance, then Krylov vectors P(i w)^-1 B (real and imaginary parts) at peaks of the band error,
one Galerkin projection W = V. Dense and slow on purpose: every error is measured against full
sparse solves, independently of ecmor's code. Needs python3-numpy and python3-scipy (Debian), which
are not build dependencies of ecmor.

  mixed_basis.py MODEL_DIR W_MIN W_MAX TOL BUDGET BLOCK [PEAKS [PATIENCE]]

W_MIN, W_MAX: the band in rad/s. BLOCK: the number of modes, or 0 for the rule "grow by 10 until
PATIENCE steps in a row (default 1) lowered the error by less than 10 %". PEAKS: how many of the error's largest local maxima are tried as
the next Krylov point (the one that lowers the error most is kept; when none does, 4 more modes).
Prints one line per step: order, what was added (m: modes, k: Krylov point), band error.
"""
import os
import sys

import numpy as np
import scipy.io as sio
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spl


def read(d, name):
    """name.mtx or name.mtx.gz (SciPy's mmread decompresses by the extension)."""
    plain = f"{d}/{name}.mtx"
    return sio.mmread(plain if os.path.exists(plain) else plain + ".gz")


def load(d):
    M, D, K = (sp.csc_matrix(read(d, x)) for x in "MDK")
    B = np.asarray(sp.csc_matrix(read(d, "B")).todense())
    C = np.asarray(sp.csc_matrix(read(d, "C")).todense())
    return M, D, K, B, C


class Problem:
    def __init__(self, d, wlo, whi):
        self.M, self.D, self.K, self.B, self.C = load(d)
        self.Md, self.Dd, self.Kd = (x.toarray() for x in (self.M, self.D, self.K))
        self.wlo, self.whi = wlo, whi
        lam, self.Phi = la.eigh(self.Kd, self.Md)
        om = np.sqrt(np.maximum(lam, 0.0))
        inside = om[(om > wlo) & (om < whi)]
        self.w = np.unique(np.concatenate([np.geomspace(wlo, whi, 3000), inside]))
        self.cache = {}
        self.H = np.array([self.full(x) for x in self.w])
        # Dominance: a mode's peak contribution at its frequency (clamped to the band) relative to
        # the response there.
        d_j = np.einsum("ij,ik,kj->j", self.Phi, self.Dd, self.Phi)
        cb = np.linalg.norm(self.C @ self.Phi, axis=0) * np.linalg.norm(self.B.T @ self.Phi, axis=0)
        wc = np.clip(om, wlo, whi)
        hn = np.interp(np.log(wc), np.log(self.w), np.array([np.linalg.norm(h, 2) for h in self.H]))
        self.ranking = np.argsort(-cb / np.abs(om**2 - wc**2 + 1j * wc * d_j) / hn)

    def solve(self, x):
        if x not in self.cache:
            s = 1j * x
            self.cache[x] = spl.spsolve((s * s * self.M + s * self.D + self.K).tocsc(), self.B)
        return self.cache[x].reshape(self.B.shape[0], -1)

    def full(self, x):
        return self.C @ self.solve(x)

    def error(self, V):
        """Relative spectral band error on the grid plus the reduced poles' frequencies."""
        Q, _ = la.qr(V, mode="economic")
        Mr, Dr, Kr = (Q.T @ X @ Q for X in (self.Md, self.Dd, self.Kd))
        Br, Cr, r = Q.T @ self.B, self.C @ Q, Q.shape[1]
        A = np.block([[np.zeros((r, r)), np.eye(r)], [-la.solve(Mr, Kr), -la.solve(Mr, Dr)]])
        pw = np.abs(la.eigvals(A).imag)
        extra = np.setdiff1d(pw[(pw > self.wlo) & (pw < self.whi)], self.w)
        ww = np.concatenate([self.w, extra])
        HH = list(self.H) + [self.full(x) for x in extra]
        e = np.array([np.linalg.norm(h - Cr @ la.solve(-x * x * Mr + 1j * x * Dr + Kr, Br), 2) /
                      np.linalg.norm(h, 2) for x, h in zip(ww, HH)])
        return e, ww, r


def peaks(e, ww):
    o = np.argsort(ww)
    e, ww = e[o], ww[o]
    loc = [j for j in range(len(e))
           if (j == 0 or e[j] >= e[j - 1]) and (j == len(e) - 1 or e[j] >= e[j + 1])]
    return [ww[j] for j in sorted(loc, key=lambda j: -e[j])]


def main():
    d, wlo, whi, tol, budget, block = sys.argv[1:7]
    wlo, whi, tol, budget, block = float(wlo), float(whi), float(tol), int(budget), int(block)
    n_peaks = int(sys.argv[7]) if len(sys.argv) > 7 else 5
    patience = int(sys.argv[8]) if len(sys.argv) > 8 else 1
    p = Problem(d, wlo, whi)
    basis = lambda m, kv: np.hstack([p.Phi[:, p.ranking[:m]]] + kv)
    kv = []
    m = block if block > 0 else 10
    e, ww, r = p.error(basis(m, kv))
    print(r, "m", f"{e.max():.3e}", flush=True)
    idle = 0
    while block == 0 and r < budget and e.max() >= tol and idle < patience:
        e2, w2, r2 = p.error(basis(m + 10, kv))
        idle = 0 if e2.max() < 0.9 * e.max() else idle + 1
        m, e, ww, r = m + 10, e2, w2, r2
        print(r, "m", f"{e.max():.3e}", flush=True)
    while r < budget and e.max() >= tol:
        best = None
        for wp in peaks(e, ww)[:n_peaks]:
            x = p.solve(wp)
            k2 = kv + [x.real, x.imag]
            en, wn, rn = p.error(basis(m, k2))
            if best is None or en.max() < best[1].max():
                best = (k2, en, wn, rn, wp)
        if best[1].max() < e.max():
            kv, e, ww, r, wp = best
            print(r, "k", f"{e.max():.3e}", f"(point {wp / (2 * np.pi):.4g} Hz)", flush=True)
        else:
            m += 4
            e, ww, r = p.error(basis(m, kv))
            print(r, "m", f"{e.max():.3e}", flush=True)


if __name__ == "__main__":
    main()
