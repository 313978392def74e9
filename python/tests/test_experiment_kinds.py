"""The model kind of an experiment's compensated variants (run_experiment(model=...))."""
import os

import pytest

import hysteron


@pytest.mark.skipif(os.environ.get("HYSTERON_SKIP_SLOW") == "1", reason="slow")
def test_pinned_kind_is_used_and_reported_and_adaptive_is_skipped():
    r = hysteron.run_experiment("gpi-pid", learning_periods=0, model="bouc-wen")
    m = r["model"]
    assert m["choice"] == "bouc-wen" and m["kind"] == "bouc-wen"
    assert [c["kind"] for c in m["candidates"]] == ["bouc-wen"] and m["candidates"][0]["chosen"]
    assert "bouc-wen asked for" in m["reason"]
    assert r["summary"]["best_model"]["model"] == "bouc-wen"
    assert r["summary"]["best_model"]["parameters"]["model"] == "bouc-wen"
    assert "adaptive" not in [x["variant"] for x in r["runs"]]
    assert any(s.startswith("adaptive (sine) not run") and "bouc-wen" in s for s in r["messages"])
    assert "model of the compensated variants: bouc-wen" in r["table"]


def test_unknown_kind_is_an_error_naming_it():
    with pytest.raises(hysteron.Error, match="kpp"):
        hysteron.run_experiment("gpi-pid", learning_periods=0, model="kpp")
    with pytest.raises(hysteron.Error):
        hysteron.run_experiment("gpi-pid", learning_periods=0, model="automatic")


@pytest.mark.skipif(os.environ.get("HYSTERON_SKIP_SLOW") == "1", reason="slow")
def test_auto_lists_every_kind_and_chooses_the_least_validation_rms():
    r = hysteron.run_experiment("gpi-pid", learning_periods=0, adaptive=False)
    m = r["model"]
    assert m["choice"] == "auto"
    assert sorted(c["kind"] for c in m["candidates"]) == sorted(k for k in hysteron.fit_models if k != "auto")
    ok = [c for c in m["candidates"] if c["ok"]]
    best = min(ok, key=lambda c: c["validation"]["rms"])
    assert best["chosen"] and best["kind"] == m["kind"]
    assert sum(c["chosen"] for c in m["candidates"]) == 1
    assert all(c["fit_time_s"] >= 0 for c in m["candidates"])


def test_reference_beyond_the_rigs_reach_is_mapped_or_kept():
    # a 35 kg load cannot lift the paper's 95 mm top: mapped into the reach by default
    heavy = {"load": {"mass": 35.0}}
    r = hysteron.run_experiment("gpi-pid", plant=heavy, learning_periods=0, adaptive=False, model="mpi-asym")
    s = r["summary"]
    (ref,) = s["references"]
    assert ref["reference"] == "sine" and ref["scaled"] and ref["reachable"]
    assert ref["paper_max_mm"] == pytest.approx(95.0)
    assert ref["max_mm"] < s["reach"]["max_mm"] < 95.0
    assert any("mapped onto the rig's reach" in m for m in r["messages"])
    comp = next(x for x in r["runs"] if x["variant"] == "compensated")
    assert comp["reference_mm"].max() == pytest.approx(ref["max_mm"])
    # paper_references=True keeps the published one and says it is out of reach
    p = hysteron.run_experiment("gpi-pid", plant=heavy, learning_periods=0, adaptive=False, model="mpi-asym",
                                paper_references=True)
    (pref,) = p["summary"]["references"]
    assert not pref["scaled"] and not pref["reachable"]
    pcomp = next(x for x in p["runs"] if x["variant"] == "compensated")
    assert pcomp["reference_mm"].max() == pytest.approx(95.0)
    assert pcomp["rms_error_mm"] > comp["rms_error_mm"]


def test_gain_trial_choice_is_in_the_summary_and_used():
    # the compensated loop's PID gains are the relay's Ziegler-Nichols gains times the gain
    # trial's scale (docs/control.md, section 2): the least RMS on the trapezoid, shaped or not
    r = hysteron.run_experiment("gpi-pid", learning_periods=0, adaptive=False, model="mpi-asym")
    (g,) = r["summary"]["gain_trials"]
    assert g["reference"] == "sine"
    assert len(g["scales"]) == len(g["rms_mm"]) == 7
    assert g["scales"] == sorted(g["scales"])
    tried = [(rms, False, s) for s, rms in zip(g["scales"], g["rms_mm"])]
    tried += [(rms, True, s) for s, rms in zip(g["scales"], g["rms_shaped_mm"])]
    rms, shaped, scale = min(tried, key=lambda t: (t[0], t[1], t[2]))
    assert (g["scale"], g["shaped"]) == (scale, shaped)
    comp = next(x for x in r["runs"] if x["variant"] == "compensated")
    assert f"x{scale:.2f} by a gain trial" in comp["description"]
    assert ("zero-vibration shaper" in comp["description"]) == shaped
