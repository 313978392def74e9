"""Tests of the identification, rig, controller, experiment and report bindings."""
import json
import math
import os
import pathlib
import re
import tempfile

import numpy as np
import pytest

import hysteron

TRUE_GPI = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1,
            "alpha": 2.0}


def decaying_triangles():
    """The GPI paper's Fig. 4 input shape: triangles of amplitude 0.6 down to 0.1 MPa."""
    return np.concatenate([np.interp(np.linspace(0, 1, 400), [0, 0.5, 1], [0, a, 0])
                           for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)])


def scale_free(model):
    """Combinations of the GPI parameters that the exact scale symmetry leaves unchanged."""
    c0, c1, c2, _ = model["c"]
    return np.array([c1, c2, model["q"] * c0, model["rho"] * c0, model["tau"] * model["alpha"]])


def test_fit_recovers_simulated_gpi():
    x = decaying_triangles()
    y = hysteron.simulate_record(TRUE_GPI, x)
    r = hysteron.fit(x, y, model="gpi", num_operators=10)
    assert r["status"] == "converged" and r["ok"], r["message"]
    assert r["train"]["rms"] < 1e-6 * (y.max() - y.min())
    np.testing.assert_allclose(scale_free(r["model"]), scale_free(TRUE_GPI), rtol=1e-4)
    names = [p["name"] for p in r["parameters"]]
    assert "q" in names and all("std_error" in p for p in r["parameters"])
    # the fitted model dict drives a Model directly
    np.testing.assert_allclose(hysteron.Model(r["model"]).simulate(x), y, atol=1e-6)
    m = hysteron.evaluate(r["model"], x, y, range=(1200, None))
    assert m["n"] == len(x) - 1200 and m["rms"] < 1e-6


def test_fit_reports_invalid_input_without_raising():
    r = hysteron.fit(np.zeros(500), np.zeros(500))
    assert r["status"] == "invalid_input" and not r["ok"] and r["message"]


def test_fit_threads_and_stationarity_options():
    x = decaying_triangles()
    y = hysteron.simulate_record(TRUE_GPI, x) + 0.01 * np.sin(np.arange(len(x)))
    seq = hysteron.fit(x, y, model="mpi-asym", num_starts=2, num_threads=1)
    par = hysteron.fit(x, y, model="mpi-asym", num_starts=2, num_threads=2)
    assert par["final_cost"] == seq["final_cost"] and par["total_iterations"] == seq["total_iterations"]
    # any decrease passes a huge tolerance: each start ends after stall_iterations iterations
    r = hysteron.fit(x, y, model="mpi-asym", num_starts=1, stall_iterations=3, stall_tolerance=1e300, mirror=False)
    assert r["status"] == "converged" and r["total_iterations"] == 3 and "stationary" in r["message"]
    # mpi-asym fits both orientations of the input by default: 3 iterations in each
    r = hysteron.fit(x, y, model="mpi-asym", num_starts=1, stall_iterations=3, stall_tolerance=1e300)
    assert r["status"] == "converged" and r["total_iterations"] == 6 and r["num_starts"] == 2
    bad = hysteron.fit(x, y, stall_tolerance=-1.0)
    assert bad["status"] == "invalid_input" and "stall_tolerance" in bad["message"]


def test_fit_html_report():
    x = decaying_triangles()
    y = hysteron.simulate_record(TRUE_GPI, x) + 0.01 * np.sin(np.arange(len(x)))
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "fit.html")
        hysteron.fit(x, y, report=path, input_axis=("Pressure", "MPa"), output_axis=("Contraction", "mm"))
        html = open(path).read()
        assert html.count("<svg") == 3 and "Pressure [MPa]" in html


def test_rls_converges_to_pi_weights():
    true = {"model": "pi", "q": 0.5, "r": [0.1, 0.2, 0.3], "p": [0.3, 0.2, 0.1]}
    x = decaying_triangles()
    y = hysteron.simulate_record(true, x)
    start = {"model": "pi", "q": 1.0, "r": [0.1, 0.2, 0.3], "p": [0.0, 0.0, 0.0]}
    fitted = hysteron.rls_fit(start, x, y, passes=2)
    np.testing.assert_allclose([fitted["q"]] + fitted["p"], [0.5, 0.3, 0.2, 0.1], atol=1e-6)
    rls = hysteron.Rls(start)
    for a, b in zip(x, y):
        rls.step(a, b)
    assert rls.theta.shape == (4,)


