#!/usr/bin/python3
"""Independent dense balanced truncation of a bench/solid model (issue 46), not through ecmor.

Usage: python3 bench/bt_solid_dense.py MODEL_DIR [--fmin 10] [--fmax 3000] [--orders 8,12,...]
                                     [--check-scipy] [--json OUT.json]

Method (all dense, double precision):
 * Modal coordinates: K phi = w^2 M phi (scipy.linalg.eigh, mass-normalised). Rayleigh damping
   D = a M + b K is diagonal there (checked: max |offdiag(Phi'D Phi)| is printed).
 * First-order realisation, block diagonal with one 2x2 block per mode, state
   (w_i eta_i, eta_i'): A_i = [[0, w_i], [-w_i, -d_i]], B_i = [0; Phi_i' B], C_i = [C Phi_i / w_i, 0],
   then each block scaled by t_i = sqrt(||C_i|| / ||B_i||) (B_i -> B_i t_i, C_i -> C_i / t_i),
   which equilibrates the diagonals of P and Q (a state transformation: the HSVs are invariant).
   E = I. This realisation is similar to E = diag(I, M), A = [0 I; -K -D], B = [0; B], C = [C 0].
 * Gramians: A P + P A' + B B' = 0 and A'Q + Q A + C'C = 0 solved exactly block by block
   (for the pair of modes (i, j) a 4x4 Kronecker system, batched): no Schur form, every entry
   with a small relative error.
 * Square-root BT: P = Zc Zc', Q = Zo Zo' (eigh, negative rounding clipped), Zo' Zc = U S V',
   V_r = Zc V_r S_r^-1/2, W_r = Zo U_r S_r^-1/2; Ar = W'AV, Br = W'B, Cr = CV.
 * Frequency-limited BT (Gawronski-Juang): P_B = S P + P S', Q_B = S' Q + Q S with
   S = s(A), s(l) = s_w2(l) - s_w1(l), s_w(l) = (-i/2pi) (Log(iw - l) - Log(-iw - l)) which is
   (1/2pi) int_{-w}^{w} (i v - l)^-1 dv; so P_B = (1/2pi) int_{+-[w1, w2]} (ivI-A)^-1 BB'(ivI-A)^-H dv
   exactly (no quadrature). Evaluated per 2x2 block through its eigendecomposition (Newton
   divided difference for near-coincident eigenvalues). Then the same square-root truncation.
 * Band error: max_f ||H(i2pi f) - Hr(i2pi f)||_2 / ||H(i2pi f)||_2 over a log grid of 6000 points
   on [fmin, fmax] plus every full-model resonance and every reduced pole (|Im|/2pi) in the band.
   H from the modal sum (exact for Rayleigh damping), cross-checked at 5 frequencies against a
   sparse solve with K - w^2 M + i w D in the original coordinates.
"""
import argparse
import json
import sys
import time

import numpy as np
import scipy.io
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def load(d):
    r = lambda n: scipy.io.mmread(f"{d}/{n}.mtx")
    M, D, K = (sp.csc_matrix(r(n)) for n in "MDK")
    B = np.asarray(r("B").todense() if sp.issparse(r("B")) else r("B"))
    C = np.asarray(r("C").todense() if sp.issparse(r("C")) else r("C"))
    return M, D, K, B, C


def block_lyap(Ab, Bb):
    """Solve A X + X A' + B B' = 0 for block-diagonal A (n blocks 2x2, Ab: (n,2,2)), B rows
    in blocks (Bb: (n,2,m)). Returns the dense (2n, 2n) X."""
    n = Ab.shape[0]
    X = np.zeros((2 * n, 2 * n))
    I2 = np.eye(2)
    # vec(A_i X + X A_j') = (I kron A_i + A_j kron I) vec(X)  (column-major vec)
    KA = np.einsum("ab,icd->iacbd", I2, Ab).reshape(n, 4, 4)  # I kron A_i
    for j in range(n):
        Kj = np.kron(Ab[j], I2)  # A_j kron I (for X A_j')
        L = KA + Kj[None]
        rhs = -np.einsum("iam,bm->iab", Bb, Bb[j])  # (n, 2, 2): B_i B_j'
        rhs = rhs.transpose(0, 2, 1).reshape(n, 4)  # column-major vec
        x = np.linalg.solve(L, rhs[..., None])[..., 0]
        X[:, 2 * j:2 * j + 2] = x.reshape(n, 2, 2).transpose(0, 2, 1).reshape(2 * n, 2)
    return 0.5 * (X + X.T)


