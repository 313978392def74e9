"""The stationarity test of the LM fits, side by side: mpi-asym (n = 10) on the piezo
record (input col 3, output col 2, fit on rows 21286:33143, validate on 33143:50001, as
bench/real_data_table.sh), with FitOptions::stall_tolerance = 0 (Ceres' tolerances only)
and with the default 1e-5, three runs each, alternating.

Usage: /usr/bin/python3 bench/stall_compare.py [BUILD_DIR]   (default: build)
"""
import os
import sys

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(root, sys.argv[1] if len(sys.argv) > 1 else "build", "python"))
import numpy as np  # noqa: E402
import hysteron  # noqa: E402

path = os.path.join(root, "..", "shared", "data", "piezo-sine", "piezo_150V_1Hz.csv")
if not os.path.exists(path):
    print(f"stall_compare: {path} not found; skipped")
    sys.exit(0)
d = np.genfromtxt(path, delimiter=",")
x, y = d[:, 3].copy(), d[:, 2].copy()
for tol in (0.0, 1e-5) * 3:
    r = hysteron.fit(x, y, model="mpi-asym", train=(21286, 33143), stall_tolerance=tol)
    v = hysteron.evaluate(r["model"], x, y, range=(33143, 50001))
    print(f"stall_tolerance={tol:g}: {r['status']}, {r['total_iterations']} iterations, {r['time_s']:.3f} s, "
          f"cost {r['final_cost']:.6f}, validation RMS {v['rms_percent_span']:.6f} % of span")