def test_rig_is_deterministic_and_seeded():
    profile = np.full(300, 0.3)
    a = hysteron.PamRig(seed=3).run_pressure(profile)
    b = hysteron.PamRig(seed=3).run_pressure(profile)
    c = hysteron.PamRig(seed=4).run_pressure(profile)
    for k in ("t", "pressure_mpa", "contraction_mm", "contraction_measured_mm"):
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["pressure_mpa"], c["pressure_mpa"])  # sensor noise differs
    assert a["t"][-1] == pytest.approx(0.3)
    assert a["contraction_mm"][-1] > 5.0  # the muscle contracts under 0.3 MPa


def test_rig_params_from_dict_and_errors():
    rig = hysteron.PamRig({"load": {"mass": 10.0}}, seed=1)
    assert rig.params["load"]["mass"] == 10.0
    with pytest.raises(hysteron.Error, match="mass"):
        hysteron.PamRig({"load": {"mass": -1.0}})
    with pytest.raises(hysteron.Error, match="nonsense"):
        hysteron.PamRig({"load": {"nonsense": 1.0}})


def test_rig_statics_with_a_return_spring():
    # a horizontal rig whose spring matches the nominal weight balances like the hanging load;
    # a stiffer spring holds the muscle shorter on both branches and lifts off at the same pressure
    nominal = hysteron.rig_statics()
    flat = hysteron.rig_statics({"load": {"gravity": 0.0, "spring_preload": 20.0 * 9.81}})
    stiff = hysteron.rig_statics({"load": {"gravity": 0.0, "spring_preload": 20.0 * 9.81, "spring_rate": 3000.0}})
    np.testing.assert_allclose(flat["rising_m"], nominal["rising_m"], rtol=1e-9, atol=1e-12)
    assert flat["weight_n"] == 0.0 and flat["return_force_rest_n"] == pytest.approx(196.2)
    assert stiff["lift_off_pa"] == pytest.approx(nominal["lift_off_pa"], rel=1e-6)
    moving = nominal["rising_m"] > 0
    assert np.all(stiff["rising_m"][moving] < nominal["rising_m"][moving])
    assert stiff["return_force_stroke_n"] == pytest.approx(196.2 + 3000.0 * stiff["stroke_m"])
    assert nominal["fall_speed_rest_m_s"] == pytest.approx(196.2 / 400.0)
    assert stiff["fall_speed_stroke_m_s"] == pytest.approx((196.2 + 3000.0 * stiff["stroke_m"]) / 400.0)
    assert nominal["unusable"] == ""
    assert "cannot lift" in hysteron.rig_statics({"load": {"spring_preload": 5000.0}})["unusable"]
    assert nominal["units"]["load.spring_rate"] == "N/m" and nominal["units"]["load.mass"] == "kg"
    with pytest.raises(hysteron.Error, match="spring_rate"):
        hysteron.rig_statics({"load": {"spring_rate": -1.0}})


def test_pid_limits_and_antiwindup():
    pid = hysteron.Pid(kp=100.0, ki=10.0, out_min=-1.0, out_max=2.0)
    assert pid.step(10.0, 0.0) == 2.0 and pid.saturated
    for _ in range(100):
        pid.step(10.0, 0.0)
    assert pid.integral <= 2.0 + 1e-12  # conditional integration stops at the limit
    assert pid.step(-10.0, 0.0) == -1.0
    assert pid.step(float("nan"), 0.0) == -1.0 and pid.faults == 1
    gp = hysteron.Pid.gpi_paper()
    assert gp.params["kp"] == pytest.approx(5.0) and gp.params["out_max"] == pytest.approx(0.6)


