#!/usr/bin/env python3
"""The reference PI of issue 10, written as the 20-line script a user would write
(numpy + scipy.optimize.nnls), independent of hysteron's C++ reference_pi:
a classical PI with N play operators, thresholds r_i = i span / (2 N), i = 1..N
(evenly spaced over half the training input span), operators relaxed at the first
sample, a free linear term and an output offset, weights >= 0 by NNLS. Like the C++
reference_pi (and every fit), a decreasing record is fitted as -y (the sign of the
least-squares line), so that a flipped sensor does not change the reference.

Usage: reference_pi.py TRAIN.csv IN OUT [--train A:B] [--validate C:D] [--validate-data V.csv ...]
Prints one JSON object: train and validation RMS in % of the measured span.
"""
import argparse
import json

import numpy as np
from scipy.optimize import nnls


def plays(x, r):
    y = np.full(len(r), x[0])  # relaxed at the first sample
    out = np.empty((len(x), len(r)))
    for k, v in enumerate(x):
        y = np.maximum(v - r, np.minimum(v + r, y))
        out[k] = y
    return out


def regressors(x, r):
    P = plays(x, r)
    return np.column_stack([x, -x, P])  # q = t0 - t1 is free; p_i >= 0


def rng(text, n):
    a, b = (text or ":").split(":")
    return slice(int(a) if a else 0, int(b) if b else n)


def pct(y, yhat, s):
    e = y[s] - yhat[s]
    return 100 * np.sqrt(np.mean(e ** 2)) / np.ptp(y[s])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data"), ap.add_argument("inp", type=int), ap.add_argument("out", type=int)
    ap.add_argument("--train"), ap.add_argument("--validate"), ap.add_argument("--validate-data", action="append", default=[])
    ap.add_argument("--n", type=int, default=10)
    a = ap.parse_args()
    d = np.genfromtxt(a.data, delimiter=",")
    x, y = d[:, a.inp], d[:, a.out]
    tr = rng(a.train, len(x))
    r = np.arange(1, a.n + 1) * np.ptp(x[tr]) / (2 * a.n)
    x0 = x[0]
    A = regressors(x[: tr.stop] - x0, r)[tr]
    sign = -1.0 if np.cov(x[tr], y[tr])[0, 1] < 0 else 1.0
    b = sign * y[tr]
    Am, bm = A.mean(axis=0), b.mean()  # the free offset, eliminated by centring
    t, _ = nnls(A - Am, b - bm)
    c = bm - Am @ t
    predict = lambda xs: sign * (regressors(xs - x0, r) @ t + c)
    res = {"train": pct(y, predict(x), tr), "validate": []}
    if a.validate_data:
        for f in a.validate_data:
            v = np.genfromtxt(f, delimiter=",")
            xv, yv = v[:, a.inp], v[:, a.out]
            res["validate"].append(pct(yv, predict(xv), rng(a.validate, len(xv))))
    elif a.validate:
        res["validate"].append(pct(y, predict(x), rng(a.validate, len(x))))
    print(json.dumps(res))


if __name__ == "__main__":
    main()
