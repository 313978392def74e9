"""fit(..., model="auto"), reference_pi, the report fields of issue 10 (reference,
inverse, warnings, candidates, poor_fit) and the dicts' agreement with the CLI's JSON."""
import json
import os
import subprocess
import tempfile

import numpy as np
import pytest

import hysteron

TRUE_GPI = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1,
            "alpha": 2.0}
REPORT_KEYS = {"status", "ok", "message", "model_kind", "model", "parameters", "train", "reference", "inverse",
               "warnings", "candidates", "initial_cost", "final_cost", "iterations", "total_iterations",
               "num_starts", "time_s", "covariance_note", "fault_runs", "fault_free_train", "report"}
METRIC_KEYS = {"rms", "max", "mae", "rms_percent_span", "r2", "n"}


def record():
    x = np.concatenate([np.interp(np.linspace(0, 1, 300), [0, 0.5, 1], [0, a, 0])
                        for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)])
    return x, hysteron.simulate_record(TRUE_GPI, x)


def test_a_stuck_output_sensor_is_named_by_fit_and_evaluate():
    """The output's reading frozen over samples 360:440 while the input rises by 44 % of its span: fit's
    training record is poor_fit with the rows named, evaluate's record has stuck_output_warning."""
    x, y = record()
    stuck = y.copy()
    stuck[360:440] = stuck[360]
    r = hysteron.fit(x, stuck, model="gpi", min_slope=0.01)
    assert r["status"] == "poor_fit", r["message"]
    assert any("(samples 360:440)" in w and "stuck" in w for w in r["warnings"]), r["warnings"]
    # where to train instead, as a range to pass back: the longest stretch without the frozen rows, the record's
    # last 1360 samples; trained there, nothing is stuck
    assert r["fault_runs"] == [{"rows": [360, 440], "column": "output"}], r["fault_runs"]
    assert r["fault_free_train"] == [440, 1800], r["fault_free_train"]
    assert any("train on samples 440:1800" in w for w in r["warnings"]), r["warnings"]
    again = hysteron.fit(x, stuck, model="gpi", min_slope=0.01, train=tuple(r["fault_free_train"]))
    assert again["status"] == "converged" and again["train"]["n"] == 1360, again["message"]
    assert again["fault_free_train"] is None and not any("stuck" in w for w in again["warnings"])
    good = hysteron.fit(x, y, model="gpi", min_slope=0.01)
    assert not any("stuck" in w for w in good["warnings"])
    assert good["fault_free_train"] is None and good["fault_runs"] == []
    m = hysteron.evaluate(good["model"], x, stuck)
    assert "(samples 360:440)" in m["stuck_output_warning"]
    assert m["stuck_output_warning"] in m["warnings"]
    assert hysteron.evaluate(good["model"], x, y)["stuck_output_warning"] == ""


def test_a_stuck_input_sensor_is_named_by_fit_and_evaluate():
    """The input's reading frozen over samples 40:120 while the true input rises by 53 % of its span (and the
    output with it): fit warns with the rows named (its status is the solver's), evaluate's record has
    stuck_input_warning."""
    x, y = record()
    stuck = x.copy()
    stuck[40:120] = stuck[40]
    r = hysteron.fit(stuck, y, model="gpi", min_slope=0.01)
    assert any("(samples 40:120)" in w and "input sensor is stuck" in w for w in r["warnings"]), r["warnings"]
    good = hysteron.fit(x, y, model="gpi", min_slope=0.01)
    assert not any("stuck" in w for w in good["warnings"])
    m = hysteron.evaluate(good["model"], stuck, y)
    assert "(samples 40:120)" in m["stuck_input_warning"]
    assert m["stuck_input_warning"] in m["warnings"]
    assert m["stuck_output_warning"] == ""
    assert hysteron.evaluate(good["model"], x, y)["stuck_input_warning"] == ""


