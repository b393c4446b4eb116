#!/usr/bin/env python3
"""The triple chain oscillator built with scipy.sparse, reduced by ecmor, its sigma plot drawn.

    python3 examples/python/triple_chain.py [n1] [--plot FILE.png]

Three chains of n1 masses (1, 2, 3; springs 10, 20, 1), each fixed to the ground at one end and
joined at the other by a mass of 10 with a spring of 50 to the ground (Truhar & Veselic 2009, with
the parameters of Saak's examples: N = 3 n1 + 1, damping D = 0.01 M + 0.01 K + 5 (e_1 e_1' +
e_n1 e_n1' + e_2n1+1 e_2n1+1')). n1 = 150 is the shipped model models/triplechain_saak09_n451.
The plot needs matplotlib (Debian: python3-matplotlib); without it the response is printed.
"""
import argparse

import numpy as np
import scipy.sparse as sp

import ecmor


def triple_chain(n1, alpha=0.01, beta=0.01, v=5.0):
    """(M, D, K, B, C): M, D, K as scipy CSC matrices, B = ones (N x 1), C = ones (1 x N)."""
    masses, springs = (1.0, 2.0, 3.0), (10.0, 20.0, 1.0)
    N = 3 * n1 + 1
    rows, cols, vals = [], [], []

    def spring(i, j, k):  # a spring of stiffness k between masses i and j (j = None: ground)
        rows.append(i), cols.append(i), vals.append(k)
        if j is not None:
            rows.extend([j, i, j]), cols.extend([j, j, i]), vals.extend([k, -k, -k])

    m = np.empty(N)
    for c in range(3):
        first = c * n1
        m[first:first + n1] = masses[c]
        spring(first, None, springs[c])
        for i in range(first, first + n1 - 1):
            spring(i, i + 1, springs[c])
        spring(first + n1 - 1, N - 1, springs[c])
    m[N - 1] = 10.0
    spring(N - 1, None, 50.0)
    K = sp.coo_matrix((vals, (rows, cols)), shape=(N, N)).tocsc()  # duplicates summed
    M = sp.diags(m, format="csc")
    grounded = np.zeros(N)
    for i in (0, n1 - 1, 2 * n1):
        grounded[i] += v
    D = (alpha * M + beta * K + sp.diags(grounded)).tocsc()
    return M, D, K, np.ones((N, 1)), np.ones((1, N))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("n1", type=int, nargs="?", default=150, help="masses per chain")
    parser.add_argument("--plot", help="write the sigma plot to this file (needs matplotlib)")
    args = parser.parse_args()

    model = ecmor.SecondOrder(*triple_chain(args.n1))
    band = (1e-5, 0.02)  # Hz: the first ten resonances
    result = ecmor.reduce(model, band=band, tol=1e-3, reducer="modal", strategy="grow_order",
                          progress=lambda row: print(f"  iteration {row['iteration']:3d}  order "
                                                     f"{row['order']:4d}  band error "
                                                     f"{row['band_error']:.3e}"))
    print(f"N = {model.N} -> order {result.order}, band error {result.band_error:.3e} "
          f"({result.termination})")

    f = np.logspace(np.log10(band[0]), np.log10(band[1]), 400)
    H = ecmor.frequency_response(model, f)[:, 0, 0]  # one input, one output
    Hr = ecmor.frequency_response(result.rom, f)[:, 0, 0]
    sigma, sigma_r, error = np.abs(H), np.abs(Hr), np.abs(H - Hr) / np.abs(H)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        for k in range(0, len(f), 50):
            print(f"  f = {f[k]:.3e} Hz   |H| = {sigma[k]:.5e}   |Hr| = {sigma_r[k]:.5e}   "
                  f"relative error {error[k]:.2e}")
        print("(install python3-matplotlib for the plot)")
        return
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(7, 6))
    top.loglog(f, sigma, label=f"full, N = {model.N}")
    top.loglog(f, sigma_r, "--", label=f"reduced, order {result.order}")
    top.set_ylabel("sigma_max(H)")
    top.legend()
    bottom.loglog(f, error)
    bottom.axhline(1e-3, color="k", lw=0.8)
    bottom.set_xlabel("f [Hz]")
    bottom.set_ylabel("relative error")
    out = args.plot or "triple_chain_sigma.png"
    fig.savefig(out, dpi=120)
    print(f"sigma plot: {out}")


if __name__ == "__main__":
    main()
