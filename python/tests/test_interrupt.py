"""Issue 13 item 5: long calls stop on Ctrl-C, and ranges that would never return are refused."""
import os
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

import hysteron


def test_run_pressure_period_must_be_whole_rig_steps():
    rig = hysteron.PamRig(seed=1)
    for bad in (1.5 * rig.dt, 0.0, -1e-3, float("nan"), 1e9):
        with pytest.raises(hysteron.Error, match="control_period"):
            rig.run_pressure(np.full(3, 0.2), control_period=bad)
    out = rig.run_pressure(np.full(3, 0.2), control_period=10 * rig.dt)
    assert len(out["t"]) == 3


def test_rls_fit_passes_range():
    x = np.linspace(0, 1, 200)
    model = {"model": "pi", "r": [0.0, 0.1], "p": [1.0, 0.5]}
    with pytest.raises(hysteron.Error, match="passes must be in 1..10000"):
        hysteron.rls_fit(model, x, x, passes=10**9)


def test_ctrl_c_stops_a_long_rig_run_within_a_second():
    # A child runs ~10^9 rig steps (hours); SIGINT must end it with KeyboardInterrupt.
    code = textwrap.dedent("""
        import sys, numpy as np, hysteron
        rig = hysteron.PamRig(seed=1)
        print("started", flush=True)
        try:
            rig.run_pressure(np.full(10, 0.2), control_period=rig.dt * 10**8)
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(0)
        sys.exit(3)
    """)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env)
    assert child.stdout.readline().strip() == "started"
    time.sleep(0.3)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    try:
        rc = child.wait(timeout=30)
    except subprocess.TimeoutExpired:
        child.kill()
        pytest.fail("run_pressure ignored SIGINT for 30 s")
    elapsed = time.monotonic() - sent
    assert rc == 0 and child.stdout.read().strip() == "interrupted"
    print(f"stopped {elapsed:.3f} s after SIGINT")


def test_ctrl_c_stops_a_long_sweep_and_writes_nothing(tmp_path):
    # ~100 runs (minutes on 2 cores); SIGINT must raise KeyboardInterrupt once the runs under
    # way end, and the table asked for must not be written.
    out = tmp_path / "sweep.csv"
    code = textwrap.dedent(f"""
        import sys, hysteron
        masses = ",".join(str(m) for m in range(10, 41))
        print("started", flush=True)
        try:
            hysteron.run_sweep("all", vary=["load.mass=" + masses], learning_periods=0, jobs=2,
                               out={str(out)!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
            sys.exit(0)
        sys.exit(3)
    """)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p)
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env)
    assert child.stdout.readline().strip() == "started"
    time.sleep(1.0)
    sent = time.monotonic()
    child.send_signal(signal.SIGINT)
    try:
        rc = child.wait(timeout=60)
    except subprocess.TimeoutExpired:
        child.kill()
        pytest.fail("run_sweep ignored SIGINT for 60 s")
    elapsed = time.monotonic() - sent
    assert rc == 0 and child.stdout.read().strip() == "interrupted"
    assert not out.exists()
    print(f"stopped {elapsed:.3f} s after SIGINT")
