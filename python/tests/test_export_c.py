"""hysteron.export_c: generated C from Python, with a run's loop around the inverse
(docs/export.md). The loop is compiled with gcc as a shared library, loaded with ctypes and
stepped beside controller_from(...) on the same inputs: the commands and duties must be equal."""
import ctypes
import pathlib
import shutil
import subprocess

import numpy as np
import pytest

import hysteron

ROOT = pathlib.Path(__file__).resolve().parents[2]
RESULT = ROOT / "tests" / "c_api" / "result.json"  # a hand-written result.json (valve loops)
MODEL = {"model": "pi", "q": 30.0, "r": [0.02, 0.05, 0.1, 0.15], "p": [12.0, 9.0, 6.0, 3.0],
         "input_limits": [0.0, 0.6]}  # MPa -> mm, about 0-35 mm


def load_generated(tmp_path, controller):
    """export_c of MODEL with `controller`'s loop (prefix lp), compiled with gcc -Werror as a shared
    library and loaded with ctypes."""
    (tmp_path / "loop.c").write_text(hysteron.export_c(MODEL, prefix="lp", controller=controller)["source"])
    lib = tmp_path / "libloop.so"
    subprocess.run(["gcc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", "-O2", "-shared", "-fPIC",
                    str(tmp_path / "loop.c"), "-o", str(lib), "-lm"], check=True, capture_output=True)
    return ctypes.CDLL(str(lib))


