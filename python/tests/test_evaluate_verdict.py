"""hysteron.evaluate judges a record as `hysteron evaluate` does (judge_evaluation): against the training
error the model file's "training" records, naming an input in another unit or zero (the input map), and
saying whether the evaluation is useless (the CLI exits 3 there). Compared with the CLI's --json on the
same files (HYSTERON_CLI)."""
import json
import os
import subprocess
import tempfile

import numpy as np
import pytest

import hysteron


def record(n=1500, seed=3):
    """A muscle-like record: pressure [kPa] -> force, with noise."""
    k = np.arange(n)
    mpa = 0.3 + 0.25 * np.sin(2 * np.pi * k / 300) * (1 - 0.5 * k / n)
    y = hysteron.Model({"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1,
                        "alpha": 2}).simulate(mpa)
    y = y + np.random.default_rng(seed).normal(0.0, 0.01 * np.ptp(y), n)
    return 1000.0 * mpa, y


@pytest.fixture(scope="module")
def fitted():
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_threads=1)
    assert r["ok"], r["message"]
    assert r["model"]["training"]["rms"] > 0
    return x, y, r["model"]


def test_the_training_record_is_not_useless(fitted):
    x, y, model = fitted
    e = hysteron.evaluate(model, x, y)
    assert e["useless"] is False and e["useless_warning"] == "" and e["input_map"] is None, e
    assert e["output_map_warning"] == "" and e["warnings"] == [], e["warnings"]
    assert e["training"] == model["training"]


@pytest.mark.parametrize("how", ["MPa", "absolute"])
def test_an_input_in_another_unit_or_zero_is_named_and_useless(fitted, how):
    x, y, model = fitted
    xr = x / 1000.0 if how == "MPa" else x + 101.325  # kPa -> MPa; gauge -> absolute pressure
    e = hysteron.evaluate(model, xr, y)
    # named as the input's unit or zero (not the output's scale or zero, nor another actuator)
    assert "the input, not the output" in e["output_map_warning"], e["output_map_warning"]
    im = e["input_map"]
    assert im is not None, e["output_map_warning"]
    if how == "MPa":
        assert im["scale"] == 1000.0 and im["shift"] == 0.0, im
        assert "another unit" in e["output_map_warning"], e["output_map_warning"]
    else:
        assert im["scale"] == 1.0 and abs(im["shift"] + 101.325) < 0.05 * 101.325, im
        assert "another zero" in e["output_map_warning"], e["output_map_warning"]
    # mapped back, the record is the training one: its error is the training error's
    assert im["rms"] < 1.5 * model["training"]["rms"] and im["rms_as_is"] > 2 * model["training"]["rms"], im
    assert e["output_map_warning"] in e["warnings"]
    # useless where the prediction is worse than the record's mean (its error is far beyond the training one's):
    # in MPa (R^2 -5 here); in absolute pressure the prediction still follows the record (R^2 0.25 here)
    assert e["rms"] > 2 * model["training"]["rms"]
    assert e["useless"] is (e["r2"] <= 0) and e["useless"] is (how == "MPa"), e
    if e["useless"]:
        useless = "the evaluation is useless: the model predicts evaluate's record (samples 0.."
        assert useless in e["useless_warning"], e["useless_warning"]
        assert e["warnings"][-1] == e["useless_warning"]
    else:
        assert e["useless_warning"] == ""


def test_a_record_far_worse_than_training_is_useless(fitted):
    x, y, model = fitted
    other = y[::-1].copy()  # the same values, against another input history: not this model's record
    e = hysteron.evaluate(model, x, other)
    assert e["r2"] <= 0 and e["rms"] > 2 * model["training"]["rms"], e
    assert "far worse" in e["output_map_warning"], e["output_map_warning"]
    assert e["input_map"] is None
    assert e["useless"] is True, e
    assert "far worse" in e["output_map_warning"], e["output_map_warning"]
    # without a training error (a hand-made model) there is nothing to compare with: never useless
    bare = {k: v for k, v in model.items() if k != "training"}
    b = hysteron.evaluate(bare, x, other)
    assert b["useless"] is False and b["useless_warning"] == "" and b["training"] is None, b
    # the same model through a file and a Model carries the training error
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "m.json")
        hysteron.Model(model).save(path)
        assert hysteron.evaluate(path, x, other)["useless"] is True
        assert hysteron.evaluate(hysteron.Model(path), x, other)["useless"] is True


@pytest.mark.skipif(not os.environ.get("HYSTERON_CLI"), reason="needs the CLI (HYSTERON_CLI)")
@pytest.mark.parametrize("case", ["same", "MPa", "absolute", "other", "narrow"])
def test_python_says_what_the_cli_says(fitted, case):
    x, y, model = fitted
    xr, yr, rng = x, y, None
    if case == "MPa":
        xr = x / 1000.0
    elif case == "absolute":
        xr = x + 101.325
    elif case == "other":
        yr = y[::-1].copy()
    elif case == "narrow":
        rng = (140, 160)
    with tempfile.TemporaryDirectory() as d:
        mpath, data = os.path.join(d, "m.json"), os.path.join(d, "rec.csv")
        hysteron.Model(model).save(mpath)
        np.savetxt(data, np.column_stack([xr, yr]), delimiter=",", header="input,output", comments="", fmt="%.17g")
        cmd = [os.environ["HYSTERON_CLI"], "evaluate", "--model", mpath, "--data", data, "--input", "input",
               "--output", "output", "--json"]
        if rng:
            cmd += ["--range", "%d:%d" % rng]
        out = subprocess.run(cmd, capture_output=True, text=True)
        cli = json.loads(out.stdout)
        # (the CLI scores censored by default; nothing clips here, so censored=True changes nothing but the key)
        e = hysteron.evaluate(mpath, xr, yr, range=rng, censored=True)
    assert out.returncode == (3 if cli["useless"] else 0), (out.returncode, out.stderr)
    assert e["rms"] == pytest.approx(cli["metrics"]["rms"]) and e["r2"] == pytest.approx(cli["metrics"]["r2"])
    # the CLI names the record by its file and adds its exit code to the useless warning
    suffix = ": evaluate exits 3"
    named = [w.replace(data, "evaluate's record") for w in cli["warnings"]]
    expected = [w[: -len(suffix)] if w.endswith(suffix) else w for w in named]
    diagnosis = [w for w in expected if not w.startswith("the evaluation is useless")
                 and "input_limits" not in w]  # (the output map's or the input map's)
    assert e["output_map_warning"] == (diagnosis[0] if diagnosis else "")
    assert e["warnings"] == expected
    assert e["useless"] == cli["useless"], (e["warnings"], cli["warnings"])
    if case in ("MPa", "other"):
        assert cli["useless"] is True
    if case == "narrow":
        assert cli["useless"] is False
