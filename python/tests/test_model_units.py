"""A model file's free-form keys ("units", "note", "metadata"; docs/model-files.md) travel with a
hysteron.Model: Model(path or dict) keeps them, save(), to_dict(), Model(m), copy and pickle write
them back, and hysteron.fit(units=...) records the units of its arrays, so that the CLI's check of a
record's units still protects a model that went through Python."""
import copy
import json
import os
import pathlib
import pickle
import subprocess

import numpy as np
import pytest

import hysteron

PI = {"model": "pi", "q": 0.8, "r": [0.0, 20.0, 40.0], "p": [0.3, 0.2, 0.1]}
EXTRA = {"units": {"input": "kPa", "output": "N"}, "note": "bench 3, 2026-11-30",
         "metadata": {"rig": {"id": 7, "tags": ["a", None]}, "score": 0.25}}


def record(n=3000):
    """A PI-like record: input in kPa (0..600), output in N."""
    k = np.arange(n)
    x = 300 + 250 * np.sin(k / 80) * (0.5 + 0.5 * np.cos(k / 900))
    return x, hysteron.Model(PI).simulate(x)


def free_keys(d):
    return {k: d[k] for k in ("units", "note", "metadata") if k in d}


def test_load_save_keeps_units_note_metadata(tmp_path):
    src = tmp_path / "m.json"
    src.write_text(json.dumps({**PI, **EXTRA}))
    m = hysteron.Model(src)
    assert m.units == EXTRA["units"]
    out = tmp_path / "saved.json"
    m.save(out)
    saved = json.loads(out.read_text())
    assert free_keys(saved) == EXTRA
    assert hysteron.Model(out).to_dict() == m.to_dict()
    # the dict holds them too, and a model built from it or from the model keeps them
    assert free_keys(m.to_dict()) == EXTRA
    assert free_keys(hysteron.Model(m.to_dict()).to_dict()) == EXTRA
    assert free_keys(hysteron.Model(m).to_dict()) == EXTRA
    assert hysteron.Model(str(src)).units == EXTRA["units"]


def test_a_model_without_free_keys_has_none():
    m = hysteron.Model(PI)
    assert m.units is None
    assert free_keys(m.to_dict()) == {}
    # one key alone
    assert hysteron.Model({**PI, "units": {"output": "mm"}}).units == {"output": "mm"}


def test_units_is_a_copy():
    m = hysteron.Model({**PI, **EXTRA})
    m.units["input"] = "bar"
    m.to_dict()["units"]["input"] = "bar"
    assert m.units == EXTRA["units"]


def test_copy_and_pickle_keep_free_keys_and_state():
    m = hysteron.Model({**PI, **EXTRA})
    x, _ = record(500)
    m.simulate(x)
    for c in (copy.copy(m), copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        assert c.units == EXTRA["units"]
        assert free_keys(c.to_dict()) == EXTRA
        assert c.state.tolist() == m.state.tolist()
        assert c.simulate(x[:50]).tolist() == copy.copy(m).simulate(x[:50]).tolist()


def test_bad_free_keys_are_refused_with_the_key_named(tmp_path):
    cases = [({"units": "kPa"}, ['"units"', "expected an object"]),
             ({"units": {"input": 100}}, ['"units.input"', "expected a string, got number"]),
             ({"note": ["a"]}, ['"note"', "expected a string, got array"]),
             ({"unit": {"input": "kPa"}}, ['"unit"', "unknown key"])]
    for extra, parts in cases:
        with pytest.raises(hysteron.Error) as e:
            hysteron.Model({**PI, **extra})
        for p in parts:
            assert p in str(e.value), (extra, str(e.value))
        f = tmp_path / "bad.json"
        f.write_text(json.dumps({**PI, **extra}))
        with pytest.raises(hysteron.Error, match="bad.json"):
            hysteron.Model(f)


def test_fit_records_the_units_of_its_arrays(tmp_path):
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_starts=1, num_threads=1, units={"input": "kPa", "output": "N"})
    assert r["model"] is not None, r["message"]
    assert r["model"]["units"] == {"input": "kPa", "output": "N"}
    m = hysteron.Model(r["model"])
    assert m.units == {"input": "kPa", "output": "N"}
    m.save(tmp_path / "m.json")
    assert json.loads((tmp_path / "m.json").read_text())["units"] == {"input": "kPa", "output": "N"}
    # the same fit without units: none recorded, the parameters alike
    r0 = hysteron.fit(x, y, model="pi", num_starts=1, num_threads=1)
    assert "units" not in r0["model"]
    assert {k: v for k, v in r["model"].items() if k != "units"} == r0["model"]
    # model="auto": every candidate's model too
    ra = hysteron.fit(x, y, model="auto", num_starts=1, num_threads=1, units={"input": "kPa"})
    assert ra["model"]["units"] == {"input": "kPa"}
    assert all(c["model"]["units"] == {"input": "kPa"} for c in ra["candidates"] if c["model"] is not None)


