"""The Python module as a demanding user meets it: copy, deepcopy and pickle of models, inverses
and PIDs (the state kept, bit for bit; to a spawned worker process), Inverse(an Inverse),
integer arguments named (no "incompatible function arguments"), fit's arrays copied before the
GIL is released, complex arrays refused, and one path mechanism (str, bytes, os.PathLike, a file
name that is not UTF-8)."""
import concurrent.futures
import copy
import inspect
import multiprocessing
import operator
import os
import pickle
import sys
import threading
import warnings

import numpy as np
import pytest

import hysteron

LIMITS = [-1.5, 1.5]
KINDS = [
    {"model": "pi", "q": 0.5, "r": [0.05, 0.1, 0.2], "p": [0.3, 0.2, 0.1]},
    {"model": "gpi", "envelope": "tanh", "c": [1, 2, -0.6, 0.6], "q": 0.8, "n": 10, "rho": 0.4, "tau": 5,
     "alpha": 0.03},
    {"model": "mpi-deadzone", "q": 0.5, "r": [0.05, 0.1], "p": [0.3, 0.2], "g0": 1.0, "z": [0.2, -0.1],
     "g": [0.3, 0.2]},
    {"model": "mpi-asym", "q": 0.5, "r": [0.05, 0.1], "p": [0.3, 0.2],
     "ascending": {"envelope": "tanh", "c": [1, 2, -0.6, 0.6]}, "descending": {"envelope": "affine", "c": [1.2, 0.0]}},
    {"model": "preisach", "q": 0.5, "lo": -1, "hi": 1, "levels": 2, "w": [0.2, 0.1, 0.3]},
    {"model": "kp", "q": 0.5, "lo": -1, "hi": 1, "levels": 2, "w": [0.2, 0.1, 0.3]},
    {"model": "bouc-wen", "kx": 1.0, "kw": -0.05, "rho": 4, "sigma": 1, "n": 1.5},
    {"model": "maxwell-slip", "k0": 0.4, "k": [0.3, 0.5], "delta": [0.1, 0.25]},
    {"model": "rate-pi", "q": 0.3, "r": [0.1, 0.2], "p": [0.4, 0.3], "c": 0.12, "tau": 0.1, "dt": 0.001},
]
KINDS = [dict(k, input_limits=LIMITS) for k in KINDS]
GPI = KINDS[1]


def wave(n, seed):
    """Reversals of random amplitude in [-1, 1] (minor loops, so the state matters)."""
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    return np.sin(2 * np.pi * k / 97) * rng.uniform(0.2, 1.0) + 0.3 * np.sin(2 * np.pi * k / 23)


def copies(obj):
    return {"copy": copy.copy(obj), "deepcopy": copy.deepcopy(obj), "pickle": pickle.loads(pickle.dumps(obj))}


# 1. copy, deepcopy and pickle keep a running model's and inverse's state bit for bit.
@pytest.mark.parametrize("spec", KINDS, ids=[k["model"] for k in KINDS])
def test_model_and_inverse_copies_continue_sample_by_sample(spec):
    m, inv = hysteron.Model(spec), hysteron.Inverse(spec)
    y = m.simulate(wave(300, 1))
    inv.simulate(y)
    m.step(float("nan"))  # a fault: counted, the output held
    inv.step(float("nan"))
    for name in ("copy", "deepcopy", "pickle"):
        mc, ic = copies(m)[name], copies(inv)[name]
        assert type(mc) is hysteron.Model and type(ic) is hysteron.Inverse, name
        assert mc.faults == m.faults > 0 and ic.faults == inv.faults > 0, name
        np.testing.assert_array_equal(mc.state, m.state)
        assert mc.to_dict() == m.to_dict() and ic.limits == inv.limits, name
        assert mc.step(float("nan")) == m.step(float("nan")), name  # the held output
        x = wave(500, 2)
        a, b = m.simulate(x), mc.simulate(x)
        np.testing.assert_array_equal(a, b)  # bit for bit
        np.testing.assert_array_equal(inv.simulate(a), ic.simulate(b))
        assert ic.saturated == inv.saturated, name
    # a copy is independent: stepping the original leaves it
    before = m.state.copy()
    c = copy.copy(m)
    m.step(0.9)
    m.step(-0.9)
    np.testing.assert_array_equal(c.state, before)


