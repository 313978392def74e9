#!/usr/bin/python3
"""Peer comparison: the 8-parameter GPI of Eqs. 5-8 (n = 10 operators) fitted by
scipy.optimize.least_squares (method 'trf', bounds of Eq. 13 plus q, alpha > 0,
2-point finite-difference Jacobian), on the same samples hysteron fits.

Usage: /usr/bin/python3 bench/peer_scipy.py DATA.csv [--n 10]
DATA.csv: two columns with a header "input,output" (written by bench/compare_scipy.sh:
the piezo record ../shared/data/piezo-sine/piezo_150V_1Hz.csv, every 5th row
starting at row 0, i.e. rows 0, 5, ..., 50000 -> 10,001 samples; input = column 3
[V], output = column 2 [um]).
Prints one JSON line: time_s (least_squares only), rms, nfev, njev, status, params.
"""
import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares


def gpi_output(theta, x, n):
    c0, c1, c2, c3, q, rho, tau, alpha = theta
    u = c0 * np.tanh(c1 * x + c2) + c3  # Eq. 5
    r = alpha * np.arange(1, n + 1)  # Eq. 7
    p = rho * np.exp(-tau * r)  # Eq. 8
    y = np.zeros(n)  # virgin state (Eq. 2)
    out = np.empty_like(x)
    for k in range(x.size):  # Eqs. 4, 6
        y = np.maximum(u[k] - r, np.minimum(u[k] + r, y))
        out[k] = q * u[k] + p @ y
    return out


def main():
    path = sys.argv[1]
    n = int(sys.argv[sys.argv.index("--n") + 1]) if "--n" in sys.argv else 10
    data = np.loadtxt(path, delimiter=",", skiprows=1)
    x, yt = data[:, 0], data[:, 1]
    # data-derived initial guess (no per-dataset tuning): envelope spans the data
    xc, xs = 0.5 * (x.max() + x.min()), 0.5 * (x.max() - x.min())
    yc, ys = 0.5 * (yt.max() + yt.min()), 0.5 * (yt.max() - yt.min())
    theta0 = np.array([ys, 1.0 / xs, -xc / xs, yc, 0.5, 0.5 / n, 1.0 / ys, 0.5 * ys / n])
    eps = 1e-9
    lo = np.array([eps, eps, -np.inf, -np.inf, eps, eps, eps, eps])
    hi = np.full(8, np.inf)

    def resid(th):
        return yt - gpi_output(th, x, n)  # Eq. 12

    t0 = time.perf_counter()
    res = least_squares(resid, theta0, bounds=(lo, hi), method="trf", jac="2-point")
    t = time.perf_counter() - t0
    rms = float(np.sqrt(np.mean(res.fun ** 2)))
    print(json.dumps({"tool": "scipy", "time_s": t, "rms": rms, "nfev": int(res.nfev),
                      "njev": int(res.njev) if res.njev is not None else None, "status": int(res.status),
                      "message": res.message, "params": res.x.tolist(), "samples": int(x.size)}))


if __name__ == "__main__":
    main()
