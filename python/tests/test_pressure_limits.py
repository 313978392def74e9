"""The controllers' pressure_limits where none are named (None, the default): the model's
input_limits (a fitted model's training input range), not the nominal rig's 0..0.6 MPa; a model
without finite ones raises hysteron.Error naming pressure_limits; named limits win."""
import math

import numpy as np
import pytest

import hysteron


def gpi(limits):
    """A GPI in MPa -> mm of the rig's magnitude (about 100 mm at 0.6 MPa)."""
    m = {"model": "gpi", "envelope": "tanh", "c": [60.0, 3.0, -0.9, 45.0], "q": 0.8, "n": 10,
         "rho": 0.05, "tau": 0.1, "alpha": 1.0}
    if limits is not None:
        m["input_limits"] = list(limits)
    return m


def pid():
    return hysteron.Pid(kp=5.0, ki=1.0)  # unbounded output: only the pressure limits bound the command


def controllers(model, **kw):
    """Every controller kind on model; kw: pressure_limits or nothing."""
    return {
        "InverseFeedforward": hysteron.InverseFeedforward(model, **kw),
        "FeedforwardPidController": hysteron.FeedforwardPidController(model, pid(), **kw),
        "FeedforwardPidController (default pid)": hysteron.FeedforwardPidController(model, **kw),
        "OpenLoopController": hysteron.OpenLoopController(model, pid(), **kw),
        "OpenLoopController (no pid)": hysteron.OpenLoopController(model, **kw),
        "CascadePwmController": hysteron.CascadePwmController(model, pid(), **kw),
        "CascadePwmController (default pid)": hysteron.CascadePwmController(model, **kw),
    }


def command_range(name, c):
    """(min, max) of the pressure commands [MPa] over 2 s at a reference of 1 m (far beyond the
    stroke; measured 0) then 2 s at -1 m (measured 0.1 m); the cascade's: its desired pressure.
    The measured pressure is the loop's own last command."""
    lo, hi, p = math.inf, -math.inf, 0.0
    for k in range(4000):
        r, y = (1.0, 0.0) if k < 2000 else (-1.0, 0.1)
        if name.startswith("InverseFeedforward"):
            u = c.step(r)
        elif name.startswith("FeedforwardPid"):
            u = c.step(r, r, y)
        elif name.startswith("OpenLoop"):
            u = c.step(r, r, y, p)
        else:
            c.step(r, r, y, p)
            u = c.desired_pressure
        p = u
        lo, hi = min(lo, u), max(hi, u)
    return lo, hi


@pytest.mark.parametrize("top", [0.4, 0.8])
def test_default_pressure_limits_are_the_models_input_limits(top):
    # rated 0.4 MPa: never above 0.4 (the default 0.6 commanded above the rating); rated 0.8: up to 0.8
    for name, c in controllers(gpi((0.0, top))).items():
        assert command_range(name, c) == (0.0, top), name
        assert c.pressure_limits == (0.0, top), name


def test_a_fitted_models_training_range_bounds_the_commands():
    truth = hysteron.Model(gpi((0.0, 0.4)))
    k = np.arange(401)
    x = np.concatenate([a * (1.0 - np.abs(2.0 * k / 400.0 - 1.0)) for a in (0.4, 0.3, 0.2, 0.1)])
    y = truth.simulate(x)
    fit = hysteron.fit(x, y, model="pi", num_operators=8)
    assert fit["status"] not in ("invalid_input", "failed")
    assert fit["model"]["input_limits"] == [0.0, 0.4]  # the record's range
    for name, c in controllers(fit["model"]).items():
        assert command_range(name, c) == (0.0, 0.4), name


def test_a_model_without_input_limits_needs_pressure_limits():
    for limits in (None, (0.0, None)):
        model = gpi(limits)
        for make in (lambda: hysteron.InverseFeedforward(model),
                     lambda: hysteron.FeedforwardPidController(model),
                     lambda: hysteron.FeedforwardPidController(model, pid()),
                     lambda: hysteron.OpenLoopController(model),
                     lambda: hysteron.CascadePwmController(model)):
            with pytest.raises(hysteron.Error, match="pressure_limits must be given"):
                make()
        for name, c in controllers(model, pressure_limits=(0.0, 0.5)).items():
            assert command_range(name, c) == (0.0, 0.5), name


def test_given_pressure_limits_win():
    model = gpi((0.0, 0.4))
    for given, expect in (((0.05, 0.5), (0.05, 0.5)),  # wider than the model's: the user's choice
                          ((0.0, 0.3), (0.0, 0.3)),
                          ((0.1, math.inf), (0.1, 0.4)),  # an infinite side: the model's
                          ((-math.inf, 0.3), (0.0, 0.3))):
        for name, c in controllers(model, pressure_limits=given).items():
            assert command_range(name, c) == expect, (name, given)
            assert c.pressure_limits == expect
    with pytest.raises(hysteron.Error, match="pressure_limits"):
        hysteron.InverseFeedforward(model, pressure_limits=(0.5, math.inf))  # lo >= the model's hi
    with pytest.raises(hysteron.Error, match="pressure_limits"):
        hysteron.FeedforwardPidController(model, pressure_limits=(math.nan, 0.4))