def test_pid_copies_continue_with_their_state_and_guard():
    pid = hysteron.Pid(kp=2.0, ki=5.0, kd=0.01, derivative_filter=0.005, out_min=-1, out_max=1,
                       guard={"period": 0.02, "amplitude": 0.05, "count": 2.0})
    for k in range(400):
        pid.step(np.sin(k * 0.6), 0.0)  # rings: the guard cuts the gains
    pid.step(float("nan"), 0.0)
    assert pid.gain_scale < 1 and pid.faults == 1
    for name in ("copy", "deepcopy", "pickle"):
        c = copies(pid)[name]
        assert (c.params, c.gain_scale, c.guard_cuts, c.integral, c.output, c.faults) == \
            (pid.params, pid.gain_scale, pid.guard_cuts, pid.integral, pid.output, pid.faults), name
        for k in range(300):
            assert c.step(np.sin(k * 0.3), 0.1) == pid.step(np.sin(k * 0.3), 0.1), (name, k)


@pytest.mark.parametrize("make, run", [
    (lambda: hysteron.PamRig(seed=3), lambda r, k: r.step(0.2 + 0.1 * np.sin(k * 0.01))["contraction_measured"]),
    (lambda: hysteron.Rls(KINDS[0]), lambda r, k: r.step(np.sin(k * 0.05), 0.3 * np.sin(k * 0.05))),
    (lambda: hysteron.IterativeLearning(20, lookahead=1), lambda c, k: (c.step(np.sin(k * 0.3)), c.correction(1))),
    (lambda: hysteron.InverseFeedforward(GPI, pressure_limits=(-1.5, 1.5), model_scale=1.0),
     lambda c, k: c.step(0.5 * np.sin(k * 0.05))),
    (lambda: hysteron.FeedforwardPidController(GPI, pressure_limits=(-1.5, 1.5), model_scale=1.0),
     lambda c, k: c.step(0.5 * np.sin(k * 0.05), 0.5 * np.sin(k * 0.05), 0.4 * np.sin(k * 0.05))),
    (lambda: hysteron.CascadePwmController(GPI, pressure_limits=(-1.5, 1.5), model_scale=1.0),
     lambda c, k: c.step(0.5 * np.sin(k * 0.05), 0.5 * np.sin(k * 0.05), 0.4 * np.sin(k * 0.05), 0.1)),
], ids=["PamRig", "Rls", "IterativeLearning", "InverseFeedforward", "FeedforwardPidController", "CascadePwm"])
def test_objects_with_live_state_copy_but_do_not_pickle(make, run):
    a = make()
    for k in range(200):
        run(a, k)
    b, c = copy.copy(a), copy.deepcopy(a)
    for k in range(200, 500):
        assert run(a, k) == run(b, k) == run(c, k), k
    with pytest.raises(TypeError, match="cannot pickle"):
        pickle.dumps(a)


def test_a_pickled_state_of_another_form_is_refused():
    state = hysteron.Model(GPI).__getstate__()
    assert state[0] == 1 and isinstance(state[1], str) and len(state[2]) == 10 + 3  # operators, u, output, faults
    m = hysteron.Model.__new__(hysteron.Model)
    with pytest.raises(hysteron.Error, match=r"Model: not a pickled state of this version of hysteron"):
        m.__setstate__((2,) + tuple(state[1:]))
    with pytest.raises(hysteron.Error, match=r"gpi: snapshot has 3 values, expected 13"):
        m.__setstate__((1, state[1], [0.0, 0.0, 0.0]))