def test_fit_takes_an_axis_unit_as_the_cli_takes_a_label():
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_starts=1, num_threads=1, input_axis=("Pressure", "kPa"))
    assert r["model"]["units"] == {"input": "kPa"}
    # the same unit twice (as spelled, or another case of the same unit) is one unit
    r = hysteron.fit(x, y, model="pi", num_starts=1, num_threads=1, input_axis=("Pressure", "KPa"),
                     units={"input": "kPa", "output": "N"})
    assert r["model"]["units"] == {"input": "kPa", "output": "N"}


def test_fit_refuses_bad_units_before_fitting():
    x, y = record(200)
    with pytest.raises(hysteron.Error, match=r"fit: units\['input'\] is 'kPa' but input_axis gives the unit 'bar'"):
        hysteron.fit(x, y, model="pi", units={"input": "kPa"}, input_axis=("p", "bar"))
    with pytest.raises(hysteron.Error, match=r"fit: units: unknown key 'inptu', did you mean 'input'"):
        hysteron.fit(x, y, model="pi", units={"inptu": "kPa"})
    with pytest.raises(TypeError, match=r"fit: units\['output'\]: expected a str"):
        hysteron.fit(x, y, model="pi", units={"output": 1.0})
    with pytest.raises(TypeError, match=r"fit: units: expected a dict"):
        hysteron.fit(x, y, model="pi", units="kPa")


def write_record(path, input_header, scale):
    x, y = record()
    with open(path, "w") as f:
        f.write(f"t [s],{input_header},force [N]\n")
        f.writelines(f"{k * 0.001!r},{float(x[k] * scale)!r},{float(y[k])!r}\n" for k in range(len(x)))


def evaluate(model, data):
    return subprocess.run([os.environ["HYSTERON_CLI"], "evaluate", "--model", str(model), "--data", str(data),
                           "--input", "pressure", "--output", "force"], capture_output=True, text=True)


@pytest.mark.skipif(not os.environ.get("HYSTERON_CLI"), reason="needs the CLI (HYSTERON_CLI)")
def test_cli_refuses_a_record_in_other_units_than_a_python_saved_model(tmp_path):
    kpa, bar = tmp_path / "kpa.csv", tmp_path / "bar.csv"
    write_record(kpa, "pressure [kPa]", 1.0)
    write_record(bar, "pressure [bar]", 0.01)
    # fitted in Python with units, saved
    x, y = record()
    r = hysteron.fit(x, y, model="pi", num_starts=1, num_threads=1, units={"input": "kPa", "output": "N"})
    py_model = tmp_path / "py.json"
    hysteron.Model(r["model"]).save(py_model)
    # fitted by the CLI, loaded in Python and saved again (and through pickle)
    cli_model = tmp_path / "cli.json"
    out = subprocess.run([os.environ["HYSTERON_CLI"], "fit", "--model", "pi", "--data", str(kpa), "--input",
                          "pressure", "--output", "force", "--threads", "1", "--out", str(cli_model), "--force"],
                         capture_output=True, text=True)
    assert out.returncode in (0, 3) and cli_model.exists(), out.stderr  # (3: a poor fit, written by --force)
    resaved = tmp_path / "resaved.json"
    pickle.loads(pickle.dumps(hysteron.Model(cli_model))).save(resaved)
    assert json.loads(resaved.read_text())["units"] == {"input": "kPa", "output": "N"}
    for model in (py_model, resaved):
        ok = evaluate(model, kpa)
        assert ok.returncode == 0, ok.stderr
        refused = evaluate(model, bar)
        assert refused.returncode == 1, (model, refused.stdout)
        assert f"the input column pressure is in bar, but the model {model}'s input is in kPa" in refused.stderr


