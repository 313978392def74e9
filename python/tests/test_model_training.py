"""A model dict from fit() records its training error ("training": rms, r2, samples; docs/model-files.md),
which Model(...) keeps through to_dict(), save() and pickles, as hysteron fit's model file has it."""
import json
import pickle

import numpy as np

import hysteron


def record(n=1200):
    k = np.arange(n)
    x = 0.3 + 0.25 * np.sin(2 * np.pi * k / 300) * (1 - 0.5 * k / n)
    y = hysteron.Model({"model": "gpi", "c": [60, 4, -0.5, 30], "q": 0.8, "n": 10, "rho": 0.4, "tau": 0.1,
                        "alpha": 2}).simulate(x)
    return x, y


def test_fit_model_dict_records_the_training_error(tmp_path):
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_threads=1)
    assert r["ok"], r["message"]
    t = r["model"]["training"]
    assert t == {"rms": r["train"]["rms"], "r2": r["train"]["r2"], "samples": r["train"]["n"]}, t
    m = hysteron.Model(r["model"])
    assert m.to_dict()["training"] == t
    assert pickle.loads(pickle.dumps(m)).to_dict()["training"] == t
    m.save(tmp_path / "m.json")
    assert json.loads((tmp_path / "m.json").read_text())["training"] == t
    assert hysteron.Model(str(tmp_path / "m.json")).to_dict() == m.to_dict()
    # without it (a model written before): as before
    d = dict(r["model"])
    del d["training"]
    assert "training" not in hysteron.Model(d).to_dict()


def test_training_is_checked_strictly():
    x, y = record()
    d = hysteron.fit(x, y, model="pi", num_threads=1)["model"]
    for bad in ({"rms": -1.0, "r2": 0.9, "samples": 10}, {"rms": 1.0, "r2": 0.9}, "x"):
        d["training"] = bad
        try:
            hysteron.Model(d)
        except hysteron.Error as e:
            assert "training" in str(e), str(e)
        else:
            raise AssertionError(f"training {bad!r} accepted")


def test_rate_pi_without_a_sample_time_names_the_argument():
    x, y = record()
    r = hysteron.fit(x, y, model="rate-pi", num_threads=1)
    assert r["status"] == "invalid_input", r["status"]
    assert "give sample_time" in r["message"] and "FitOptions::" not in r["message"], r["message"]


def test_evaluate_does_not_blame_a_short_stretch_on_a_unit_or_a_zero():
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_threads=1)
    w = hysteron.evaluate(r["model"], x, y, range=(140, 160))["output_map_warning"]
    assert "sensor offset" not in w and "another unit" not in w, w