def test_a_model_goes_to_a_spawned_worker_and_back():
    x = wave(400, 3)
    m = hysteron.Model(GPI)
    m.simulate(wave(100, 4))  # mid-run
    expected = copy.copy(m).simulate(x)
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        remote = pool.submit(operator.methodcaller("simulate", x), m).result(timeout=120)
        back = pool.submit(copy.copy, m).result(timeout=120)
    np.testing.assert_array_equal(remote, expected)
    np.testing.assert_array_equal(back.simulate(x), expected)


# 2. Inverse(an Inverse): its model and limits, in the virgin state; limits= replaces them.
def test_inverse_of_an_inverse_is_a_copy_of_its_model_and_limits():
    inv = hysteron.Inverse(GPI, limits=(-0.5, 0.9))
    y = hysteron.Model(GPI).simulate(wave(300, 5))
    inv.simulate(y[:100])  # mid-run: the copy starts virgin all the same
    again = hysteron.Inverse(inv)
    assert again.limits == (-0.5, 0.9)
    np.testing.assert_array_equal(again.simulate(y), hysteron.Inverse(GPI, limits=(-0.5, 0.9)).simulate(y))
    assert hysteron.Inverse(inv, limits=(-0.2, 0.3)).limits == (-0.2, 0.3)
    assert "or a hysteron.Inverse: its model and limits" in hysteron.Inverse.__doc__


# 3. Every integer argument: a negative value or a non-integer is named.
def test_every_integer_argument_is_named():
    x = wave(200, 6)
    y = hysteron.Model(GPI).simulate(x)
    ilc = hysteron.IterativeLearning(10, lookahead=2)
    cases = [
        (lambda: hysteron.fit(x, y, num_operators=-1), hysteron.Error,
         r"^fit: num_operators must be an integer >= 0, got -1$"),
        (lambda: hysteron.fit(x, y, num_operators=2.0), TypeError,
         r"^fit: num_operators: expected an integer >= 0, got float"),
        (lambda: hysteron.fit(x, y, num_starts=-2), ValueError, r"fit: num_starts must be"),
        (lambda: hysteron.fit(x, y, num_starts=2.5), TypeError, r"fit: num_starts: expected"),
        (lambda: hysteron.fit(x, y, max_iterations=-1), ValueError, r"fit: max_iterations must be"),
        (lambda: hysteron.fit(x, y, num_threads="2"), TypeError, r"fit: num_threads: expected .* got str '2'"),
        (lambda: hysteron.fit(x, y, num_threads=-1), ValueError, r"fit: num_threads must be"),
        (lambda: hysteron.fit(x, y, num_dead_zones=-1), ValueError, r"fit: num_dead_zones must be"),
        (lambda: hysteron.fit(x, y, stall_iterations=None), TypeError, r"fit: stall_iterations: expected"),
        (lambda: hysteron.fit(x, y, censor_passes=-1), ValueError, r"fit: censor_passes must be"),
        (lambda: hysteron.fit(x, y, num_operators=2**40), ValueError,
         r"fit: num_operators = 1099511627776 is too large \(at most 2147483647\)"),
        (lambda: hysteron.fit(x, y, seed=2**32), ValueError,
         r"fit: seed = 4294967296 is too large \(at most 4294967295\)"),
        (lambda: hysteron.reference_pi(x, y, num_operators=-3), ValueError, r"reference_pi: num_operators must be"),
        (lambda: hysteron.run_experiment("gpi-pid", learning_periods=-1), hysteron.Error,
         r"run_experiment: learning_periods must be an integer >= 0, got -1"),
        (lambda: hysteron.run_experiment("gpi-pid", learning_periods=2.5), TypeError,
         r"run_experiment: learning_periods: expected"),
        (lambda: hysteron.run_sweep("gpi-pid", vary=["load.mass=10"], learning_periods=-1), ValueError,
         r"run_sweep: learning_periods must be"),
        (lambda: hysteron.rls_fit(KINDS[0], x, y, passes=-1), ValueError, r"rls_fit: passes must be an integer >= 0"),
        (lambda: hysteron.rls_fit(KINDS[0], x, y, passes=1.5), TypeError, r"rls_fit: passes: expected"),
        (lambda: hysteron.plot_hysteresis_loops(x, y, y, "p.svg", major_end=-1), ValueError,
         r"plot_hysteresis_loops: major_end must be an integer >= 0, got -1"),
        (lambda: ilc.correction(ahead=-1), ValueError, r"IterativeLearning.correction: ahead must be an integer >= 0"),
        (lambda: ilc.correction(ahead=1.0), TypeError, r"IterativeLearning.correction: ahead: expected"),
        (lambda: hysteron.mpi_sine_contraction(0.01, -1), ValueError, r"mpi_sine_contraction: periods_each must be"),
        (lambda: hysteron.mpi_triangle_contraction(0.01, 1.5), TypeError, r"mpi_triangle_contraction: periods_each"),
        (lambda: hysteron.wave_sequence([{"periods": 1.5}], 0.01), TypeError,
         r'wave_sequence: segments\[0\]\["periods"\]: expected'),
    ]
    for call, kind, message in cases:
        with pytest.raises(kind, match=message) as e:
            call()
        assert "incompatible function arguments" not in str(e.value)
    assert ilc.correction(ahead=np.int64(2)) == 0.0  # numpy integers are integers
    # help() still shows the types
    assert "num_operators: int = 10" in hysteron.fit.__doc__
    assert "x: numpy.ndarray[numpy.float64]" in hysteron.fit.__doc__
    assert "report: os.PathLike = ''" in hysteron.fit.__doc__


