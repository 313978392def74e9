"""From an experiment to a deployed loop (docs/deploy.md, "From an experiment to a
deployment"): run gpi-pid's experiment with 3 learning periods, rebuild its learning loop
from result.json's "controller" and best_model.json with the classes a deployment uses
(FeedforwardPidController, IterativeLearning), warm-start the learning from the correction
the run ended with, and track 2 more periods on the rig with another noise seed (another
day on the rig), beside the same loop started cold. The rig starts vented at rest, so each
period's RMS error is taken from 1 s on. Fails unless the warm start's error is below half
the cold start's in both periods."""
import json
import math
import os
import sys
import tempfile

import numpy as np

import hysteron

with tempfile.TemporaryDirectory() as d:
    hysteron.run_experiment("gpi-pid", learning_periods=3, out=d)
    with open(os.path.join(d, "result.json")) as f:
        run = json.load(f)["learning"]  # one reference: the run itself
    with open(os.path.join(d, "best_model.json")) as f:
        best_model_json = json.load(f)
    loop_csv = np.genfromtxt(os.path.join(d, "tracking_learning_sine.csv"), delimiter=",", names=True)
    ctl = run["controller"]
    p, q = ctl["pid"], ctl["learning"]
    ts = ctl["sample_time_s"]  # the control period
    inf = math.inf
    pid = hysteron.Pid(kp=p["kp_mpa_per_m"], ki=p["ki_mpa_per_m_s"], kd=p["kd_mpa_s_per_m"],
                       sample_time=p["sample_time_s"], derivative_filter=p["derivative_filter_s"],
                       out_min=-inf if p["out_min_mpa"] is None else p["out_min_mpa"],
                       out_max=inf if p["out_max_mpa"] is None else p["out_max_mpa"],
                       anti_windup=p["anti_windup"], tracking_time=p["tracking_time_s"],
                       setpoint_weight_p=p["setpoint_weight_p"], setpoint_weight_d=p["setpoint_weight_d"])

n = q["period_samples"]
# the reference over one period and the correction the run's last period applied [m]
r = loop_csv["reference_mm"][:n] * 1e-3
learnt = loop_csv["correction_mm"][-n:] * 1e-3

# the feedforward's preview: lead samples ahead, through the shaper if the run had one
lead = ctl["feedforward_lead_samples"]
preview = r.copy()
if "shaper" in ctl:
    z = ctl["shaper"]
    k = np.arange(n)
    a, delay = z["advance_samples"], z["delay_samples"]
    preview = z["a1"] * r[(k + a) % n] + z["a2"] * r[(k + a - delay) % n]


def track(warm):
    """RMS error [mm] from 1 s on of 2 periods, the learning warm-started or not."""
    ilc = hysteron.IterativeLearning(period=n, gain=q["gain"], lead=q["lead_samples"], half_width=q["half_width"],
                                     lookahead=q["lookahead"],
                                     rise_tolerance=inf if q["rise_tolerance"] is None else q["rise_tolerance"],
                                     hold_after_cuts=q["hold_after_cuts"], max_gain=q["max_gain"])
    if warm:
        ilc.reset(learnt)
    ff = ctl["feedforward"]  # the run's pressure limits [MPa], model scale and lag
    lo, hi = ff["pressure_min_mpa"], ff["pressure_max_mpa"]
    fb = hysteron.FeedforwardPidController(best_model_json, pid, pressure_limits=(lo, hi),
                                           model_scale=ff["model_scale_per_m"],
                                           lag_time_constant=ff["lag_time_constant_s"], sample_time=ts)
    rig = hysteron.PamRig(seed=7)
    rig.reset()
    substeps = round(ts / rig.dt)
    skip = round(1.0 / ts)
    y, rms = 0.0, []
    for _ in range(2):
        e2 = 0.0
        for k in range(n):
            e = r[k] - y
            if k >= skip:
                e2 += e * e
            cmd = fb.step(r[k] + ilc.correction(0), preview[(k + lead) % n] + ilc.correction(lead), y)
            ilc.step(0.0 if cmd <= lo or cmd >= hi else e)  # no learning at a pressure limit
            for _ in range(substeps):
                o = rig.step(pressure_command=cmd)
            y = o["contraction_measured"]
        rms.append(math.sqrt(e2 / (n - skip)) * 1e3)
    return rms


cold, warm = track(False), track(True)
periods = " ".join(f"{x['rms_error_mm']:.3f}" for x in run["periods"])
print(f"experiment (seed 1): RMS per period {periods} mm")
print(f"the loop rebuilt from result.json on the rig (seed 7), RMS from 1 s on per period [mm]: "
      f"cold start {cold[0]:.3f} {cold[1]:.3f}, warm start {warm[0]:.3f} {warm[1]:.3f}")
sys.exit(0 if all(w < 0.5 * c for w, c in zip(warm, cold)) else 1)
