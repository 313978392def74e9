#!/usr/bin/env python3
"""Why no rate-independent kind fitted on the rig's major loop predicts its minor loops to
1 mm (issue 14's 2x target; docs/models.md, "Comparison on the simulated rig").

Record A of bench/rig_kinds_table.py (the gpi-pid identification run, rig seed 1, 200 Hz):
0.2 Hz triangles from 0 MPa with peaks 0.6, 0.5, ..., 0.1 MPa. The fit sees the first
loop only, whose ascending branch starts from the rig at rest (its Bouc-Wen friction
state z = 0, a demagnetised state). Every later ascending branch starts at 0 MPa after a
descent (z at its lower bound). Model-free: the measured ascending branch of each later
loop minus the first loop's ascending branch at the same pressure. Then, for kp, gpi and
mpi-asym fitted on the first loop: their mean error on each later loop's ascending and
descending half.
Usage: bench/rig_ascent_check.py [PYTHON_MODULE_DIR]   (default: build/python)
"""
import os
import sys

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, sys.argv[1] if len(sys.argv) > 1 else os.path.join(root, "build", "python"))
import hysteron as h  # noqa: E402

TC, EVERY = 1e-3, 5
r = h.PamRig(seed=1).run_pressure(np.asarray(h.gpi_identification_pressure(TC), dtype=float), TC)
x, y = r["pressure_mpa"][::EVERY].copy(), r["contraction_measured_mm"][::EVERY].copy()
L = int(round(5.0 / (TC * EVERY)))  # samples per loop (5 s)
x0, y0 = x[:L // 2], y[:L // 2]
order = np.argsort(x0)

print("| loop | peak [MPa] | measured ascent - first ascent [mm] (mean / RMS) |"
      + "".join(f" {k} error ascent / descent [mm] |" for k in ("kp", "gpi", "mpi-asym")))
print("|---|---|---|---|---|---|")
fits = {k: h.Model(h.fit(x, y, model=k, train=(0, L))["model"]).simulate(x) for k in ("kp", "gpi", "mpi-asym")}
for k in range(1, len(x) // L):
    xs, ys = x[k * L:k * L + L // 2], y[k * L:k * L + L // 2]
    ok = xs > 0.05
    d = ys[ok] - np.interp(xs[ok], x0[order], y0[order])
    cells = []
    for name, yh in fits.items():
        e = np.asarray(yh) - y
        cells.append(f" {e[k * L:k * L + L // 2].mean():+.2f} / {e[k * L + L // 2:(k + 1) * L].mean():+.2f} |")
    print(f"| {k} | {xs.max():.2f} | {d.mean():+.2f} / {np.sqrt((d ** 2).mean()):.2f} |" + "".join(cells))