# 4. fit copies x and y before it releases the GIL: another thread changing them does not reach it.
def test_fit_is_not_disturbed_by_a_thread_changing_its_arrays():
    x = np.tile(wave(1000, 7), 4)
    y = hysteron.Model(GPI).simulate(x) + 0.01 * np.random.default_rng(8).standard_normal(x.size)
    options = dict(model="gpi", num_starts=2, num_threads=1)
    expected = hysteron.fit(x.copy(), y.copy(), **options)
    assert expected["status"] == "converged"
    result = {}
    old = sys.getswitchinterval()
    sys.setswitchinterval(5.0)  # the fit's thread keeps the GIL until the fit releases it
    try:
        t = threading.Thread(target=lambda: result.update(hysteron.fit(x, y, **options)))
        t.start()
        x[:] = np.nan  # runs once the fit released the GIL: while it runs
        y[::-1] = y.copy()
        t.join()
    finally:
        sys.setswitchinterval(old)
    assert result["status"] == "converged"
    assert [p["value"] for p in result["parameters"]] == [p["value"] for p in expected["parameters"]]
    assert result["train"] == expected["train"]


# 4b. evaluate and simulate_record copy their arrays and run without the GIL. With a switch interval
# of 5 s a thread keeps the GIL until a call releases it: a worker makes K calls in a row, and this
# thread, waiting for the GIL in t.start(), runs again while one of them is in progress (fewer than
# K results yet). Holding the GIL, the calls would all end first (K results when this thread runs;
# the K calls take well under the 5 s). K chances, since the wake-up may take a time slice.
def test_evaluate_and_simulate_record_run_without_the_gil():
    x = np.tile(wave(1000, 7), 20)
    y = hysteron.Model(GPI).simulate(x) + 0.01 * np.random.default_rng(8).standard_normal(x.size)
    calls = {
        "simulate_record": (50, lambda: hysteron.simulate_record(GPI, x)),
        "evaluate": (10, lambda: hysteron.evaluate(GPI, x, y)),
    }
    for name, (k, call) in calls.items():
        expected = call()
        results = []
        old = sys.getswitchinterval()
        sys.setswitchinterval(5.0)
        try:
            t = threading.Thread(target=lambda: results.extend(call() for _ in range(k)))
            t.start()
            during = len(results) < k
            t.join()
        finally:
            sys.setswitchinterval(old)
        assert during, f"{name} held the GIL until it ended"
        assert len(results) == k
        for r in results:
            if name == "evaluate":
                assert {q: r[q] for q in ("rms", "max", "n")} == {q: expected[q] for q in ("rms", "max", "n")}
            else:
                np.testing.assert_array_equal(r, expected)


