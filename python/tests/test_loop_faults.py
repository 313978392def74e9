"""The controllers on faulty sensors and their limit-cycle guard (audit s26 a3): faults, feedforward_faults,
pressure_faults, gain_scale, guard_cuts and restart_guard(); a NaN position reading keeps feeding forward, a
NaN pressure reading closes the cascade's valves."""
import math

import pytest

import hysteron

MODEL = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1,
         "alpha": 2.0, "input_limits": [0.0, 0.6]}
NAN = float("nan")


def guarded_pid():
    return hysteron.Pid(kp=5.0, ki=1.0, out_min=-0.6, out_max=0.6,
                        guard={"period": 0.02, "amplitude": 1e-3, "count": 2.0})


def controllers():
    return {
        "ff_pid": hysteron.FeedforwardPidController(MODEL, guarded_pid()),
        "open_loop": hysteron.OpenLoopController(MODEL, guarded_pid()),
        "cascade": hysteron.CascadePwmController(MODEL, guarded_pid()),
    }


def step(c, r, y, p=0.3, preview=None):
    pv = r if preview is None else preview
    return c.step(r, pv, y) if isinstance(c, hysteron.FeedforwardPidController) else c.step(r, pv, y, p)


def test_faults_count_the_samples_the_position_pid_held():
    for name, c in controllers().items():
        assert (c.faults, c.feedforward_faults, c.gain_scale, c.guard_cuts) == (0, 0, 1.0, 0), name
        for k in range(100):
            step(c, 0.03, 0.03)
        for k in range(7):
            step(c, 0.03, NAN)  # a position sensor out
        for k in range(3):
            step(c, NAN, 0.03, preview=0.03)  # a reference out
        step(c, 0.03, 0.03, preview=NAN)  # a preview out: the inverse's
        assert c.faults == 10, name
        assert c.feedforward_faults == 1, name
        c.reset()
        assert c.faults == 0 and c.feedforward_faults == 0, name
    cas = hysteron.CascadePwmController(MODEL)
    assert cas.pressure_faults == 0
    for p in (NAN, math.inf, -math.inf):
        assert cas.step(0.05, 0.05, 0.02, p) == 0.0  # valves closed on a pressure sensor out
    assert cas.pressure_faults == 3 and cas.faults == 0


def test_a_held_pid_keeps_feeding_forward():
    # no gains: the PID's correction is 0, the command the inverse's pressure, sensor or not
    ff = hysteron.InverseFeedforward(MODEL)
    c = hysteron.FeedforwardPidController(MODEL, hysteron.Pid(out_min=-0.6, out_max=0.6))
    for k in range(2000):
        r = 0.02 + 0.015 * math.sin(2 * math.pi * k / 1000)
        assert c.step(r, r, NAN if 500 <= k < 1500 else r) == ff.step(r), k
    assert c.faults == 1000


def test_cascade_holds_the_position_integral_while_the_pressure_is_out():
    c = hysteron.CascadePwmController(MODEL, hysteron.Pid(kp=5.0, ki=50.0, out_min=-0.6, out_max=0.6))
    for k in range(200):
        duty = c.step(0.04, 0.04, 0.02, 0.05)
    assert duty > 0.1
    p_d = c.desired_pressure
    for k in range(300):
        assert c.step(0.04, 0.04, 0.02, NAN) == 0.0
    assert c.desired_pressure == p_d  # feedforward and correction unchanged: no wind-up
    assert c.pressure_faults == 300 and c.faults == 0


def test_restart_guard_restores_the_tuned_gains():
    for name, c in controllers().items():
        for k in range(400):  # an error ringing at the guard's period
            step(c, 0.03, 0.03 + (0.01 if (k // 10) % 2 else -0.01))
        assert c.guard_cuts > 0 and c.gain_scale < 1.0, name
        c.restart_guard()
        assert c.gain_scale == 1.0 and c.guard_cuts == 0, name
        step(c, 0.03, 0.03)  # steps on
    pid = guarded_pid()
    for k in range(400):
        pid.step(0.0, 0.01 if (k // 10) % 2 else -0.01)
    assert pid.guard_cuts > 0
    integral = pid.integral
    pid.restart_guard()
    assert pid.gain_scale == 1.0 and pid.guard_cuts == 0 and pid.integral == integral
    assert pid.params["guard"]["period"] == 0.02  # kept


def test_the_properties_are_read_only():
    c = hysteron.FeedforwardPidController(MODEL)
    for attr in ("faults", "feedforward_faults", "gain_scale", "guard_cuts"):
        with pytest.raises(AttributeError):
            setattr(c, attr, 1)