def test_a_spike_in_an_evaluated_record_is_named():
    """One input sample at 3x the input's largest value (a glitch) and, separately, one output sample far off: fit
    refuses such a training record; evaluate scored it silently (its largest error the spike's). Now
    outlier_warning names the sample and the column."""
    x, y = record()
    good = hysteron.fit(x, y, model="gpi", min_slope=0.01)
    assert hysteron.evaluate(good["model"], x, y)["outlier_warning"] == ""
    k = len(x) // 2
    xs = x.copy()
    xs[k] = 3.0 * np.max(x)
    m = hysteron.evaluate(good["model"], xs, y)
    assert f"sample(s) of the input lie far outside the rest (sample {k} (" in m["outlier_warning"], m["warnings"]
    assert m["outlier_warning"] in m["warnings"]
    ys = y.copy()
    ys[k + 7] = np.max(y) + 5.0 * (np.max(y) - np.min(y))
    m = hysteron.evaluate(good["model"], x, ys)
    assert f"sample(s) of the output lie far outside the rest (sample {k + 7} (" in m["outlier_warning"], m["warnings"]
    assert "of the input" not in m["outlier_warning"]


def test_names_include_poor_fit_and_auto():
    assert "poor_fit" in hysteron.fit_statuses
    assert {"auto", "gpi", "pi", "mpi-deadzone", "mpi-asym", "preisach", "kp", "bouc-wen", "maxwell-slip",
            "rate-pi"} == set(hysteron.fit_models)


def test_fit_report_fields():
    x, y = record()
    r = hysteron.fit(x, y, model="gpi", train=(0, 1200), min_slope=0.01)
    assert set(r) == REPORT_KEYS
    assert r["status"] in hysteron.fit_statuses
    assert set(r["train"]) == METRIC_KEYS and set(r["reference"]) == METRIC_KEYS
    assert r["reference"]["n"] == r["train"]["n"] == 1200
    assert set(r["inverse"]) == {"max_slope", "max_jump", "max_input_step", "increasing"}
    assert isinstance(r["warnings"], list) and all(isinstance(w, str) for w in r["warnings"])
    assert r["candidates"] == []  # only with model="auto"
    # metrics dicts come from the same writer as the fit's
    m = hysteron.evaluate(r["model"], x, y, range=(0, 1200))
    assert set(m) == METRIC_KEYS | {"outside_input_limits", "output_map", "output_map_warning", "clipping_warning",
                                    "input_coverage_warning", "input_map", "training", "useless", "useless_warning",
                                    "stuck_output_warning", "stuck_input_warning", "outlier_warning", "warnings"}
    assert m["output_map_warning"] == ""  # the model on its own training record
    assert m["stuck_output_warning"] == "" and m["stuck_input_warning"] == "" and m["outlier_warning"] == ""
    assert m["useless"] is False and m["warnings"] == [] and m["input_map"] is None
    assert m["outside_input_limits"] == 0  # the training range itself
    # an input beyond the range the model was fitted on is counted (input_limits: that range)
    lo, hi = r["model"]["input_limits"]
    wide = 3.0 * np.asarray(x) + 1.0
    expected = int((np.maximum(lo - wide, wide - hi) > 0.02 * (hi - lo)).sum())
    assert hysteron.evaluate(r["model"], wide, y)["outside_input_limits"] == expected > 100


def test_min_slope_is_validated():
    x, y = record()
    bad = hysteron.fit(x, y, model="pi", min_slope=-1.0)
    assert bad["status"] == "invalid_input" and "min_slope" in bad["message"], bad["message"]
    assert bad["model"] is None


