"""Compensated tracking on the simulated rig (GPI paper, Fig. 10): identify a
GPI model from the Fig. 4 pressure input, then track the Eq. 18 sinusoid with
inverse-GPI feedforward + the PID of Table 3. Fails if the maximum tracking
error after the first second exceeds 8 mm."""
import sys

import numpy as np

import hysteron

ts = 1e-3
rig = hysteron.PamRig(seed=1)
ident = rig.run_pressure(hysteron.gpi_identification_pressure(ts), control_period=ts)
p, x = ident["pressure_mpa"][::10], ident["contraction_measured_mm"][::10]
fit = hysteron.fit(p, x, model="gpi", num_operators=10)
print(f"identification: {fit['status']}, RMS {fit['train']['rms']:.3f} mm")
if fit["status"] in ("invalid_input", "failed"):
    sys.exit(1)

# pressure commands clamped to the muscle's rating (0..0.6 MPa); left unset, the limits would be the
# model's input range (the fit's measured pressures)
p_max = rig.params["muscle"]["max_pressure"] * 1e-6  # [MPa]
ctl = hysteron.FeedforwardPidController(fit["model"], hysteron.Pid.gpi_paper(ts), pressure_limits=(0.0, p_max),
                                        sample_time=ts)
ref = hysteron.gpi_sinusoid_reference(ts, 10.0)  # contraction [m]
rig.reset()
steps = round(ts / rig.dt)
measured = np.empty(len(ref))
y = 0.0
for k, r in enumerate(ref):
    cmd = ctl.step(r, r, y)
    for _ in range(steps):
        o = rig.step(pressure_command=cmd)
    y = o["contraction_measured"]
    measured[k] = y
err = (ref[1:] - measured[:-1]) * 1e3
err = err[int(1.0 / ts):]
print(f"tracking the Eq. 18 sinusoid for 10 s: max error {np.max(np.abs(err)):.3f} mm, "
      f"RMS {np.sqrt(np.mean(err ** 2)):.3f} mm (paper: 2.659, 0.8701)")
sys.exit(0 if np.max(np.abs(err)) < 8.0 else 1)