def test_pid_limit_cycle_guard():
    # P control at twice the ultimate gain of a 50-sample delay: the loop rings between the limits.
    # The guard (period about the ring's, 100 samples at 1 ms) cuts the gains until it stops.
    def run(pid, n=8000, delay=50):
        line, y, errors = [0.0] * delay, 0.0, []
        for k in range(n):
            errors.append(1.0 - y)
            line.append(pid.step(1.0, y))
            y = line.pop(0)  # a pure delay: the ultimate gain is 1, the period 2 delays
        last = np.array(errors[-2000:])
        return last.max() - last.min()  # the ring's swing over the last 2 s
    ringing = hysteron.Pid(kp=2.0, ki=0.0, out_min=-3.0, out_max=3.0)
    assert run(ringing) > 1.0 and ringing.gain_scale == 1.0 and ringing.guard_cuts == 0
    guarded = hysteron.Pid(kp=2.0, ki=0.0, out_min=-3.0, out_max=3.0)
    guarded.set_guard(period=0.1, amplitude=0.05)
    assert guarded.params["guard"]["period"] == 0.1
    again = hysteron.Pid(**guarded.params)  # the params are the constructor's arguments, the guard too
    assert again.params == guarded.params
    with pytest.raises(hysteron.Error, match="unknown key 'periods'"):
        hysteron.Pid(guard={"periods": 0.1})
    held = run(guarded)
    assert guarded.guard_cuts >= 2 and guarded.gain_scale < 0.5  # 2 x 0.63^2 = 0.79 < 1 is stable
    assert held < 1e-6  # settled (P alone keeps an offset of 1 / (1 + K), no ring around it)
    with pytest.raises(hysteron.Error, match="pid.guard.factor"):
        guarded.set_guard(period=0.1, amplitude=0.05, factor=1.0)
    guarded.reset()
    assert guarded.gain_scale == 1.0 and guarded.guard_cuts == 0


def test_inverse_feedforward_round_trip():
    model = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1,
             "alpha": 2.0, "input_limits": [0.0, 0.6]}
    ff = hysteron.InverseFeedforward(model)
    fwd = hysteron.Model(model)
    for d_mm in np.linspace(5.0, 40.0, 30):
        p = ff.step(d_mm / 1000.0)
        assert 0.0 <= p <= 0.6
        assert fwd.step(p) == pytest.approx(d_mm, abs=1e-9)
    ctl = hysteron.FeedforwardPidController(model, hysteron.Pid.gpi_paper())
    assert 0.0 <= ctl.step(0.02, 0.02, 0.0) <= 0.6