def test_fit_auto_lists_every_candidate():
    x, y = record()
    r = hysteron.fit(x, y, model="auto", train=(0, 1200), sample_time=1e-3)
    kinds = [c["kind"] for c in r["candidates"]]
    assert set(kinds) == {"gpi", "pi", "mpi-deadzone", "mpi-asym", "preisach", "kp", "bouc-wen", "maxwell-slip",
                          "rate-pi"}
    chosen = [c for c in r["candidates"] if c["chosen"]]
    assert len(chosen) == 1
    assert r["model_kind"] == chosen[0]["kind"] and r["model_kind"] != "auto"
    for c in r["candidates"]:
        assert set(c["train"]) == METRIC_KEYS and set(c["holdout"]) == METRIC_KEYS
        assert c["time_s"] >= 0 and c["status"] in hysteron.fit_statuses
        # a candidate is its fold-0 fit: on the training range without its last 20 %
        assert c["fit_range"] == [0, 960], c["fit_range"]
    # the chosen kind has the lowest hold-out score among the candidates that have one; the
    # score is >= 1 (1: the best kind on both folds)
    scored = [c for c in r["candidates"] if c["holdout_score"] is not None and c["model"] is not None]
    assert chosen[0]["holdout_score"] == min(c["holdout_score"] for c in scored)
    assert all(c["holdout_score"] >= 1 for c in scored)
    assert r["model"] is not None and hysteron.Model(r["model"]).simulate(x).shape == x.shape


def test_reference_pi_is_a_model():
    x, y = record()
    ref = hysteron.reference_pi(x, y, train=(0, 1200), num_operators=10)
    assert ref["model"] == "pi"
    yr = hysteron.Model(ref).simulate(x)
    assert yr.shape == x.shape and np.all(np.isfinite(yr))
    # it fits the record: far better than the mean
    e = hysteron.compute_metrics(y[:1200], yr[:1200])
    assert e["r2"] > 0.9, e


@pytest.mark.skipif(not os.environ.get("HYSTERON_CLI"), reason="needs the CLI (HYSTERON_CLI)")
def test_python_dict_equals_cli_json():
    """The CLI's --json and Python's fit() come from the same to_json: same keys, same values."""
    x, y = record()
    with tempfile.TemporaryDirectory() as d:
        data = os.path.join(d, "data.csv")
        np.savetxt(data, np.column_stack([x, y]), delimiter=",", header="input,output", comments="", fmt="%.17g")
        out = subprocess.run([os.environ["HYSTERON_CLI"], "fit", "--model", "pi", "--data", data, "--input", "input",
                              "--output", "output", "--train", "0:1200", "--threads", "1", "--out",
                              os.path.join(d, "m.json"), "--json", "--force"], capture_output=True, text=True)
        assert out.returncode in (0, 2, 3), out.stderr
        cli = json.loads(out.stdout)  # exactly one JSON document
    r = hysteron.fit(x, y, model="pi", train=(0, 1200), num_threads=1)
    assert cli["status"] == r["status"]
    assert cli["model_kind"] == r["model_kind"]
    assert cli["train"] == pytest.approx(r["train"])
    assert cli["reference"] == pytest.approx(r["reference"])
    assert [p["name"] for p in cli["parameters"]] == [p["name"] for p in r["parameters"]]
    assert set(r) - {"ok", "report"} <= set(cli)


def test_new_kinds_run_invert_and_fit_from_python():
    specs = [
        {"model": "preisach", "q": 0.5, "lo": -1, "hi": 1, "levels": 2, "w": [0.2, 0.1, 0.3], "input_limits": [-1.5, 1.5]},
        {"model": "kp", "q": 0.5, "lo": -1, "hi": 1, "levels": 2, "w": [0.2, 0.1, 0.3], "input_limits": [-1.5, 1.5]},
        {"model": "bouc-wen", "kx": 1.0, "kw": -0.05, "rho": 4, "sigma": 1, "n": 1.5, "input_limits": [-1.5, 1.5]},
        {"model": "maxwell-slip", "k0": 0.4, "k": [0.3, 0.5], "delta": [0.1, 0.25]},
        {"model": "rate-pi", "q": 0.3, "r": [0.1, 0.2], "p": [0.4, 0.3], "c": 0.12, "tau": 0.1, "dt": 0.001,
         "input_limits": [-1.5, 1.5]},
    ]
    x = np.sin(np.linspace(0, 6 * np.pi, 600)) * np.linspace(0.2, 1.0, 600)
    for spec in specs:
        m = hysteron.Model(spec)
        assert spec["model"] in repr(m)
        y = m.simulate(x)
        inv = hysteron.Inverse(spec)
        assert np.max(np.abs(inv.simulate(y) - x)) < 1e-9, spec["model"]
        assert hysteron.Model(m.to_dict()).simulate(x).tolist() == y.tolist()
    r = hysteron.fit(x, hysteron.Model(specs[1]).simulate(x), model="kp", num_operators=4)
    assert r["status"] == "converged" and r["model"]["model"] == "kp", r["message"]
    bad = hysteron.fit(x, y, model="rate-pi")
    assert bad["status"] == "invalid_input" and "sample time" in bad["message"]


