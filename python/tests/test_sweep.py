"""hysteron.run_sweep: the experiments over plant variants, as `hysteron sweep` (docs/plant.md)."""
import csv
import os

import pytest

import hysteron


def _rms(doc, variant):
    run = next(r for r in doc["runs"] if r["variant"] == variant)
    assert run["ok"], run
    return {(t["reference"], t["kind"]): t["rms_error_mm"] for t in run["tracking"]}


@pytest.mark.skipif(os.environ.get("HYSTERON_SKIP_SLOW") == "1", reason="slow")
def test_identified_on_the_base_rig_is_run_experiment_with_a_tracking_plant(tmp_path):
    """A variant's run with identify_on_base equals run_experiment identified on the base rig and
    tracking on the variant, to the last digit; by default the variant is identified on its own
    rig. The table and the page are written."""
    out, page = tmp_path / "sweep.csv", tmp_path / "sweep.html"
    kw = dict(vary=["load.damping=200"], learning_periods=0, model="gpi", jobs=2)
    changed = hysteron.run_sweep("gpi-pid", identify_on_base=True, out=str(out), report=str(page), **kw)
    own = hysteron.run_sweep(["gpi-pid"], **kw)
    assert changed["identify_on_base"] is True and own["identify_on_base"] is False
    assert changed["failures"] == 0
    assert [v["name"] for v in changed["variants"]] == ["nominal", "load.damping=200"]
    exp = hysteron.run_experiment("gpi-pid", learning_periods=0, model="gpi",
                                  tracking_plant={"load": {"damping": 200}})
    by_kind = {(r["reference"], r["variant"]): r["rms_error_mm"] for r in exp["runs"]}
    sweep = _rms(changed, "load.damping=200")
    assert sweep.keys() == by_kind.keys()
    for k, v in by_kind.items():
        assert sweep[k] == v, (k, sweep[k], v)
    assert sweep[("sine", "compensated")] != _rms(own, "load.damping=200")[("sine", "compensated")]
    assert _rms(changed, "nominal") == _rms(own, "nominal")
    assert "identified on the base rig" in changed["text"]
    rows = list(csv.DictReader(open(out)))
    assert {r["variant"] for r in rows} == {"nominal", "load.damping=200"}
    row = next(r for r in rows if r["variant"] == "load.damping=200" and r["kind"] == "compensated")
    assert float(row["rms_mm"]) == sweep[("sine", "compensated")]
    assert "<svg" in page.read_text() or "<table" in page.read_text()


def test_bad_input_raises_naming_it_and_writes_nothing(tmp_path):
    out = tmp_path / "t.csv"
    with pytest.raises(hysteron.Error, match="load.mas"):
        hysteron.run_sweep("gpi-pid", vary=["load.mas=10"], out=str(out))
    with pytest.raises(hysteron.Error, match="no variants"):
        hysteron.run_sweep("gpi-pid", out=str(out))
    with pytest.raises(hysteron.Error, match="unknown set"):
        hysteron.run_sweep("gpi-pid", set="worst", out=str(out))
    with pytest.raises(hysteron.Error, match="gpi-pd"):
        hysteron.run_sweep("gpi-pd", vary=["load.mass=35"], out=str(out))
    with pytest.raises(hysteron.Error, match="nmae"):
        hysteron.run_sweep("gpi-pid", grid={"variants": [{"nmae": "x", "set": {"load.mass": 35}}]}, out=str(out))
    assert not out.exists()
