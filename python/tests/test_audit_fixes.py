"""Findings of the Python audit (2026-12): a controller's PID at another sample time, a Model or a
pathlib.Path where a model or a path is taken, (N, 1) and (1, N) arrays, Model.faults, wrong-type
and negative integer arguments, PamRig.reset_at_pressure's range, compute_metrics on nothing, and
the reprs docs/python.md shows."""
import json
import pathlib
import re

import numpy as np
import pytest

import hysteron

ROOT = pathlib.Path(__file__).resolve().parents[2]
GPI = {"model": "gpi", "envelope": "tanh", "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "n": 10,
       "rho": 0.4, "tau": 0.1, "alpha": 2.0, "input_limits": [0.0, 0.6]}


def ramp():
    k = np.arange(400)
    return np.concatenate([a * (1.0 - np.abs(2.0 * k / 400.0 - 1.0)) for a in (0.6, 0.4)])


# 1. The PID of a controller ran at its own sample time (Pid's default 1e-3 s) in a 10 ms loop.
@pytest.mark.parametrize("make", [
    lambda pid, ts: hysteron.FeedforwardPidController(GPI, pid=pid, pressure_limits=(0, 0.6), sample_time=ts),
    lambda pid, ts: hysteron.OpenLoopController(GPI, pid=pid, sample_time=ts),
    lambda pid, ts: hysteron.CascadePwmController(GPI, pid=pid, sample_time=ts),
])
def test_a_pid_at_another_sample_time_than_the_controller_is_refused(make):
    with pytest.raises(hysteron.Error, match=r"\.sample_time = 0\.001 s differs from the loop's sample_time = 0\.01 s "
                                             r"\(one sample time for the loop: set the PID's to 0\.01 s\)"):
        make(hysteron.Pid(kp=1.0, ki=1.0, out_min=-1, out_max=1), 0.01)
    make(hysteron.Pid(kp=1.0, ki=1.0, out_min=-1, out_max=1, sample_time=0.01), 0.01)  # the same: fine
    make(None, 0.01)  # the default PID takes the controller's sample time


def test_the_cascades_pressure_pid_at_another_sample_time_is_refused():
    with pytest.raises(hysteron.Error, match=r"cascade PWM controller: pressure\.sample_time = 0\.001 s differs"):
        hysteron.CascadePwmController(GPI, pressure_pid=hysteron.Pid(kp=20, out_min=-1, out_max=1), sample_time=0.01)


def test_the_controllers_integral_runs_at_the_controllers_sample_time():
    # a constant error e for one second: the integral is ki e (1 s), whatever the sample time
    ts, e = 0.01, 0.01
    ctl = hysteron.FeedforwardPidController(
        GPI, pid=hysteron.Pid(ki=1.0, out_min=-1, out_max=1, sample_time=ts), sample_time=ts,
        model_scale=1.0)
    u = [ctl.step(0.1 + e, 0.1, 0.1) for _ in range(int(round(1.0 / ts)) + 1)]
    ff = hysteron.InverseFeedforward(GPI, model_scale=1.0, sample_time=ts).step(0.1)
    assert u[-1] - ff == pytest.approx(1.0 * e * 1.0, rel=0.02)


# 2. A hysteron.Model and an os.PathLike where a model or a path is taken.
def test_a_model_or_a_pathlike_is_accepted_as_a_model(tmp_path):
    x = ramp()
    ref = hysteron.Model(GPI).simulate(x)
    m = hysteron.Model(GPI)
    m.step(0.3)  # a copy of its parameters, from the virgin state
    np.testing.assert_array_equal(hysteron.Model(m).simulate(x), ref)
    np.testing.assert_array_equal(hysteron.Inverse(m).simulate(ref[:100]), hysteron.Inverse(GPI).simulate(ref[:100]))
    path = tmp_path / "model.json"
    m.save(path)  # a pathlib.Path to write
    assert json.loads(path.read_text())["model"] == "gpi"
    np.testing.assert_array_equal(hysteron.Model(path).simulate(x), ref)
    np.testing.assert_array_equal(hysteron.Inverse(path).simulate(ref[:100]),
                                  hysteron.Inverse(GPI).simulate(ref[:100]))
    assert hysteron.evaluate(path, x, ref)["rms"] == 0.0
    np.testing.assert_array_equal(hysteron.simulate_record(path, x), ref)
    assert hysteron.InverseFeedforward(path).step(0.01) == hysteron.InverseFeedforward(GPI).step(0.01)
    assert hysteron.InverseFeedforward(m).step(0.01) == hysteron.InverseFeedforward(GPI).step(0.01)


