"""Simulate a GPI model (GPI paper, Eqs. 5-8) on a decaying triangle input and
invert its output exactly: the input must come back to 1e-9."""
import sys

import numpy as np

import hysteron

gpi = {"model": "gpi", "envelope": "tanh", "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "n": 10,
       "rho": 0.4, "tau": 0.1, "alpha": 2.0, "input_limits": [0.0, 0.6]}

k = np.arange(400)
x = np.concatenate([a * (1.0 - np.abs(2.0 * k / 400.0 - 1.0)) for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)])
y = hysteron.Model(gpi).simulate(x)          # contraction [mm]
back = hysteron.Inverse(gpi).simulate(y)     # pressure [MPa]
err = np.max(np.abs(back - x))
print(f"GPI: {len(x)} samples, output {y.min():.2f}..{y.max():.2f} mm; "
      f"inverse round trip max error {err:.3g} MPa")
sys.exit(0 if err < 1e-9 else 1)
