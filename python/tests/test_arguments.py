"""Arguments the binding converts itself: a wrong type is a TypeError (a bad value a ValueError)
naming the argument and what it takes, never pybind11's RuntimeError "Unable to cast Python
instance to C++ type"; dicts with an unknown key are refused with the closest key; the outputs
of a long run are checked before it starts."""
import copy
import os
import pathlib

import numpy as np
import pytest

import hysteron

ROOT = pathlib.Path(__file__).resolve().parents[2]
RESULT = ROOT / "tests" / "c_api" / "result.json"  # a hand-written result.json (valve loops)
MODEL = {"model": "pi", "q": 30.0, "r": [0.02, 0.05, 0.1, 0.15], "p": [12.0, 9.0, 6.0, 3.0]}


def test_bad_argument_types_name_the_argument():
    cases = [
        (lambda: hysteron.Inverse(MODEL, limits=(None, 0.6)), TypeError, r"Inverse: limits: expected \(lo, hi\)"),
        (lambda: hysteron.Inverse(MODEL, limits=0.6), TypeError, r"Inverse: limits: expected .* got float 0.6"),
        (lambda: hysteron.FeedforwardPidController(MODEL, pid={"kp": 1.0}), TypeError,
         r"FeedforwardPidController: pid: expected a hysteron.Pid .* got dict"),
        (lambda: hysteron.OpenLoopController(MODEL, pid={"kp": 1.0}), TypeError, "OpenLoopController: pid"),
        (lambda: hysteron.CascadePwmController(MODEL, pressure_pid={"kp": 20}), TypeError,
         "CascadePwmController: pressure_pid: expected a hysteron.Pid"),
        (lambda: hysteron.CascadePwmController(MODEL, pwm=[1, 2]), TypeError, "CascadePwmController: pwm: expected a dict"),
        (lambda: hysteron.CascadePwmController(MODEL, pwm={"gain": "high"}), TypeError,
         r'pwm\["gain"\]: expected a number, got str'),
        (lambda: hysteron.Pid(kp=1, guard={"period": "1s"}), TypeError, r'Pid: guard\["period"\]: expected a number'),
        (lambda: hysteron.wave_sequence([{"amplitude": "1"}], 0.01), TypeError,
         r'wave_sequence: segments\[0\]\["amplitude"\]: expected a number'),
        (lambda: hysteron.wave_sequence([3.0], 0.01), TypeError, r"wave_sequence: segments\[0\]: expected a dict"),
        (lambda: hysteron.run_sweep(1, vary=["load.mass=10"]), TypeError, "run_sweep: experiments: expected"),
        (lambda: hysteron.plot([{"label": "a", "x": [0, 1], "y": ["p", "q"]}], "p.svg"), TypeError,
         r'plot: series\[0\]\["y"\]: expected an array'),
    ]
    for call, kind, message in cases:
        with pytest.raises(kind, match=message):
            call()


def test_sample_ranges_name_the_argument():
    x = np.linspace(0.0, 0.6, 200)
    y = hysteron.Model(MODEL).simulate(x)
    with pytest.raises(ValueError, match=r"fit: train: begin = -1: a sample index must be >= 0"):
        hysteron.fit(x, y, model="pi", train=(-1, 100))
    with pytest.raises(ValueError, match=r"evaluate: range: end = -5"):
        hysteron.evaluate(MODEL, x, y, range=(0, -5))
    with pytest.raises(TypeError, match=r"fit: train: begin: expected a sample index .* got float 2.5"):
        hysteron.fit(x, y, model="pi", train=(2.5, 100))
    with pytest.raises(TypeError, match=r"reference_pi: train: expected \(begin, end\)"):
        hysteron.reference_pi(x, y, train=100)
    with pytest.raises(TypeError, match=r"fit_weights: train: end: expected"):
        hysteron.fit_weights(MODEL, x, y, train=(0, "end"))
    # numpy integers and None are sample indices
    assert hysteron.evaluate(MODEL, x, y, range=(np.int64(10), None))["n"] == 190


def test_loop_dicts_refuse_unknown_keys():
    ctl = hysteron.loop_of_run(str(RESULT), "learning.triangle")
    hysteron.controller_from(ctl, MODEL)  # as written: accepted
    cases = [
        ([], "feedforward_lead_sampels", "controller: unknown key 'feedforward_lead_sampels', "
                                         "did you mean 'feedforward_lead_samples'?"),
        (["learning"], "gian", "controller.learning: unknown key 'gian', did you mean 'gain'?"),
        (["pid"], "kp", "controller.pid: unknown key 'kp' "),  # not close to a key: the keys listed
        (["feedforward"], "pressure_max", "controller.feedforward: unknown key 'pressure_max', "
                                          "did you mean 'pressure_max_mpa'?"),
        (["pwm"], "dead_band", "controller.pwm: unknown key 'dead_band', did you mean 'deadband'?"),
    ]
    for path, key, message in cases:
        bad = copy.deepcopy(ctl)
        d = bad
        for p in path:
            d = d[p]
        d[key] = 1.0
        for call in (lambda: hysteron.controller_from(bad, MODEL), lambda: hysteron.learning_from(bad),
                     lambda: hysteron.feedforward_preview(bad, [0.01, 0.02]),
                     lambda: hysteron.export_c(MODEL, controller=bad)):
            with pytest.raises(hysteron.Error) as e:
                call()
            assert message in str(e.value), str(e.value)
    with pytest.raises(hysteron.Error, match=r"wave_sequence: segments\[0\]: unknown key 'amplitde', "
                                             r"did you mean 'amplitude'\?"):
        hysteron.wave_sequence([{"amplitde": 1.0}], 0.01)
    with pytest.raises(hysteron.Error, match=r"plot: series\[0\]: unknown key 'colour', did you mean 'color'\?"):
        hysteron.plot([{"label": "a", "x": [0, 1], "y": [0, 1], "colour": "red"}], "p.svg")