def test_a_pathlike_is_accepted_as_a_rig_file_and_an_output(tmp_path):
    rig = tmp_path / "rig.json"
    rig.write_text(json.dumps({"load": {"mass": 12.0}}))
    assert hysteron.PamRig(rig).params["load"]["mass"] == 12.0
    assert hysteron.rig_params(rig)["load"]["mass"] == 12.0
    x = ramp()
    y = hysteron.Model(GPI).simulate(x)
    report = tmp_path / "fit.html"
    hysteron.fit(x, y, model="pi", num_operators=4, num_starts=1, report=report)
    assert report.stat().st_size > 1000
    # the Path reaches the reader: its error names the file, it is no TypeError
    with pytest.raises(hysteron.Error, match="nothing.json"):
        hysteron.write_report(tmp_path / "nothing.json", tmp_path / "r.html")


def test_a_model_of_the_wrong_type_is_named_without_a_traceback():
    for call, message in [
        (lambda: hysteron.Model(3), r"Model: spec: expected a model dict .* got int 3"),
        (lambda: hysteron.Inverse([1, 2]), r"Inverse: spec: expected a model dict .* got list"),
        (lambda: hysteron.evaluate(object(), [0.1], [0.1]), r"evaluate: model: expected a model dict .* got object"),
        (lambda: hysteron.InverseFeedforward(3.5), r"InverseFeedforward: model: expected .* got float 3.5"),
    ]:
        with pytest.raises(TypeError, match=message) as e:
            call()
        assert "Traceback" not in str(e.value)
    with pytest.raises(hysteron.Error, match=r"Model: spec: cannot convert to JSON: .*a PosixPath is not a number") as e:
        hysteron.Model(dict(GPI, note=pathlib.Path("x")))
    assert "Traceback" not in str(e.value) and "\n" not in str(e.value)


# 3. (N, 1) and (1, N) arrays (scipy.io.loadmat's vectors) are their N values; other shapes are named.
def test_column_and_row_vectors_are_taken_and_other_shapes_named():
    x = ramp()
    m = hysteron.Model(GPI)
    ref = m.simulate(x)
    np.testing.assert_array_equal(hysteron.Model(GPI).simulate(x[:, None]), ref)
    np.testing.assert_array_equal(hysteron.Model(GPI).simulate(x[None, :]), ref)
    np.testing.assert_array_equal(hysteron.simulate_record(GPI, np.asfortranarray(x[:, None])), ref)
    assert hysteron.evaluate(GPI, x[:, None], ref[None, :])["rms"] == 0.0
    assert hysteron.compute_metrics(ref[:, None], ref)["n"] == len(x)
    with pytest.raises(hysteron.Error, match=r"Model.simulate: x: expected a one-dimensional array .* "
                                             r"got shape \(400, 2\)"):
        hysteron.Model(GPI).simulate(np.stack([x[:400], x[:400]], axis=1))
    with pytest.raises(hysteron.Error, match=r"fit: y: expected a one-dimensional array .* got shape \(2, 2, 200\)"):
        hysteron.fit(x, ref.reshape(2, 2, 200))
    with pytest.raises(hysteron.Error, match=r"Inverse.simulate: y: .* got a scalar"):
        hysteron.Inverse(GPI).simulate(0.3)


# 4. Model.step on NaN or infinity holds the output and counts it; so does Inverse.step.
def test_model_and_inverse_count_the_inputs_they_ignore():
    m = hysteron.Model(GPI)
    y = m.step(0.3)
    assert m.faults == 0
    assert m.step(float("nan")) == y and m.step(float("inf")) == y and m.step(float("-inf")) == y
    assert m.faults == 3
    m.reset()
    assert m.faults == 0
    inv = hysteron.Inverse(GPI, limits=(0.0, 0.6))
    u = inv.step(40.0)
    assert inv.step(float("inf")) == u and inv.step(float("-inf")) == u and inv.step(float("nan")) == u
    assert inv.faults == 3
    assert inv.step(1e300) == 0.6 and inv.saturated  # finite and beyond reach: the limit in its direction
    for method in (hysteron.Model.step, hysteron.Inverse.step):
        assert "faults" in method.__doc__ and "infinite" in method.__doc__
    text = (ROOT / "docs" / "python.md").read_text()
    assert "`Model.faults`" in text and "`Inverse.faults`" in text