def test_open_loop_and_cascade_controllers():
    # The open loop: p_d = FF (the feedforward twin), command clamp(p_d + 0.5 (p_d - p)); with a PID,
    # p_d + PID clamped. The cascade: p_d = the FeedforwardPidController twin's command, duty
    # clamp(20 (p_d - p), -1, 1) with the paper's P loop and the default PWM.
    model = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1,
             "alpha": 2.0, "input_limits": [0.0, 0.6]}
    ff = hysteron.InverseFeedforward(model)
    ol = hysteron.OpenLoopController(model)
    twin = hysteron.FeedforwardPidController(model, hysteron.Pid.gpi_paper())
    cas = hysteron.CascadePwmController(model)
    ts = np.arange(2000) * 1e-3
    ref = (20.0 + 15.0 * np.sin(2 * np.pi * 0.5 * ts)) / 1000.0
    p = 0.1
    saturated = 0
    for r, t in zip(ref, ts):
        p_d = ff.step(r)
        u = ol.step(r, r, 0.9 * r, p)
        assert u == pytest.approx(min(0.6, max(0.0, p_d + 0.5 * (p_d - p))), abs=1e-15)
        p_valves = 0.3 + 0.25 * np.sin(2 * np.pi * 1.3 * t)  # the valves' chamber, independently
        duty = cas.step(r, r, 0.9 * r, p_valves)
        assert cas.desired_pressure == pytest.approx(twin.step(r, r, 0.9 * r), abs=1e-15)
        expected = min(1.0, max(-1.0, 20.0 * (cas.desired_pressure - p_valves)))
        assert duty == pytest.approx(expected, abs=1e-15)
        saturated += abs(expected) == 1.0
        p += 0.2 * (u - p)
    assert 0 < saturated < len(ref)
    with_pid = hysteron.OpenLoopController(model, hysteron.Pid(kp=5.0, ki=1.0), pressure_gain=0.0)
    assert with_pid.step(0.02, 0.02, 0.0, 0.3) > hysteron.OpenLoopController(model, pressure_gain=0.0).step(
        0.02, 0.02, 0.0, 0.3)
    # the PWM's dead band and an inner PI; bad parameters name the field
    cas2 = hysteron.CascadePwmController(model, pressure_pid=hysteron.Pid(kp=20.0, out_min=-1, out_max=1),
                                         pwm={"deadband": 0.5})
    assert cas2.step(0.02, 0.02, 0.02, 0.0) == pytest.approx(0.5)  # u = 1 (limited): 1 - dead band
    assert cas2.step(0.02, 0.02, 0.02, cas2.desired_pressure) == 0.0  # |u| <= dead band
    with pytest.raises(hysteron.Error, match="pwm.max_duty"):
        hysteron.CascadePwmController(model, pwm={"max_duty": 1.5})
    with pytest.raises(ValueError, match="unknown key"):
        hysteron.CascadePwmController(model, pwm={"dutty": 0.5})
    with pytest.raises(hysteron.Error, match="pressure_gain"):
        hysteron.OpenLoopController(model, pressure_gain=-1.0)
    assert repr(ol).startswith("OpenLoopController(") and repr(cas).startswith("CascadePwmController(")
    # controller_from builds each kind from a "controller" dict (result.json's numbers) and gives
    # the same commands as the classes built by hand
    ff = {"pressure_min_mpa": 0.0, "pressure_max_mpa": 0.6, "model_scale_per_m": 1000.0, "lag_time_constant_s": 0.0}
    pid = {"kp_mpa_per_m": 20.0, "ki_mpa_per_m_s": 0.0, "kd_mpa_s_per_m": 0.0, "sample_time_s": 1e-3,
           "derivative_filter_s": 0.0, "out_min_mpa": -1.0, "out_max_mpa": 1.0, "anti_windup": "conditional",
           "tracking_time_s": 0.0, "setpoint_weight_p": 1.0, "setpoint_weight_d": 0.0}
    common = {"feedforward": ff, "sample_time_s": 1e-3, "feedforward_lead_samples": 0}
    ol2 = hysteron.controller_from(dict(common, loop="open_loop", pressure_gain=0.5), model)
    cas3 = hysteron.controller_from(dict(common, loop="cascade_pwm", pressure_pid=pid,
                                         pwm={"gain": 1.0, "deadband": 0.0, "min_duty": 0.0, "max_duty": 1.0,
                                              "resolution": 0.0}), model)
    assert isinstance(ol2, hysteron.OpenLoopController) and isinstance(cas3, hysteron.CascadePwmController)
    ol.reset()
    for r in ref[:200]:
        assert ol2.step(r, r, r, 0.2) == ol.step(r, r, r, 0.2)
    assert -1.0 <= cas3.step(0.02, 0.02, 0.0, 0.1) <= 1.0 and cas3.desired_pressure > 0.0


