"""Ceres logs through glog: importing hysteron silences it (python/src/module.cpp), so a fit
prints no glog line even with GLOG_v=10 in the environment, unless the user asks to keep glog
(HYSTERON_KEEP_GLOG=1): that case shows the check below does see glog lines when there are any."""
import os
import re
import subprocess
import sys

# glog's line format (MMDD or YYYYMMDD date) and its "logging before InitGoogleLogging" notice
GLOG_LINE = re.compile(r"^[IWEF]\d{4,8} [0-9:.]+ |InitGoogleLogging", re.MULTILINE)

SCRIPT = """
import numpy as np
import hysteron
x = np.concatenate([np.interp(np.linspace(0, 1, 300), [0, 0.5, 1], [0, a, 0])
                    for a in (0.6, 0.5, 0.4, 0.3, 0.2, 0.1)])
true = {"model": "gpi", "n": 10, "c": [60.0, 4.0, -0.5, 30.0], "q": 0.8, "rho": 0.4, "tau": 0.1, "alpha": 2.0}
y = hysteron.simulate_record(true, x)
r = hysteron.fit(x, y, model="gpi", train=(0, 1200))
print("status", r["status"])
"""


def run_fit(**extra_env):
    env = dict(os.environ)
    env.pop("HYSTERON_KEEP_GLOG", None)
    env.update(GLOG_v="10", **extra_env)
    return subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True, text=True, timeout=600)


def test_fit_prints_no_glog_lines_with_glog_v_10():
    p = run_fit()
    assert p.returncode == 0, p.stderr
    assert "status " in p.stdout
    lines = GLOG_LINE.findall(p.stderr)
    assert not lines, f"{len(lines)} glog line(s) on stderr:\n{p.stderr[:3000]}"


def test_keep_glog_opt_out_shows_the_lines():
    p = run_fit(HYSTERON_KEEP_GLOG="1")
    assert p.returncode == 0, p.stderr
    assert GLOG_LINE.search(p.stderr), "HYSTERON_KEEP_GLOG=1: expected Ceres' glog lines with GLOG_v=10"