# 5. Complex arrays are refused naming the argument (numpy would drop the imaginary part with a warning).
def test_complex_arrays_are_refused():
    x = wave(50, 9)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way
        for call, message in [
            (lambda: hysteron.Model(GPI).simulate(x + 0.5j),
             r"^Model.simulate: x: a complex array \(dtype complex128\)"),
            (lambda: hysteron.Model(GPI).simulate(x.astype(np.complex64)), r"dtype complex64"),
            (lambda: hysteron.fit(x, [1 + 1j] * 50), r"^fit: y: a complex array"),
            (lambda: hysteron.Inverse(GPI).simulate(list(x + 0j)), r"^Inverse.simulate: y: a complex array"),
            (lambda: hysteron.compute_metrics(x, x * 1j), r"compute_metrics: predicted: a complex array"),
        ]:
            with pytest.raises(TypeError, match=message):
                call()
        # what is no array of numbers is named too
        with pytest.raises(TypeError, match=r"^Model.simulate: x: expected an array of real numbers, got list \['a'\]"):
            hysteron.Model(GPI).simulate(["a"])
        with pytest.raises(TypeError, match=r"IterativeLearning.reset: correction: expected an array"):
            hysteron.IterativeLearning(3).reset([[1.0], [2.0, 3.0]])
    # real arrays of any dtype, lists and booleans are as before
    np.testing.assert_array_equal(hysteron.Model(GPI).simulate(x.astype(np.float32)),
                                  hysteron.Model(GPI).simulate(x.astype(np.float32).astype(float)))
    np.testing.assert_array_equal(hysteron.Model(GPI).simulate(list(x)), hysteron.Model(GPI).simulate(x))


# 6. One path mechanism: str, bytes, os.PathLike and a file name that is not UTF-8, for reading and writing.
def test_paths_one_mechanism(tmp_path):
    m = hysteron.Model(GPI)
    odd = tmp_path / os.fsdecode(b"model-\xff.json")  # not UTF-8: a surrogate escape in the str
    m.save(odd)
    assert os.path.exists(os.fsencode(odd))
    assert hysteron.Model(odd).to_dict() == m.to_dict()
    assert hysteron.Model(str(odd)).to_dict() == m.to_dict()
    assert hysteron.Model(os.fsencode(odd)).to_dict() == m.to_dict()  # bytes: read as well as written
    missing = tmp_path / os.fsdecode(b"none-\xff.json")  # named in the error as the str given, no UnicodeDecodeError
    with pytest.raises(hysteron.Error, match="none-\udcff.json: cannot open model file"):
        hysteron.Model(missing)
    m.save(os.fsencode(tmp_path / "b.json"))
    assert hysteron.Model(tmp_path / "b.json").to_dict() == m.to_dict()
    for call, message in [
        (lambda: m.save(3), r"^Model.save: path: expected a path \(a str, bytes or an os.PathLike"),
        (lambda: hysteron.fit([0.0, 1.0], [0.0, 1.0], report=3.5), r"^fit: report: expected a path"),
        (lambda: hysteron.write_report(None, "x.html"), r"^write_report: input: expected a path"),
        (lambda: hysteron.loop_of_run(3, "compensated"), r"^loop_of_run: result: expected a path"),
    ]:
        with pytest.raises(TypeError, match=message) as e:
            call()
        assert "incompatible function arguments" not in str(e.value)
    assert "path: os.PathLike" in inspect.getdoc(hysteron.Model.save)