# 5. Integers: a negative count or seed is named, not pybind11's "incompatible function arguments".
def test_negative_and_wrong_type_integers_are_named():
    x = ramp()
    y = hysteron.Model(GPI).simulate(x)
    cases = [
        (lambda: hysteron.IterativeLearning(-1), ValueError,
         r"^IterativeLearning: period must be a positive integer, got -1$"),
        (lambda: hysteron.IterativeLearning(0), ValueError, r"IterativeLearning: period must be a positive integer"),
        (lambda: hysteron.IterativeLearning(100, lead=-2), ValueError,
         r"IterativeLearning: lead must be an integer >= 0, got -2"),
        (lambda: hysteron.IterativeLearning(2.5), TypeError, r"IterativeLearning: period: expected a positive integer"),
        (lambda: hysteron.PamRig(seed=-1), ValueError, r"PamRig: seed must be an integer >= 0, got -1"),
        (lambda: hysteron.PamRig(seed=True), TypeError, r"PamRig: seed: expected an integer >= 0, got bool"),
        (lambda: hysteron.fit(x, y, seed=-1), ValueError, r"fit: seed must be an integer >= 0, got -1"),
        (lambda: hysteron.run_sweep("gpi-pid", vary=["load.mass=10"], jobs=-1), ValueError,
         r"run_sweep: jobs must be an integer >= 0, got -1"),
        (lambda: hysteron.run_experiment("gpi-pid", seed=-3), ValueError, r"run_experiment: seed must be"),
        (lambda: hysteron.InverseFeedforward(GPI, pressure_limits=(None, 0.6)), TypeError,
         r"InverseFeedforward: pressure_limits: expected \(lo, hi\), two numbers, got tuple \(None, 0.6\)"),
        (lambda: hysteron.FeedforwardPidController(GPI, pressure_limits=0.6), TypeError,
         r"FeedforwardPidController: pressure_limits: expected"),
    ]
    for call, kind, message in cases:
        with pytest.raises(kind, match=message) as e:
            call()
        assert "incompatible function arguments" not in str(e.value)
    # numpy integers are integers
    assert hysteron.PamRig(seed=np.uint64(3)).seed == 3
    assert "period=5," in repr(hysteron.IterativeLearning(np.int64(5)))


# 6. reset_at_pressure takes pascals: a value beyond the supply, below 0, or MPa given as Pa is named.
def test_reset_at_pressure_checks_its_range_in_pascals():
    rig = hysteron.PamRig()
    air = rig.params["air"]
    top = air["supply_pressure"] - air["atmospheric_pressure"]
    for p in (-1e6, 1e9, top * 1.01):
        with pytest.raises(hysteron.Error, match=r"PamRig.reset_at_pressure: p_gauge = .* Pa is outside 0 \.\. "):
            rig.reset_at_pressure(p)
    with pytest.raises(hysteron.Error, match=r"p_gauge = 0.3 Pa: the unit is Pa, not MPa \(for 0.3 MPa give 300000;"):
        rig.reset_at_pressure(0.3)
    rig.reset_at_pressure(3e5)
    assert rig.state["pressure"] == pytest.approx(air["atmospheric_pressure"] + 3e5)
    rig.reset_at_pressure(0.0)
    rig.reset_at_pressure(top)


# 7. compute_metrics of no samples was all zeros: a perfect fit.
def test_compute_metrics_of_nothing_is_an_error():
    with pytest.raises(hysteron.Error, match="compute_metrics: measured and predicted are empty"):
        hysteron.compute_metrics([], [])


# 8. The reprs docs/python.md shows are the ones printed; Model.name's docstring lists every kind.
def test_the_documented_reprs_and_model_kinds():
    text = (ROOT / "docs" / "python.md").read_text()
    spec = {"model": "gpi", "n": 10, "c": [1.0, 2.0, -0.6, 0.6], "q": 0.8, "rho": 0.4, "tau": 5.0, "alpha": 0.03}
    model_repr = repr(hysteron.Model(spec))
    inverse_repr = repr(hysteron.Inverse(spec, limits=(0.0, 0.6)))
    assert f"`{model_repr}`" in text and f"`{inverse_repr}`" in text
    doc = hysteron.Model.name.__doc__
    for kind in hysteron.fit_models:
        if kind != "auto":
            assert f"'{kind}'" in doc, kind
    assert re.search(r"`Model`, `Inverse`[^.]*name their parameters", text) is None