def test_export_c_text_and_errors():
    plain = hysteron.export_c(MODEL, prefix="pam")
    assert "double pam_inverse_step(pam_inverse *inv, double y_desired)" in plain["source"]
    assert "pam_loop" not in plain["source"] and plain["header"] == ""
    ctl = hysteron.loop_of_run(str(RESULT), "compensated.sine")
    both = hysteron.export_c(MODEL, prefix="pam", header_name="pam.h", controller=ctl)
    assert '#include "pam.h"' in both["source"]
    assert "double pam_loop_step(pam_loop *c" in both["header"]
    assert "cascade_pwm" in both["source"]
    learning = hysteron.loop_of_run(str(RESULT), "learning.triangle")
    learnt = hysteron.export_c(MODEL, prefix="pam", header_name="pam.h", controller=learning)
    assert "double pam_loop_learning_step(pam_loop *c, pam_learning *l" in learnt["header"]
    assert "#define PAM_LEARNING_PERIOD %du" % learning["learning"]["period_samples"] in learnt["header"]
    # the filter's summed taps (about 6.4 sqrt(h) each side) wider than a period
    learning["learning"]["half_width"] = min(learning["learning"]["period_samples"] ** 2 // 16, 10_000_000)
    with pytest.raises(hysteron.Error, match="learning"):
        hysteron.export_c(MODEL, controller=learning)
    adaptive = hysteron.loop_of_run(str(RESULT), "adaptive.sine")  # "adaptation": an inverse adapted online
    with pytest.raises(hysteron.Error, match="its inverse is adapted online"):
        hysteron.export_c(MODEL, controller=adaptive)
    with pytest.raises(hysteron.Error, match="its inverse is adapted online"):
        hysteron.controller_from(adaptive, MODEL)
    with pytest.raises(hysteron.Error, match="differ from the loop's pressure limits"):
        hysteron.export_c(MODEL, controller=ctl, limits=(0.0, 0.5))
    with pytest.raises(hysteron.Error, match="prefix"):
        hysteron.export_c(MODEL, prefix="9lives")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not found: generated C not compiled")
def test_generated_loop_steps_as_controller_from(tmp_path):
    ctl = hysteron.loop_of_run(str(RESULT), "compensated.sine")
    c = load_generated(tmp_path, ctl)
    c.lp_loop_step.restype = ctypes.c_double
    c.lp_loop_step.argtypes = [ctypes.c_void_p] + [ctypes.c_double] * 4 + [ctypes.POINTER(ctypes.c_double)]
    c.lp_loop_preview.argtypes = [ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t]
    state = ctypes.create_string_buffer(1 << 16)  # lp_loop, opaque here (a few hundred bytes)
    c.lp_loop_reset(state)
    lib_loop = hysteron.controller_from(ctl, MODEL)  # a CascadePwmController

    n = 5000
    t = np.arange(n) * 1e-3
    ref = (16.0 + 12.0 * np.sin(2 * np.pi * 0.5 * t)) / 1000.0
    preview = hysteron.feedforward_preview(ctl, ref)
    c_preview = np.zeros(n)
    c.lp_loop_preview(ref.ctypes.data, c_preview.ctypes.data, n)
    assert np.array_equal(c_preview, preview)
    # a non-finite or 2-D reference is refused by name, as the C ABI's hysteron_loop_preview does
    bad = ref.copy()
    bad[7] = np.nan
    with pytest.raises(hysteron.Error, match=r"feedforward_preview: reference\[7\] = nan"):
        hysteron.feedforward_preview(ctl, bad)
    with pytest.raises(ValueError, match="one-dimensional"):
        hysteron.feedforward_preview(ctl, ref.reshape(50, 100))
    rng = np.random.default_rng(5)
    measured = ref + 0.004 * np.sin(2 * np.pi * 1.7 * t) + 0.0005 * rng.standard_normal(n)
    pressure = np.clip(0.3 + 0.3 * np.sin(2 * np.pi * 0.5 * t - 0.4) + 0.02 * rng.standard_normal(n), 0, 0.7)
    measured[1000] = np.nan
    pressure[2000] = np.inf
    duty = ctypes.c_double()
    limits = 0
    for k in range(n):
        u = c.lp_loop_step(state, ref[k], preview[k], measured[k], pressure[k], ctypes.byref(duty))
        d = lib_loop.step(ref[k], preview[k], measured[k], pressure[k])
        assert u == lib_loop.desired_pressure, k
        assert duty.value == d, k
        limits += u in (0.0, 0.6)
    assert limits > 0  # the commands reached a pressure limit


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not found: generated C not compiled")
def test_generated_learning_loop_steps_as_learning_from(tmp_path):
    # a learning run's loop and its iterative learning in generated C, against Python's own
    # composition: controller_from(...) fed reference + c(0) and preview + c(lead), and
    # learning_from(...) fed the error, or 0 at a pressure limit (docs/export.md, "The learning")
    ctl = hysteron.loop_of_run(str(RESULT), "learning.triangle")
    c = load_generated(tmp_path, ctl)
    c.lp_loop_learning_step.restype = ctypes.c_double
    c.lp_loop_learning_step.argtypes = [ctypes.c_void_p, ctypes.c_void_p] + [ctypes.c_double] * 4 + [
        ctypes.POINTER(ctypes.c_double)]
    c.lp_learning_correction.restype = ctypes.c_double
    c.lp_learning_correction.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
    period = ctl["learning"]["period_samples"]
    loop_state = ctypes.create_string_buffer(1 << 16)
    learning_state = ctypes.create_string_buffer(8 * 6 * period + 4096)  # 5 N doubles and the counters
    c.lp_loop_reset(loop_state)
    c.lp_learning_reset(learning_state)
    lib_loop = hysteron.controller_from(ctl, MODEL)  # a CascadePwmController
    ilc = hysteron.learning_from(ctl)
    lead = ctl["feedforward_lead_samples"]
    lo, hi = ctl["feedforward"]["pressure_min_mpa"], ctl["feedforward"]["pressure_max_mpa"]

    n = 3 * period
    t = np.arange(n) * 1e-3
    ref = (16.0 + 12.0 * np.sin(2 * np.pi * t / (period * 1e-3))) / 1000.0
    preview = np.array(hysteron.feedforward_preview(ctl, ref))
    rng = np.random.default_rng(11)
    measured = ref + 0.003 * np.sin(2 * np.pi * t / (period * 1e-3) - 0.5) + 0.0003 * rng.standard_normal(n)
    pressure = np.clip(0.3 + 0.3 * np.sin(2 * np.pi * t / (period * 1e-3) - 0.4), 0, 0.7)
    measured[700] = np.nan
    duty = ctypes.c_double()
    learnt = 0.0
    for k in range(n):
        c0 = ilc.correction(0)
        assert c.lp_learning_correction(learning_state, 0) == c0, k
        u = c.lp_loop_learning_step(loop_state, learning_state, ref[k], preview[k], measured[k], pressure[k],
                                    ctypes.byref(duty))
        d = lib_loop.step(ref[k] + c0, preview[k] + ilc.correction(lead), measured[k], pressure[k])
        p = lib_loop.desired_pressure
        ilc.step(0.0 if (p <= lo or p >= hi) else ref[k] - measured[k])
        assert u == p, k
        assert duty.value == d, k
        learnt = max(learnt, abs(c0))
    assert ilc.iteration == 3 and learnt > 1e-4  # three periods, corrections learnt


def compile_generated(tmp_path, source, name, flags):
    """source compiled with gcc -Werror and `flags` as a shared library, loaded with ctypes."""
    (tmp_path / (name + ".c")).write_text(source)
    lib = tmp_path / ("lib%s.so" % name)
    subprocess.run(["gcc", "-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror", *flags, "-shared", "-fPIC",
                    str(tmp_path / (name + ".c")), "-o", str(lib), "-lm"], check=True, capture_output=True)
    return ctypes.CDLL(str(lib))


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not found: generated C not compiled")
def test_generated_c_refuses_nan_under_fast_math(tmp_path):
    # isfinite()/isnan() are folded to constants under -ffast-math (-ffinite-math-only): the
    # generated checks read the bit pattern, so a NaN is still refused (docs/export.md)
    ctl = hysteron.loop_of_run(str(RESULT), "learning.triangle")
    source = hysteron.export_c(MODEL, prefix="fm", controller=ctl)["source"]
    nan = float("nan")
    for flags in (["-O2"], ["-O2", "-ffast-math"], ["-O3", "-ffinite-math-only"]):
        c = compile_generated(tmp_path, source, "fm" + "".join(flags).replace("-", "_"), flags)
        for f in ("fm_model_step", "fm_inverse_step"):
            getattr(c, f).restype = ctypes.c_double
            getattr(c, f).argtypes = [ctypes.c_void_p, ctypes.c_double]
        c.fm_model_reset_state.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double), ctypes.c_double]
        c.fm_loop_step.restype = ctypes.c_double
        c.fm_loop_step.argtypes = [ctypes.c_void_p] + [ctypes.c_double] * 4 + [ctypes.POINTER(ctypes.c_double)]
        c.fm_learning_correction.restype = ctypes.c_double
        c.fm_learning_correction.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
        c.fm_learning_step.argtypes = [ctypes.c_void_p, ctypes.c_double]
        model, inverse, loop = (ctypes.create_string_buffer(1 << 16) for _ in range(3))
        learning = ctypes.create_string_buffer(8 * 6 * ctl["learning"]["period_samples"] + 4096)
        c.fm_model_reset(model)
        y = c.fm_model_step(model, 0.3)
        assert np.isfinite(y) and c.fm_model_step(model, nan) == y, flags  # held
        state = (ctypes.c_double * 4)(0.1, 0.1, nan, 0.1)
        assert c.fm_model_reset_state(model, state, 0.2) == -1, flags
        # a state no accepted input reaches (its step would overflow to inf - inf = NaN) is refused
        c.fm_inverse_reset_state.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double), ctypes.c_double]
        big = (ctypes.c_double * 4)(1e308, 1e308, 1e308, 1e308)
        assert c.fm_model_reset_state(model, big, 1e308) == -1, flags
        assert c.fm_inverse_reset_state(inverse, big, 1e308) == -1, flags
        c.fm_inverse_reset(inverse)
        x = c.fm_inverse_step(inverse, 10.0)
        assert 0.0 < x < 0.6 and c.fm_inverse_step(inverse, nan) == x, flags  # held
        c.fm_loop_reset(loop)
        duty = ctypes.c_double()
        for k in range(3):  # the lag compensation's derivative settles at 0
            u = c.fm_loop_step(loop, 0.016, 0.016, 0.015, 0.3, ctypes.byref(duty))
        held = c.fm_loop_step(loop, 0.016, 0.016, nan, nan, ctypes.byref(duty))
        assert np.isfinite(u) and held == u, (flags, u, held)  # the PID holds
        c.fm_learning_reset(learning)
        for k in range(10):
            c.fm_learning_step(learning, nan)  # learnt as 0
        assert c.fm_learning_correction(learning, 0) == 0.0, flags