def block_s(Ab, w1, w2):
    """S = s(A) for the band +-[w1, w2], per 2x2 block; returns (n,2,2) complex... real part."""
    def s_w(l, w):
        return (-1j / (2 * np.pi)) * (np.log(1j * w - l) - np.log(-1j * w - l))

    def ds_w(l, w):
        return (-1j / (2 * np.pi)) * (-1.0 / (1j * w - l) + 1.0 / (-1j * w - l))

    f = lambda l: s_w(l, w2) - s_w(l, w1)
    df = lambda l: ds_w(l, w2) - ds_w(l, w1)
    n = Ab.shape[0]
    S = np.zeros((n, 2, 2), dtype=complex)
    I2 = np.eye(2)
    for i in range(n):
        A = Ab[i]
        tr, det = np.trace(A), np.linalg.det(A)
        disc = np.sqrt(complex(tr * tr / 4 - det))
        l1, l2 = tr / 2 + disc, tr / 2 - disc
        if abs(l1 - l2) > 1e-6 * abs(l1):
            dd = (f(l1) - f(l2)) / (l1 - l2)
        else:
            dd = df(0.5 * (l1 + l2))
        # f(A) = f(l2) I + f[l1, l2] (A - l2 I)
        S[i] = f(l2) * I2 + dd * (A - l2 * I2)
    assert np.max(np.abs(S.imag)) < 1e-8 * max(1.0, np.max(np.abs(S.real))), np.max(np.abs(S.imag))
    return S.real


def blockdiag_apply_left(Sb, X):
    n = Sb.shape[0]
    Y = X.reshape(n, 2, -1)
    return np.einsum("iab,ibk->iak", Sb, Y).reshape(X.shape)


def psd_factor(X):
    w, U = np.linalg.eigh(X)
    keep = w > 0
    return U[:, keep] * np.sqrt(w[keep])