def test_the_controllers_take_model_scale_from_the_models_units():
    # a model fitted with its output in m under the controllers' default model_scale 1000 asked the
    # inverse for outputs 1000x too large (saturated at the top pressure, silently)
    base = {"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3,
            "tau": 1.5, "alpha": 0.05, "input_limits": [0, 0.6]}
    in_mm = dict(base, output_gain=30.0, units={"input": "MPa", "output": "mm"})
    in_m = dict(base, output_gain=0.030, units={"input": "MPa", "output": "m"})
    mm = hysteron.InverseFeedforward(in_mm)
    m = hysteron.InverseFeedforward(in_m)
    plain = hysteron.InverseFeedforward(dict(base, output_gain=0.030), model_scale=1.0)
    for desired in (0.010, 0.020, 0.030, 0.025):
        a, b, c = mm.step(desired), m.step(desired), plain.step(desired)
        assert 0.0 < b < 0.6
        assert b == c
        assert abs(a - b) < 1e-9
    assert hysteron.InverseFeedforward(dict(base, output_gain=0.030, units={"output": "um"})).step(1e-6) >= 0.0
    hysteron.InverseFeedforward(dict(base, units={"output": "in"}), model_scale=39.37)  # 1 / 0.0254, rounded
    # an output that is no length (a force record's N): the default 1000 is said, model_scale=1 is silent
    with pytest.warns(UserWarning, match="the model's output is in N, not a length"):
        hysteron.InverseFeedforward(dict(base, units={"output": "N"}))
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        hysteron.InverseFeedforward(dict(base, units={"output": "N"}), model_scale=1.0)
        hysteron.InverseFeedforward(in_mm)
    with pytest.raises(hysteron.Error, match=r"model_scale = 1000 .* the model's output is in m \(1 per metre\)"):
        hysteron.FeedforwardPidController(in_m, model_scale=1000.0)
    for make in (hysteron.FeedforwardPidController, hysteron.OpenLoopController, hysteron.CascadePwmController):
        make(in_m)  # model_scale from the units


def test_the_controllers_refuse_a_model_whose_input_is_in_another_pressure_unit(tmp_path):
    # the controllers' pressures (limits, PID gains, commands) are in MPa: on a model in kPa the inverse
    # saturated (a warning only, before 2026-12-01); refused as the C ABI and export --loop refuse it
    base = {"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3,
            "tau": 1.5, "alpha": 0.05, "output_gain": 30.0}
    in_kpa = dict(base, units={"input": "kPa", "output": "mm"}, input_limits=[0, 600])
    path = tmp_path / "model_kpa.json"
    path.write_text(json.dumps(in_kpa))
    for make in (hysteron.InverseFeedforward, hysteron.FeedforwardPidController, hysteron.OpenLoopController,
                 hysteron.CascadePwmController):
        name = make.__name__
        with pytest.raises(hysteron.Error, match=rf"{name}: model: the model's input is in kPa, not MPa.*refit the "
                                                 r"model with its pressure in MPa \(1 kPa = 0.001 MPa"):
            make(in_kpa)
        with pytest.raises(hysteron.Error, match=rf"{name}: model .*model_kpa.json: the model's input is in kPa"):
            make(str(path))
        with pytest.raises(hysteron.Error, match=r"the model's input is in bar, not MPa"):
            make(dict(base, units={"input": "bar"}, input_limits=[0, 6]))
        make(dict(base, units={"input": "MPa", "output": "mm"}, input_limits=[0, 0.6]))
        make(dict(base, input_limits=[0, 0.6]))  # no units: as before
    result = pathlib.Path(__file__).resolve().parents[2] / "tests" / "c_api" / "result.json"
    ctl = hysteron.loop_of_run(str(result), "compensated.sine")
    with pytest.raises(hysteron.Error, match=r"controller_from: model .*model_kpa.json: the model's input is in kPa"):
        hysteron.controller_from(ctl, str(path))
    with pytest.raises(hysteron.Error, match=r"the model's input is in kPa, not MPa"):
        hysteron.export_c(in_kpa, controller=ctl)
    hysteron.export_c(in_kpa)  # the model alone, in its own units


def test_a_loop_from_a_result_is_refused_on_a_model_in_another_length_unit():
    # result.json's loops carry model_scale 1000 (the experiments' models are in mm): on a model in
    # m, controller_from and export_c (as hysteron export --loop) built a loop that asked the
    # inverse for outputs 1000x too large
    result = pathlib.Path(__file__).resolve().parents[2] / "tests" / "c_api" / "result.json"
    ctl = hysteron.loop_of_run(str(result), "compensated.sine")
    pi = {"model": "pi", "q": 0.03, "r": [0.02, 0.05, 0.1, 0.15], "p": [0.012, 0.009, 0.006, 0.003],
          "input_limits": [0, 0.6]}
    in_m = dict(pi, units={"input": "MPa", "output": "m"})
    with pytest.raises(hysteron.Error, match=r"controller_from: model_scale = 1000 .*output is in m"):
        hysteron.controller_from(ctl, in_m)
    with pytest.raises(hysteron.Error, match=r"model_scale = 1000 .*output is in m"):
        hysteron.export_c(in_m, controller=ctl)
    in_mm = dict(pi, q=30, p=[12, 9, 6, 3], units={"input": "MPa", "output": "mm"})
    hysteron.controller_from(ctl, in_mm)
    hysteron.export_c(in_mm, controller=ctl)
    hysteron.controller_from(ctl, dict(pi, q=30, p=[12, 9, 6, 3]))  # no units: as before