def test_iterative_learning_on_a_lagged_loop():
    """The learning update around y_k = a y_(k-1) + (1 - a) u_(k-1), u = r + c: the error of each
    period falls, to under 5 % of the first period's within 15 (the same loop as the C ABI's test)."""
    n, a = 200, 0.8
    ilc = hysteron.IterativeLearning(period=n, gain=0.5, lead=2, half_width=4, lookahead=3)
    assert "period=200" in repr(ilc) and "half_width=4" in repr(ilc)
    r = np.sin(2 * np.pi * np.arange(n) / n)
    y = u = 0.0
    rms = []
    saved = np.empty(n)
    for j in range(15):
        e2 = 0.0
        for k in range(n):
            y = a * y + (1 - a) * u
            saved[k] = ilc.correction(0)  # the last period's is kept for the warm start below
            u = r[k] + saved[k]
            e = r[k] - y
            e2 += e * e
            ilc.step(e)
        rms.append(math.sqrt(e2 / n))
    assert all(b <= a_ * (1 + 1e-9) for a_, b in zip(rms, rms[1:])), rms
    assert rms[-1] < 0.05 * rms[0]
    assert ilc.iteration == 15 and ilc.phase == 0 and ilc.gain == 0.5 and not ilc.held
    ilc.correction(3)
    with pytest.raises(ValueError, match="lookahead = 3"):
        ilc.correction(4)
    ilc.step(float("nan"))
    assert ilc.faults == 1 and ilc.phase == 1
    ilc.reset()
    assert ilc.phase == 0 and ilc.iteration == 0 and ilc.correction(0) == 0.0
    # warm start from the 15th period's correction: the plant at rest, the first period applies it
    with pytest.raises(hysteron.Error, match="has 199 values"):
        ilc.reset(saved[:-1])
    ilc.reset(saved)
    y = u = e2 = 0.0
    for k in range(n):
        y = a * y + (1 - a) * u
        assert ilc.correction(0) == saved[k]
        u = r[k] + ilc.correction(0)
        e2 += (r[k] - y) ** 2
        ilc.step(r[k] - y)
    assert math.sqrt(e2 / n) < 0.2 * rms[0]
    with pytest.raises(hysteron.Error, match="period"):
        hysteron.IterativeLearning(period=1)
    with pytest.raises(hysteron.Error, match="must be < period = 200"):
        hysteron.IterativeLearning(period=n, lead=2, half_width=2000)  # 2 x 287 summed taps
    # a period beyond the documented bound is refused before anything is allocated (10^8 raised
    # MemoryError after 2 s, 10^9 stalled the process)
    with pytest.raises(hysteron.Error, match=r"learning.period = 1000000000: must be <= 10000000"):
        hysteron.IterativeLearning(period=10**9)


def test_non_finite_arguments_are_refused_by_name():
    # each was silent before 2026-11-29 (a NaN metric read as a perfect fit, a NaN reset as virgin)
    with pytest.raises(hysteron.Error, match=r"predicted\[3\] = nan: not finite"):
        hysteron.compute_metrics([1.0, 2.0, 3.0, 4.0], [1.0, 2.0, 3.0, float("nan")])
    with pytest.raises(hysteron.Error, match=r"measured\[0\] = inf"):
        hysteron.compute_metrics([float("inf"), 2.0], [1.0, 2.0])
    m = hysteron.Model({"model": "pi", "r": [0.0, 0.1], "p": [1.0, 0.5]})
    with pytest.raises(hysteron.Error, match="Model.reset_relaxed: x0 = nan"):
        m.reset_relaxed(float("nan"))
    m.reset_relaxed(0.2)  # finite: fine
    with pytest.raises(hysteron.Error, match="Pid.reset: u0 = nan"):
        hysteron.Pid(kp=1.0).reset(float("nan"))
    rig = hysteron.PamRig(seed=1)
    with pytest.raises(hysteron.Error, match="reset_at_pressure: p_gauge = inf"):
        rig.reset_at_pressure(float("inf"))
    with pytest.raises(hysteron.Error, match=r"run_pressure: profile\[1\] = nan"):
        rig.run_pressure(np.array([0.1, np.nan, 0.2]))
    rls = hysteron.Rls({"model": "pi", "r": [0.0, 0.1], "p": [1.0, 0.5]})
    with pytest.raises(hysteron.Error, match="Rls.reset_state: x0 = nan"):
        rls.reset_state("relaxed", float("nan"))
    # a constant input leaves the weights undetermined (q came out near 1e294)
    with pytest.raises(hysteron.Error, match="input is constant"):
        hysteron.fit_weights({"model": "pi", "r": [0.0, 0.1], "p": [1.0, 0.5]}, np.full(50, 0.3), np.linspace(0, 1, 50))


def test_signals():
    p = hysteron.gpi_identification_pressure(0.01)
    assert p.max() == pytest.approx(0.6, abs=1e-9) and p.min() >= 0.0
    w = hysteron.wave_sequence([{"waveform": "sine", "amplitude": 1.0, "period": 1.0}], 0.01)
    assert len(w) >= 100


