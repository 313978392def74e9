"""Fit a GPI model to measured data: Festo 10 mm muscle, force [N] (column 0)
against pressure [kPa] (column 1), if the shared data set is present; else to
data simulated here (and say so).  Usage: 02_fit_measured.py [csv]"""
import os
import sys

import numpy as np

import hysteron

path = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/pam-force-pressure/festo10mm_20cm_test8.csv"
if os.path.exists(path):
    data = np.loadtxt(path, delimiter=",")
    x, y = data[::5, 1], data[::5, 0]  # pressure [kPa], force [N]; 15000 -> 3000 samples
    print(f"measured data: {path} ({len(x)} samples used)")
else:
    gpi = {"model": "gpi", "c": [300.0, 0.004, -0.5, 150.0], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.01,
           "alpha": 20.0}
    k = np.arange(400)
    x = np.concatenate([a * (1.0 - np.abs(2.0 * k / 400.0 - 1.0)) for a in (600, 500, 400, 300, 200, 100)])
    y = hysteron.simulate_record(gpi, x) + 0.5 * np.sin(0.7 * np.arange(len(x)))
    print(f"{path} not found: fitting data simulated in this example instead")

r = hysteron.fit(x, y, model="gpi", num_operators=10)
print(r["report"])
good = r["status"] not in ("invalid_input", "failed") and r["train"]["r2"] > 0.95
print(f"R^2 = {r['train']['r2']:.5f}, RMS = {r['train']['rms']:.3g} N: {'ok' if good else 'FAILED'}")
sys.exit(0 if good else 1)