def test_long_runs_check_their_outputs_first(tmp_path):
    # The destination is checked before the run: with an unknown experiment name the run itself
    # would fail at once, so the destination's error shows that the check came first.
    missing = tmp_path / "missing" / "deeper"
    with pytest.raises(hysteron.Error, match=r"run_experiment: report .*missing/deeper/r.html: directory .* does not "
                                             r"exist \(nothing was run or written\)"):
        hysteron.run_experiment("no-such-experiment", report=str(missing / "r.html"))
    (tmp_path / "file").write_text("x")
    with pytest.raises(hysteron.Error, match=r"run_experiment: out .*file/res: .*file is not a directory"):
        hysteron.run_experiment("no-such-experiment", out=str(tmp_path / "file" / "res"))
    with pytest.raises(hysteron.Error, match="run_experiment: report .*: is a directory"):
        hysteron.run_experiment("no-such-experiment", report=str(tmp_path))
    with pytest.raises(hysteron.Error, match=r"run_sweep: out .*: directory .* does not exist"):
        hysteron.run_sweep("no-such-experiment", vary=["load.mass=10"], out=str(missing / "t.csv"))
    with pytest.raises(hysteron.Error, match=r"run_sweep: report .*: directory .* does not exist"):
        hysteron.run_sweep("no-such-experiment", vary=["load.mass=10"], report=str(missing / "t.html"))
    x = np.linspace(0.0, 0.6, 200)
    with pytest.raises(hysteron.Error, match=r"fit: report .*: directory .* does not exist"):
        hysteron.fit(x, hysteron.Model(MODEL).simulate(x), model="pi", report=str(missing / "fit.html"))
    assert not (tmp_path / "missing").exists() and sorted(os.listdir(tmp_path)) == ["file"]
    # a new out directory (created by the run) with the report in it passes the check: the
    # unknown experiment is what fails
    for out, report in [(tmp_path / "new" / "res", tmp_path / "new" / "res" / "report.html"),
                        (tmp_path / "new2", "")]:
        with pytest.raises(hysteron.Error, match="no-such-experiment"):
            hysteron.run_experiment("no-such-experiment", out=str(out), report=str(report))
    assert sorted(os.listdir(tmp_path)) == ["file"]


def test_outputs_and_report_are_replaced_together(tmp_path):
    # run_experiment(out=, report=) and run_sweep(out=, report=) replace their files together, as
    # the CLI's --out/--report: a report that cannot be written (a file without any write bit is
    # refused, even for root) leaves the earlier outputs as they were.
    fast = dict(seed=1, learning_periods=0, adaptive=False, model="gpi")
    out = tmp_path / "res"
    out.mkdir()
    (out / "result.json").write_text("earlier run")
    locked = tmp_path / "locked.html"
    locked.write_text("earlier page")
    locked.chmod(0o444)
    with pytest.raises(hysteron.Error, match="locked.html"):
        hysteron.run_experiment("gpi-pid", out=str(out), report=str(locked), **fast)
    assert (out / "result.json").read_text() == "earlier run"
    assert sorted(os.listdir(out)) == ["result.json"]
    table = tmp_path / "t.csv"
    table.write_text("earlier table")
    with pytest.raises(hysteron.Error, match="locked.html"):
        hysteron.run_sweep("gpi-pid", vary=["load.mass=35"], learning_periods=0, model="gpi", jobs=1,
                           out=str(table), report=str(locked))
    assert table.read_text() == "earlier table"
    assert locked.read_text() == "earlier page"
    # a report inside out is one of the run's files: a second run keeps it (not removed as stale)
    inside = out / "report.html"
    for _ in range(2):
        hysteron.run_experiment("gpi-pid", out=str(out), report=str(inside), **fast)
        assert inside.exists() and "<html" in inside.read_text()[:2000].lower()
    assert (out / "result.json").read_text() != "earlier run"
    # ... also where it is a link to a page elsewhere: the link stays, its target is the page
    pub = tmp_path / "pub"
    pub.mkdir()
    inside.unlink()
    inside.symlink_to("../pub/index.html")
    for _ in range(2):
        hysteron.run_experiment("gpi-pid", out=str(out), report=str(inside), **fast)
        assert inside.is_symlink() and "<html" in (pub / "index.html").read_text()[:2000].lower()