def test_plot_errors():
    with tempfile.TemporaryDirectory() as d:
        with pytest.raises(hysteron.Error, match="no finite data"):
            hysteron.plot_tracking([], [], [], os.path.join(d, "x.svg"))
        hysteron.plot_tracking([0, 1, 2], [0, 1, 2], [0, 1.1, 2], os.path.join(d, "x.png"))
        assert open(os.path.join(d, "x.png"), "rb").read(4) == b"\x89PNG"


@pytest.mark.skipif(os.environ.get("HYSTERON_SKIP_SLOW") == "1", reason="slow")
def test_model_identification_run_where_the_model_is_not_fitted_on_the_papers_run():
    # mpi-openloop's model is fitted on its input scaled to the references' pressures: that run
    # is returned, written to model_identification.csv and plotted in the report
    with tempfile.TemporaryDirectory() as d:
        r = hysteron.run_experiment("mpi-openloop", seed=1, out=os.path.join(d, "out"), report=os.path.join(d, "r.html"),
                                    learning_periods=0, adaptive=False)
        m = r["model_identification"]
        top = r["summary"]["model_identification_top_mpa"]
        assert 0.0 < top < 0.5
        assert m["t"].shape == m["pressure_command_mpa"].shape == m["contraction_mm"].shape
        assert np.max(m["pressure_command_mpa"]) == pytest.approx(top, abs=1e-9)
        assert np.max(r["identification"]["pressure_command_mpa"]) == pytest.approx(0.5, abs=1e-9)
        back = np.genfromtxt(os.path.join(d, "out", "model_identification.csv"), delimiter=",", names=True)
        assert np.allclose(back["contraction_mm"], m["contraction_mm"], atol=1e-9)
        html = open(os.path.join(d, "r.html")).read()
        assert "model_identification.csv" in html
        # the residual figure's RMS is the chosen model's, simulated here on the run's pressure
        model = hysteron.Model(os.path.join(d, "out", "best_model.json"))
        rms = np.sqrt(np.mean((m["contraction_mm"] - model.simulate(m["pressure_mpa"])) ** 2))
        said = re.search(r"over the run it was fitted on \(the whole run\): RMS ([0-9.]+) mm", html)
        assert said is not None
        assert float(said.group(1)) == pytest.approx(rms, abs=6e-4)
        assert 0.0 < rms < 1.0  # a model that fits its own run


