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
