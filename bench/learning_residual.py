#!/usr/bin/env python3
"""Where a learning run's remaining error is: its last period against the one before, and the
error's spectrum in bands (docs/history.md, part 2).

    build/hysteron demo            # writes out/demo/<experiment>/tracking_learning_<reference>.csv
    /usr/bin/python3 bench/learning_residual.py out/demo/mpi-openloop/tracking_learning_triangle.csv

A learning run is 10 periods of its reference, logged at the control period (column t_s).
Errors: reference - measured (as the experiment scores them) and reference - actual (without
the sensor's noise)."""
import sys

import numpy as np

BANDS = [0, 0.5, 1, 2, 3, 4, 5, 6, 8, 10, 15, 20, 50]


def main(path, periods=10):
    d = np.genfromtxt(path, delimiter=",", names=True)
    t, r = d["t_s"], d["reference_mm"]
    dt = t[1] - t[0]
    n = len(t) // periods
    for label, col in (("measured", "measured_mm"), ("actual", "actual_mm")):
        e = r - d[col]
        last, prev = e[-n:], e[-2 * n:-n]
        k = int(np.argmax(np.abs(last)))
        print(f"{label:8s} last period: RMS {np.sqrt(np.mean(last ** 2)):.3f} mm, max {np.abs(last).max():.3f} mm "
              f"at {k * dt:.3f} s of {n * dt:.0f} s; period before: RMS {np.sqrt(np.mean(prev ** 2)):.3f}, "
              f"max {np.abs(prev).max():.3f}; RMS of their difference {np.sqrt(np.mean((last - prev) ** 2)):.3f} mm")
    e = (r - d["actual_mm"])[-n:]
    amp = np.fft.rfft(e) / n * 2  # one-sided amplitudes
    f = np.fft.rfftfreq(n, dt)
    for lo, hi in zip(BANDS, BANDS[1:] + [f[-1] + 1]):
        s = (f >= lo) & (f < hi)
        print(f"  {lo:5.1f}-{hi:6.1f} Hz: RMS {np.sqrt(np.sum(np.abs(amp[s]) ** 2) / 2):.4f} mm")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
