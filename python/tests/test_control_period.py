"""run_experiment(control_period=...) and run_sweep(control_period=...): the loop's sample time
[s] reaches the experiment (result's "controller" records it, the time series step by it); a bad
period is hysteron.Error before anything runs or is written."""
import math

import numpy as np
import pytest

import hysteron

FAST = dict(seed=1, learning_periods=0, adaptive=False, model="gpi")


def test_run_experiment_runs_at_the_period_given(tmp_path):
    r = hysteron.run_experiment("gpi-pid", control_period=0.0005, out=str(tmp_path / "o"), **FAST)
    assert r["runs"]
    for run in r["runs"]:
        assert run["controller"]["sample_time_s"] == 0.0005, run["variant"]
        assert np.allclose(np.diff(run["t"]), 0.0005, rtol=0, atol=1e-12), run["variant"]
    # the lead is identified in seconds: the same lead at 1 ms is half as many samples (+-1 of rounding)
    one = hysteron.run_experiment("gpi-pid", **FAST)
    lead = {x["variant"]: x["controller"]["feedforward_lead_samples"] for x in one["runs"]}
    half = {x["variant"]: x["controller"]["feedforward_lead_samples"] for x in r["runs"]}
    assert lead["compensated"] >= 10
    assert abs(2 * lead["compensated"] - half["compensated"]) <= 2, (lead, half)
    # the period is said where a reader looks: the summary (result.json's) and the table
    assert r["summary"]["control_period_s"] == 0.0005 and one["summary"]["control_period_s"] == 0.001
    assert "control period 0.5 ms" in r["table"] and "control period 1 ms" in one["table"]


@pytest.mark.parametrize("period, message", [
    (math.nan, "control_period = nan s must be within"),
    (0.0, "control_period = 0 s must be within"),
    (0.03, "control_period = 0.03 s must be within"),
    (0.00025, "is not a whole multiple of the rig's simulation.dt"),
])
def test_bad_control_period_is_an_error_and_writes_nothing(tmp_path, period, message):
    out = tmp_path / "o"
    with pytest.raises(hysteron.Error, match=message):
        hysteron.run_experiment("gpi-pid", control_period=period, out=str(out), **FAST)
    assert not out.exists()
    with pytest.raises(hysteron.Error, match=message):
        hysteron.run_sweep("gpi-pid", vary=["load.mass=35"], control_period=period, out=str(tmp_path / "s.csv"))
    assert not (tmp_path / "s.csv").exists()