def test_experiment_summary_keys():
    with tempfile.TemporaryDirectory() as d:
        r = hysteron.run_experiment("gpi-pid", seed=1, out=os.path.join(d, "out"), report=os.path.join(d, "r.html"),
                                    learning_periods=2)
        s = r["summary"]
        for k in ("experiment", "compensated", "faithful", "baseline", "published", "identification"):
            assert k in s, k
        for v in ("compensated", "faithful", "baseline"):
            assert set(s[v]) >= {"max_error_mm", "mae_mm", "rms_error_mm"}
        assert s["published"]["max_error_mm"] == pytest.approx(2.659)
        assert [x["variant"] for x in r["runs"]] == ["faithful", "compensated", "learning", "adaptive", "baseline"]
        assert r["runs"][0]["t"].shape == r["runs"][0]["measured_mm"].shape
        assert len(r["runs"][2]["periods"]) == 2 and r["runs"][0]["periods"] == []
        assert s["variants"] == ["faithful", "compensated", "learning", "adaptive", "baseline"]
        assert r["identification"]["train_end"] > 0
        assert r["model_identification"] is None  # gpi-pid's model is fitted on the paper's run
        assert open(os.path.join(d, "r.html")).read().count("<svg") == 7  # + the learning periods
        hysteron.write_report(os.path.join(d, "out"), os.path.join(d, "r2.html"))
        assert os.path.getsize(os.path.join(d, "r2.html")) > 10000
        # the learning run's "controller" rebuilds its update outside the experiment
        # (docs/deploy.md): fed the run's errors, it applies the run's corrections
        lr = r["runs"][2]
        ctl = lr["controller"]
        assert ctl["pid"]["kp_mpa_per_m"] > 0 and ctl["feedforward_lead_samples"] > 0
        assert "pid" in r["runs"][0]["controller"] and "learning" not in r["runs"][1]["controller"]
        p = ctl["learning"]
        ilc = hysteron.IterativeLearning(period=p["period_samples"], gain=p["gain"], lead=p["lead_samples"],
                                         half_width=p["half_width"], lookahead=p["lookahead"],
                                         rise_tolerance=p["rise_tolerance"], hold_after_cuts=p["hold_after_cuts"],
                                         max_gain=p["max_gain"])
        c = np.empty(lr["t"].shape)
        for k in range(len(c)):
            c[k] = ilc.correction(0) * 1e3
            cmd = lr["pressure_command_mpa"][k]
            ilc.step(0.0 if cmd <= 0.0 or cmd >= 0.6 else (lr["reference_mm"][k] - lr["measured_mm"][k]) * 1e-3)
        assert np.max(np.abs(lr["correction_mm"])) > 0.05
        assert np.max(np.abs(c - lr["correction_mm"])) < 1e-9
        # the same update in one call
        ilc2 = hysteron.learning_from(ctl)
        c2 = np.empty(lr["t"].shape)
        for k in range(len(c2)):
            c2[k] = ilc2.correction(0) * 1e3
            cmd = lr["pressure_command_mpa"][k]
            ilc2.step(0.0 if cmd <= 0.0 or cmd >= 0.6 else (lr["reference_mm"][k] - lr["measured_mm"][k]) * 1e-3)
        assert np.array_equal(c2, c) and ilc2.gain == ilc.gain and ilc2.held == ilc.held
        with pytest.raises(hysteron.Error, match="not a learning run"):
            hysteron.learning_from(r["runs"][1]["controller"])
        assert ilc.gain == p["final_gain"] and ilc.gain_cuts == p["gain_cuts"]
        csv = np.genfromtxt(os.path.join(d, "out", "tracking_learning_sine.csv"), delimiter=",", names=True)
        assert np.array_equal(csv["correction_mm"], lr["correction_mm"])
        with open(os.path.join(d, "out", "result.json")) as f:
            assert json.load(f)["learning"]["controller"] == ctl
        # the compensated loop rebuilt from its "controller" and best_model.json (controller_from,
        # feedforward_preview), fed the run's recorded inputs, commands what the run commanded
        comp = r["runs"][1]
        assert comp["controller"]["loop"] == "feedforward_pid"
        loop = hysteron.controller_from(comp["controller"], os.path.join(d, "out", "best_model.json"))
        assert isinstance(loop, hysteron.FeedforwardPidController)
        ref = comp["reference_mm"] * 1e-3
        pre = hysteron.feedforward_preview(comp["controller"], ref)
        assert pre.shape == ref.shape and not np.array_equal(pre, ref)
        u = np.array([loop.step(ref[k], pre[k], comp["measured_mm"][k] * 1e-3) for k in range(len(ref))])
        assert np.max(np.abs(u - comp["pressure_command_mpa"])) < 1e-9
        assert comp["pressure_measured_mpa"].shape == ref.shape
        bad = dict(comp["controller"], loop="bang_bang")
        with pytest.raises(hysteron.Error, match="unknown loop"):
            hysteron.controller_from(bad, os.path.join(d, "out", "best_model.json"))
        # loop_of_run: one run's controller out of result.json (a file or its parsed dict), the
        # reader behind the C ABI's hysteron_loop_params_from_file
        rj = os.path.join(d, "out", "result.json")
        assert hysteron.loop_of_run(rj, "compensated") == comp["controller"]
        assert hysteron.loop_of_run(pathlib.Path(rj), "learning.sine") == ctl
        with open(rj) as f:
            doc = json.load(f)
        assert hysteron.loop_of_run(doc, "faithful") == r["runs"][0]["controller"]
        assert hysteron.loop_of_run(comp["controller"], "") == comp["controller"]
        with pytest.raises(hysteron.Error, match=r'no run "nope" \(variants: .*compensated'):
            hysteron.loop_of_run(rj, "nope")
        with pytest.raises(hysteron.Error, match='no reference "triangle"'):
            hysteron.loop_of_run(rj, "compensated.triangle")
        with pytest.raises(hysteron.Error, match="cannot open result file"):
            hysteron.loop_of_run(os.path.join(d, "missing.json"), "compensated")