TANH_MODELS = {  # tanh envelopes (the branch-free tanh and atanh kernels), gpi-pid's scale (MPa -> mm)
    "gpi": {"model": "gpi", "envelope": "tanh", "c": [26.5, 5.4, -1.67, 21.4], "q": 0.8, "n": 10, "rho": 0.4,
            "tau": 0.1, "alpha": 2.0, "input_limits": [0.0, 0.6]},
    "mpi_asym": {"model": "mpi-asym", "ascending": {"envelope": "tanh", "c": [26.5, 5.4, -1.67, 21.4]},
                 "descending": {"envelope": "tanh", "c": [21.0, 7.7, -1.84, 15.2]}, "q": 0.02,
                 "r": [0.3 * i for i in range(1, 9)], "p": [1.1, 0.45, 0.25, 0.1, 0.05, 0.03, 0.02, 0.3],
                 "input_limits": [0.0, 0.6]}}


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not found: generated C not compiled")
@pytest.mark.parametrize("name", sorted(TANH_MODELS))
def test_generated_c_under_fast_math_matches_the_library(tmp_path, name):
    # -ffast-math (-fassociative-math) used to fold the tanh kernel's (y/ln2 + 1.5 2^52) - 1.5 2^52
    # to y/ln2: the model was off by up to 10 mm and its inverse by 0.09 MPa, commands within limits.
    # Now k is read from the bits; the results stay within 1e-12 (relative to the output range) of
    # the library's, and bit-identical without the flags (docs/export.md, "Limits").
    spec = TANH_MODELS[name]
    source = hysteron.export_c(spec, prefix="tm")["source"]
    n = 4000
    k = np.arange(n)
    rng = np.random.default_rng(3)
    x = np.clip(0.3 + 0.3 * np.exp(-k / 2000) * np.sin(2 * np.pi * k / 400) + 0.01 * rng.standard_normal(n), 0, 0.6)
    lib_model = hysteron.Model(spec)
    y_lib = np.array([lib_model.step(v) for v in x])
    y_span = y_lib.max() - y_lib.min()
    yd = np.concatenate([y_lib[::-1], [y_lib.max() + 5.0, y_lib.min() - 5.0]])  # and two beyond reach
    lib_inverse = hysteron.Inverse(spec)
    x_lib = np.array([lib_inverse.step(v) for v in yd])
    for flags in (["-O2"], ["-O2", "-ffast-math"], ["-O3", "-fassociative-math", "-fno-signed-zeros",
                                                     "-fno-trapping-math"]):
        c = compile_generated(tmp_path, source, "tm" + "".join(flags).replace("-", "_"), flags)
        for f in ("tm_model_step", "tm_inverse_step"):
            getattr(c, f).restype = ctypes.c_double
            getattr(c, f).argtypes = [ctypes.c_void_p, ctypes.c_double]
        model, inverse = ctypes.create_string_buffer(1 << 16), ctypes.create_string_buffer(1 << 16)
        c.tm_model_reset(model)
        c.tm_inverse_reset(inverse)
        y_c = np.array([c.tm_model_step(model, v) for v in x])
        x_c = np.array([c.tm_inverse_step(inverse, v) for v in yd])
        if flags == ["-O2"]:
            assert np.array_equal(y_c, y_lib) and np.array_equal(x_c, x_lib), name
            continue
        y_err = np.max(np.abs(y_c - y_lib)) / y_span
        x_err = np.max(np.abs(x_c - x_lib)) / 0.6
        assert y_err <= 1e-12 and x_err <= 1e-12, (name, flags, y_err, x_err)
        assert x_c[-2] == 0.6 and x_c[-1] == 0.0, (name, flags)  # beyond reach: the limits


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc not found: generated C not compiled")
def test_learning_with_huge_errors_keeps_its_corrections_finite(tmp_path):
    # errors of 1.2e308 are finite, but L e overflows with L = 1.9 (and alternating signs give
    # inf - inf): the sample keeps its correction of the period before (counted in overflows), in
    # the library and in generated C alike
    ctl = hysteron.loop_of_run(str(RESULT), "learning.triangle")
    ctl["learning"].update({"gain": 1.9, "max_gain": 0.0, "rise_tolerance": None, "half_width": 2,
                            "hold_after_cuts": 0})
    ilc = hysteron.learning_from(ctl)
    period = ctl["learning"]["period_samples"]
    c = compile_generated(tmp_path, hysteron.export_c(MODEL, prefix="lp", controller=ctl)["source"], "lp", ["-O2"])
    c.lp_learning_correction.restype = ctypes.c_double
    c.lp_learning_correction.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
    c.lp_learning_step.argtypes = [ctypes.c_void_p, ctypes.c_double]
    learning = ctypes.create_string_buffer(8 * 6 * period + 4096)
    c.lp_learning_reset(learning)
    for k in range(3 * period):
        e = 1.2e308 if k % 2 else -1.2e308
        assert np.isfinite(ilc.correction(0)), k
        assert c.lp_learning_correction(learning, 0) == ilc.correction(0), k
        ilc.step(e)
        c.lp_learning_step(learning, e)
    assert ilc.overflows > 0 and ilc.faults == 0
    plain = hysteron.IterativeLearning(period=20, gain=1.9, half_width=2)
    for k in range(80):  # L e alone overflows; alternating signs: inf - inf
        assert np.isfinite(plain.correction(0)), k
        plain.step(1.2e308 if k % 2 else -1.2e308)
    assert plain.overflows > 0
