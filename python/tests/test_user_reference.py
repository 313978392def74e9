"""run_experiment(references=[SPEC, ...]): the user's own references tracked instead of the
paper's (as the CLI's --reference), named by their kind or name=; a bad spec is hysteron.Error
naming references and the key before anything runs or is written."""
import math

import numpy as np
import pytest

import hysteron

FAST = dict(seed=1, learning_periods=0, adaptive=False, model="gpi")


def test_a_user_triangle_is_tracked_instead_of_the_papers(tmp_path):
    r = hysteron.run_experiment("gpi-pid", references=["triangle:amplitude=15,offset=50,frequency=0.5,periods=2"],
                                out=str(tmp_path / "o"), **FAST)
    assert {run["reference"] for run in r["runs"]} == {"triangle"}
    by = {run["variant"]: run for run in r["runs"]}
    assert by["compensated"]["rms_error_mm"] < by["baseline"]["rms_error_mm"]
    ref = by["compensated"]["reference_mm"]
    assert abs(ref.max() - 65.0) < 1e-6 and abs(ref.min() - 35.0) < 1e-6
    for run in r["runs"]:
        assert math.isfinite(run["rms_error_mm"])
        p = run["pressure_command_mpa"]
        assert p.min() >= 0.0 and p.max() <= r["summary"]["pressure_limit_mpa"]
    assert (tmp_path / "o" / "tracking_compensated_triangle.csv").exists()
    assert r["published"]["triangle"] == {}  # no paper's figures for it


@pytest.mark.parametrize("refs, message", [
    (["sine:amplitude=10,offset=50,frequency=1,periods=2,phase=1"], "references 'sine:.*unknown key \"phase\""),
    (["sine:amplitude=10,offset=50,frequency=-1,periods=2"], "frequency = -1 Hz must be > 0"),
    (["sine:amplitude=10,offset=50,periods=2"], "missing key \"frequency\""),
    (["file:/nonexistent/r.csv"], "/nonexistent/r.csv"),
    ([3], r"references\[0\] must be a SPEC string"),
])
def test_a_bad_spec_is_an_error_and_writes_nothing(tmp_path, refs, message):
    out = tmp_path / "o"
    with pytest.raises(hysteron.Error, match=message):
        hysteron.run_experiment("gpi-pid", references=refs, out=str(out), **FAST)
    assert not out.exists()