def test_clipped_output_is_fitted_as_censored_unless_asked_not_to():
    """A record whose sensor clips (its lowest third read as the limit, with noise elsewhere)
    is fitted as censored data by default; censor_passes=0 fits it to the limit as recorded."""
    x, truth = record()
    limit = np.percentile(truth, 33)
    rng = np.random.default_rng(3)
    y = np.maximum(truth + rng.normal(0.0, 0.02, truth.size), limit)
    censored = hysteron.fit(x, y, model="pi", num_operators=6)
    as_recorded = hysteron.fit(x, y, model="pi", num_operators=6, censor_passes=0)
    assert any("fitted as censored data" in w for w in censored["warnings"]), censored["warnings"]
    assert any("fitted to the limit there" in w for w in as_recorded["warnings"]), as_recorded["warnings"]
    # the censored metrics: a prediction below the limit where the record sits at it is no error
    assert censored["train"]["rms"] < as_recorded["train"]["rms"]
    bad = hysteron.fit(x, y, model="pi", censor_passes=11)
    assert bad["status"] == "invalid_input" and "censor_passes" in bad["message"], bad["message"]


def test_evaluate_scores_a_clipped_record_as_censored_when_asked():
    """evaluate(censored=True): a sample at the clipped limit where the model predicts beyond it
    is no error (checked sample by sample here); the default scores the record as recorded."""
    x, truth = record()
    limit = np.percentile(truth, 33)
    rng = np.random.default_rng(4)
    y = np.maximum(truth + rng.normal(0.0, 0.02, truth.size), limit)
    model = hysteron.fit(x, truth, model="pi", num_operators=6)["model"]
    pred = hysteron.simulate_record(model, x)
    no_error = (y == limit) & (pred < limit)
    expected = np.sqrt(np.mean(np.where(no_error, 0.0, y - pred) ** 2))
    cens = hysteron.evaluate(model, x, y, censored=True)
    plain = hysteron.evaluate(model, x, y)
    assert cens["censored_samples"] == int(no_error.sum()) > 10
    assert abs(cens["rms"] - expected) <= 1e-9 * expected
    assert "censored_samples" not in plain and plain["rms"] > cens["rms"]
    unclipped = hysteron.evaluate(model, x, truth + rng.normal(0.0, 0.02, truth.size), censored=True)
    assert unclipped["censored_samples"] == 0


def test_evaluate_names_a_record_whose_output_is_negated_or_offset():
    """evaluate(): output_map is the least-squares y ~ gain * prediction + offset (checked with
    numpy here), and output_map_warning names a flipped sign or a zero where that map explains
    what the prediction does not; the model's own output gets none."""
    x, truth = record()
    model = hysteron.fit(x, truth, model="pi", num_operators=6)["model"]
    pred = hysteron.simulate_record(model, x)
    span = truth.max() - truth.min()
    own = hysteron.evaluate(model, x, truth)
    assert own["output_map_warning"] == "", own["output_map_warning"]
    for y, words in ((-truth, "is its sign flipped"), (truth + 0.3 * span, "or a zero (a sensor offset)")):
        d = hysteron.evaluate(model, x, y)
        gain, offset = np.polyfit(pred, y, 1)
        m = d["output_map"]
        assert abs(m["gain"] - gain) <= 1e-9 * abs(gain) and abs(m["offset"] - offset) <= 1e-9 * span, (m, gain, offset)
        assert abs(m["rms"] - d["rms"]) <= 1e-12 * span and m["rms_mapped"] < 0.5 * m["rms"], m
        assert words in d["output_map_warning"], d["output_map_warning"]