def bt(Zc, Zo, A, B, C, r):
    U, s, Vt = np.linalg.svd(Zo.T @ Zc, full_matrices=False)
    Sr = 1.0 / np.sqrt(s[:r])
    V = Zc @ Vt[:r].T * Sr
    W = Zo @ U[:, :r] * Sr
    return W.T @ A @ V, W.T @ B, C @ V, s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("model")
    ap.add_argument("--fmin", type=float, default=10.0)
    ap.add_argument("--fmax", type=float, default=3000.0)
    ap.add_argument("--orders", default="4,8,12,16,20,24,30,40,50,60,80,100")
    ap.add_argument("--grid", type=int, default=6000)
    ap.add_argument("--check-scipy", action="store_true",
                    help="also solve the Lyapunov equations of E^-1 A in the original coordinates "
                         "with scipy.linalg.solve_continuous_lyapunov (Bartels-Stewart)")
    ap.add_argument("--json")
    ap.add_argument("--no-scan", action="store_true", help="skip the smallest-r scans")
    a = ap.parse_args()
    t0 = time.time()
    M, D, K, B, C = load(a.model)
    N = K.shape[0]
    lam, Phi = sla.eigh(K.toarray(), M.toarray())
    om = np.sqrt(lam)
    Dm = Phi.T @ (D @ Phi)
    d = np.diag(Dm).copy()
    offd = np.max(np.abs(Dm - np.diag(d))) / np.max(np.abs(d))
    zeta = d / (2 * om)
    print(f"N = {N}, first-order states {2 * N}; eigenfrequencies {om[0] / 2 / np.pi:.4g} .. "
          f"{om[-1] / 2 / np.pi:.4g} Hz; zeta {zeta.min():.3g} .. {zeta.max():.3g}; "
          f"modes in band {np.sum((om / 2 / np.pi >= a.fmin) & (om / 2 / np.pi <= a.fmax))}; "
          f"|offdiag(Phi'D Phi)|/max diag = {offd:.1e}; eigh {time.time() - t0:.1f} s")
    bt_ = Phi.T @ B  # (N, m)
    ct_ = C @ Phi  # (p, N)
    # blocks, state (w eta, eta')
    nb = np.linalg.norm(bt_, axis=1)
    nc = np.linalg.norm(ct_, axis=0) / om
    tsc = np.sqrt(np.where(nb > 0, nc / np.maximum(nb, 1e-300), 1.0))
    tsc[~np.isfinite(tsc) | (tsc == 0)] = 1.0
    Ab = np.zeros((N, 2, 2))
    Ab[:, 0, 1] = om
    Ab[:, 1, 0] = -om
    Ab[:, 1, 1] = -d
    Bb = np.zeros((N, 2, B.shape[1]))
    Bb[:, 1, :] = bt_ * tsc[:, None]
    Cb = np.zeros((C.shape[0], N, 2))
    Cb[:, :, 0] = ct_ / om / tsc
    A = sla.block_diag(*Ab)
    Bf = Bb.reshape(2 * N, -1)
    Cf = Cb.reshape(C.shape[0], 2 * N)

    t1 = time.time()
    P = block_lyap(Ab, Bb)
    Q = block_lyap(np.transpose(Ab, (0, 2, 1)), np.transpose(Cb, (1, 2, 0)))
    resP = np.linalg.norm(A @ P + P @ A.T + Bf @ Bf.T) / np.linalg.norm(Bf @ Bf.T)
    resQ = np.linalg.norm(A.T @ Q + Q @ A + Cf.T @ Cf) / np.linalg.norm(Cf.T @ Cf)
    print(f"Gramians (block-exact) {time.time() - t1:.1f} s; residuals {resP:.1e} {resQ:.1e}; "
          f"trace(P) trace(Q) / s_1^2 below")
    Zc, Zo = psd_factor(P), psd_factor(Q)
    w1, w2 = 2 * np.pi * a.fmin, 2 * np.pi * a.fmax
    Sb = block_s(Ab, w1, w2)
    SP = blockdiag_apply_left(Sb, P)
    PB = SP + SP.T
    SQ = blockdiag_apply_left(np.transpose(Sb, (0, 2, 1)), Q)  # S' Q
    QB = SQ + SQ.T
    ZcB, ZoB = psd_factor(0.5 * (PB + PB.T)), psd_factor(0.5 * (QB + QB.T))
    negB = (np.linalg.eigvalsh(PB).min() / np.linalg.eigvalsh(PB).max())

    hsv = np.linalg.svd(Zo.T @ Zc, compute_uv=False)
    hsvB = np.linalg.svd(ZoB.T @ ZcB, compute_uv=False)
    print(f"s_1 = {hsv[0]:.4e}; trace(P) trace(Q) / s_1^2 = {np.trace(P) * np.trace(Q) / hsv[0]**2:.3g}"
          f" (this balanced-ish realisation); FL min eig ratio P_B {negB:.1e}")

    # ecmor-like floor in ecmor's realisation: sqrt(n eps trace(P_e) trace(E'Q_e E)),
    # with x = [q; q'], E = diag(I, M). P_e = T P T', T maps our state to [q; q'].
    # q = Phi eta = Phi (x1 / w) / t; q' = Phi eta' = Phi x2 / t
    Tq = Phi / (om * tsc)  # acting on x1 components
    Tv = Phi / tsc
    x1, x2 = slice(0, None, 2), slice(1, None, 2)
    trPe = np.trace(Tq @ P[x1, x1] @ Tq.T) + np.trace(Tv @ P[x2, x2] @ Tv.T)
    # E'Q_e E with E'Q_eE in [q; q'] coordinates: Q_e = T^-T Q T^-1; E'QE blocks: q block T_q^-T Q11 T_q^-1,
    # q' block M T_v^-T Q22 T_v^-1 M. T_q^-1 = diag(w t) Phi' M (Phi' M Phi = I).
    Mi = M.toarray()
    Tqi = (om * tsc)[:, None] * (Phi.T @ Mi)
    Tvi = tsc[:, None] * (Phi.T @ Mi)
    trQe = np.trace(Tqi.T @ Q[x1, x1] @ Tqi) + np.trace(Mi @ Tvi.T @ Q[x2, x2] @ Tvi @ Mi)
    floor = np.sqrt(2 * N * np.finfo(float).eps * trPe * trQe)
    nfloor = int(np.sum(hsv > floor))
    print(f"ecmor's rule in ecmor's realisation: trace(P) trace(E'QE) / s_1^2 = "
          f"{trPe * trQe / hsv[0]**2:.3g}; floor sqrt(n eps trP trE'QE) = {floor:.3e} "
          f"= {floor / hsv[0]:.2e} s_1 -> admits {nfloor} HSVs; n eps s_1 admits "
          f"{int(np.sum(hsv > 2 * N * np.finfo(float).eps * hsv[0]))}")

    # frequency grid
    fres = om / 2 / np.pi
    fgrid = np.unique(np.concatenate([np.geomspace(a.fmin, a.fmax, a.grid),
                                      fres[(fres >= a.fmin) & (fres <= a.fmax)],
                                      (np.sqrt(np.maximum(om**2 - d**2 / 4, 0)) / 2 / np.pi)[
                                          (fres >= a.fmin) & (fres <= a.fmax)]]))

    def Hfull(f):
        w = 2 * np.pi * f
        den = (lam[None, :] - w[:, None] ** 2 + 1j * w[:, None] * d[None, :])  # (F, N)
        return np.einsum("pn,fn,nm->fpm", ct_, 1.0 / den, bt_)

    Hf = Hfull(fgrid)
    nH = np.linalg.norm(Hf, ord=2, axis=(1, 2))
    # cross-check the modal sum against sparse solves in the original coordinates
    chk = []
    for f in [a.fmin, 100.0, 1000.0, fres[(fres > a.fmin)][2], a.fmax]:
        w = 2 * np.pi * f
        Hs = C @ spla.spsolve((K - w * w * M + 1j * w * D).tocsc(), B.astype(complex))
        chk.append(np.linalg.norm(Hs - Hfull(np.array([f]))[0], 2) / np.linalg.norm(Hs, 2))
    print(f"modal sum vs sparse solve: max rel diff {max(chk):.1e}")
    print(f"||H||_2 over the band: max {nH.max():.4e} at {fgrid[nH.argmax()]:.1f} Hz, "
          f"min {nH.min():.4e} at {fgrid[nH.argmin()]:.1f} Hz, ratio min/max {nH.min() / nH.max():.2e}; "
          f"||H(i 2pi fmin)|| = {nH[0]:.3e}, ||H(i 2pi fmax)|| = {nH[-1]:.3e}; s_1 = {hsv[0]:.3e}")

    def band_err(Ar, Br, Cr):
        ev = np.linalg.eigvals(Ar)
        fp = np.abs(ev.imag) / 2 / np.pi
        fp = fp[(fp >= a.fmin) & (fp <= a.fmax)]
        unstable = int(np.sum(ev.real >= 0))
        fe = np.unique(np.concatenate([fgrid, fp]))
        He = Hf if len(fp) == 0 else None
        if He is None:
            He = Hfull(fe)
            nHe = np.linalg.norm(He, ord=2, axis=(1, 2))
        else:
            nHe = nH
        r = Ar.shape[0]
        Hr = np.empty_like(He)
        I = np.eye(r)
        for k0 in range(0, len(fe), 400):
            ss = 2j * np.pi * fe[k0:k0 + 400]
            Hr[k0:k0 + 400] = Cr @ np.linalg.solve(ss[:, None, None] * I - Ar, np.broadcast_to(Br, (len(ss),) + Br.shape))
        e = np.linalg.norm(He - Hr, ord=2, axis=(1, 2)) / nHe
        k = int(np.argmax(e))
        return float(e[k]), float(fe[k]), unstable

    orders = [int(x) for x in a.orders.split(",")]
    rows = []
    print("\n| r | s_r/s_1 | s_{r+1}/s_1 | 2 sum_{i>r} s_i / min_f ||H|| | band error BT (f_peak Hz) | "
          "FL-BT s_r/s_1 | band error FL-BT (f_peak Hz) | unstable poles BT/FL |")
    print("|---|---|---|---|---|---|---|---|")
    for r in orders:
        Ar, Br, Cr, _ = bt(Zc, Zo, A, Bf, Cf, r)
        e, fe, u = band_err(Ar, Br, Cr)
        ArB, BrB, CrB, _ = bt(ZcB, ZoB, A, Bf, Cf, r)
        eB, feB, uB = band_err(ArB, BrB, CrB)
        tail = 2 * hsv[r:].sum()
        rows.append(dict(r=r, hsv_r=hsv[r - 1] / hsv[0], hsv_next=hsv[r] / hsv[0],
                         bound_rel=tail / nH.min(), bt=e, bt_f=fe, fl=eB, fl_f=feB,
                         hsvB_r=hsvB[r - 1] / hsvB[0], unstable=u, unstableB=uB))
        print(f"| {r} | {hsv[r - 1] / hsv[0]:.2e} | {hsv[r] / hsv[0]:.2e} | {tail / nH.min():.2e} | "
              f"{e:.3e} ({fe:.0f}) | {hsvB[r - 1] / hsvB[0]:.2e} | {eB:.3e} ({feB:.0f}) | {u}/{uB} |",
              flush=True)
    # smallest r meeting 1e-2 / 1e-3 (scan)
    best = {}
    for tol in (() if a.no_scan else (1e-2, 1e-3)):
        for name, Z in (("bt", (Zc, Zo)), ("fl", (ZcB, ZoB))):
            hit = None
            for r in list(range(2, 61)) + list(range(65, 201, 5)):
                Ar, Br, Cr, _ = bt(Z[0], Z[1], A, Bf, Cf, r)
                e, _, _ = band_err(Ar, Br, Cr)
                if e <= tol:
                    hit = (r, e, int(np.sum(np.linalg.eigvals(Ar).real >= 0)))
                    break
            best[f"{name}_{tol:g}"] = hit
            print(f"smallest r with band error <= {tol:g}, {name}: {hit}", flush=True)
    print("\nHSVs s_i/s_1, i = 1..80:")
    print(" ".join(f"{x:.2e}" for x in hsv[:80] / hsv[0]))
    print("FL HSVs s_i/s_1, i = 1..80:")
    print(" ".join(f"{x:.2e}" for x in hsvB[:80] / hsvB[0]))

    if a.check_scipy:
        t2 = time.time()
        Mi_inv = np.linalg.inv(Mi)
        F = np.block([[np.zeros((N, N)), np.eye(N)], [-Mi_inv @ K.toarray(), -Mi_inv @ D.toarray()]])
        Bt = np.vstack([np.zeros_like(B), Mi_inv @ B])
        Ct = np.hstack([C, np.zeros_like(C)])
        P2 = sla.solve_continuous_lyapunov(F, -Bt @ Bt.T)
        Q2 = sla.solve_continuous_lyapunov(F.T, -Ct.T @ Ct)
        ev = np.sort(np.sqrt(np.abs(np.linalg.eigvals(P2 @ Q2))))[::-1]
        print(f"\nscipy Bartels-Stewart on E^-1 A ({time.time() - t2:.0f} s): HSV s_i/s_1 "
              f"(sqrt |eig(PQ)|), i = 1..40, and relative difference to the block-exact ones:")
        print(" ".join(f"{x:.2e}" for x in ev[:40] / ev[0]))
        print(" ".join(f"{x:.0e}" for x in np.abs(ev[:40] - hsv[:40]) / hsv[:40]))
        # BT from these (original-coordinate, Bartels-Stewart) Gramians: same orders, same error measure
        Zc2, Zo2 = psd_factor(0.5 * (P2 + P2.T)), psd_factor(0.5 * (Q2 + Q2.T))
        print("| r | band error, BT from scipy Bartels-Stewart Gramians of E^-1 A (f_peak Hz) | unstable |")
        print("|---|---|---|")
        for r in orders:
            Ar, Br, Cr, _ = bt(Zc2, Zo2, F, Bt, Ct, r)
            e, fe, u = band_err(Ar, Br, Cr)
            print(f"| {r} | {e:.3e} ({fe:.0f}) | {u} |", flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(dict(N=N, hsv=list(hsv[:200]), hsvB=list(hsvB[:200]), rows=rows,
                           best=best, floor=floor, nfloor=nfloor,
                           nH_min=float(nH.min()), nH_max=float(nH.max()),
                           f_min_H=float(fgrid[nH.argmin()])), fh, indent=1)
    print(f"total {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