def test_experiment_registry():
    names = hysteron.experiment_names()
    infos = hysteron.experiments()
    assert [e["name"] for e in infos] == names
    assert set(names) == {"gpi-pid", "mpi-openloop", "mpi-pwm"}
    for e in infos:
        assert e["title"] and e["summary"]
        assert "learning" in e["variants"] and "compensated" in e["variants"]
    with pytest.raises(hysteron.Error, match="learning_periods"):
        hysteron.run_experiment("gpi-pid", learning_periods=-1)


def test_a_decreasing_model_is_fed_back_with_its_sign():
    # a record of the muscle's length instead of its contraction gives a decreasing model; the
    # controllers' PIDs take gains as magnitudes and feed back y - r there (positive feedback before)
    base = {"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3,
            "tau": 1.5, "alpha": 0.05, "input_origin": 0.05, "input_scale": 0.5, "output_offset": 1.0,
            "output_gain": 30.0, "input_limits": [0, 0.6]}
    down = dict(base, output_offset=-1.0, output_gain=-30.0)  # y -> -y
    assert hysteron.InverseFeedforward(base).feedback_sign == 1.0
    assert hysteron.InverseFeedforward(down).feedback_sign == -1.0

    def run(model, sign):
        pid = hysteron.Pid(kp=8.0, ki=40.0, sample_time=1e-3, out_min=0.0, out_max=0.6)
        c = hysteron.FeedforwardPidController(model, pid=pid, lag_time_constant=0.02)
        plant = hysteron.Model(model)
        a, p, y = np.exp(-1e-3 / 0.03), 0.0, plant.step(0.0) + sign * 2.0
        commands, errors = [], []
        for k in range(3000):
            r = sign * (30.0 + 8.0 * np.sin(2 * np.pi * k * 1e-3))
            u = c.step(r * 1e-3, r * 1e-3, y * 1e-3)
            p = a * p + (1 - a) * u
            y = plant.step(p) + sign * 2.0
            commands.append(u)
            errors.append(r - y)
        return np.array(commands), float(np.sqrt(np.mean(np.square(errors[1500:]))))

    up_u, up_rms = run(base, 1.0)
    down_u, down_rms = run(down, -1.0)
    assert up_rms < 1.0
    np.testing.assert_array_equal(up_u, down_u)
    assert down_rms == up_rms


def test_rls_survives_a_held_input():
    """The input held for 200 memory lengths, then moving again: the covariance stays positive
    definite and bounded by its prior's trace, and the estimate predicts to the noise level again
    (unbounded, P became indefinite and the estimate ran away to q = -9.3e7)."""
    nominal = {"model": "pi", "q": 0.5, "r": [0.0, 0.1, 0.2, 0.3, 0.4], "p": [0.3, 0.2, 0.15, 0.1, 0.05]}
    true = dict(nominal, p=[1.3 * v for v in nominal["p"]])
    lam, sigma, period = 0.999, 0.005, 20000
    sine = 0.5 - 0.45 * np.cos(2 * np.pi * np.arange(2 * period) / period)
    x = np.concatenate([sine, np.full(200_000, 0.5), sine])
    y = hysteron.simulate_record(true, x) + sigma * np.random.default_rng(1).standard_normal(x.size)
    rls = hysteron.Rls(nominal, lam=lam)
    pred = np.array([rls.step(a, b) for a, b in zip(x, y)])
    np.linalg.cholesky(rls.covariance)  # raises unless positive definite
    assert np.trace(rls.covariance) <= 6 * 1e6 * (1 + 1e-12)
    assert rls.faults == 0 and rls.resets == 0 and rls.bounded > 0
    rms = np.sqrt(np.mean((pred[-period:] - y[-period:]) ** 2))
    assert rms < 1.2 * sigma  # a-priori prediction error: the noise, and little more
