"""Fixes from the third Python audit (session 24): each test fails without its fix."""
import json

import numpy as np
import pytest

import hysteron

GPI = {"model": "gpi", "n": 10, "c": [1.0, 2.0, -0.6, 0.6], "q": 0.8, "rho": 0.4, "tau": 5.0, "alpha": 0.03}


def decaying_sine(n=800):
    t = np.linspace(0, 4 * np.pi, n)
    return 0.3 + 0.3 * np.sin(t) * np.exp(-t / 20)


def test_rls_estimate_that_makes_no_valid_model_raises_naming_the_parameter():
    # The record's part along the envelope is negative: the RLS estimate of q is -0.8, which
    # a gpi refuses (q > 0, Eq. 6). rls_fit returned it as a model dict that Model() refused.
    x = decaying_sine()
    c = GPI["c"]
    y = hysteron.Model(GPI).simulate(x) - 1.6 * (c[0] * np.tanh(c[1] * x + c[2]) + c[3])
    with pytest.raises(hysteron.Error, match=r"rls: .*gpi: q must be > 0"):
        hysteron.rls_fit(GPI, x, y, 1.0, 2, "virgin")
    rls = hysteron.Rls(GPI)
    for a, b in zip(x, y):
        rls.step(a, b)
    assert rls.theta[0] < 0  # the weights are still there to read
    assert "Rls(model='gpi'" in repr(rls)
    with pytest.raises(hysteron.Error, match=r"q must be > 0"):
        rls.params()
    # a valid estimate is returned as before
    assert hysteron.rls_fit(GPI, x, hysteron.Model(GPI).simulate(x))["q"] == pytest.approx(0.8, rel=1e-6)


MPI_ASYM = {"model": "mpi-asym", "ascending": {"envelope": "tanh", "c": [1.0, 2.0, -0.6, 0.6]},
            "descending": {"envelope": "tanh", "c": [1.1, 2.0, -0.7, 0.55]}, "q": 0.5,
            "r": [0.03 * i for i in range(1, 9)], "p": [0.3, 0.2, 0.15, 0.1, 0.08, 0.06, 0.04, 0.02],
            "input_limits": [0.0, 0.6]}


def test_fit_weights_keeps_mpi_asym_invertible():
    # A record whose least-squares weights have p_3 = -0.1 (cumulative slopes all positive):
    # the bound on the cumulative slopes let it through and Inverse() refused the model.
    x = decaying_sine()
    truth = dict(MPI_ASYM, p=[0.3, 0.2, -0.1, 0.1, 0.08, 0.06, 0.04, 0.02])
    y = hysteron.Model(truth).simulate(x)
    fw = hysteron.fit_weights(MPI_ASYM, x, y, "virgin", None)
    assert fw["q"] > 0 and min(fw["p"]) >= 0
    inv = hysteron.Inverse(fw)
    yp = hysteron.Model(fw).simulate(x)
    assert np.max(np.abs(hysteron.Model(fw).simulate(inv.simulate(yp)) - yp)) < 1e-6
    # weights the bounds do not touch are recovered as before
    fit = hysteron.fit_weights(MPI_ASYM, x, hysteron.Model(MPI_ASYM).simulate(x), "virgin", None)
    assert np.allclose(fit["p"], MPI_ASYM["p"], atol=1e-6) and fit["q"] == pytest.approx(0.5, abs=1e-6)


def test_run_experiment_returns_the_baseline_model_that_replays_the_baseline_run(tmp_path):
    res = hysteron.run_experiment("gpi-pid", learning_periods=0, adaptive=False, model="gpi",
                                  out=str(tmp_path / "out"))
    with open(tmp_path / "out" / "result.json") as f:
        assert res["baseline_model"] == json.load(f)["baseline_model"]
    run = [r for r in res["runs"] if r["variant"] == "baseline"][0]
    loop = hysteron.controller_from(run["controller"], res["baseline_model"])
    ref = run["reference_mm"] * 1e-3
    pre = hysteron.feedforward_preview(run["controller"], ref)
    u = np.array([loop.step(ref[k], pre[k], run["measured_mm"][k] * 1e-3) for k in range(len(ref))])
    assert np.max(np.abs(u - run["pressure_command_mpa"])) < 1e-9


def test_evaluate_says_where_the_output_clips_and_the_cli_would_censor():
    x = decaying_sine()
    y = hysteron.Model(GPI).simulate(x)
    limit = np.percentile(y, 85)
    yc = np.minimum(y, limit)
    e = hysteron.evaluate(GPI, x, yc)
    n = hysteron.evaluate(GPI, x, yc, censored=True)["censored_samples"]
    assert n > 50
    assert "%d samples" % n in e["clipping_warning"] and "censored=True" in e["clipping_warning"]
    assert e["rms"] > 0 and "censored_samples" not in e  # scored as recorded, as documented
    assert hysteron.evaluate(GPI, x, y)["clipping_warning"] == ""
    assert hysteron.evaluate(GPI, x, yc, censored=True)["clipping_warning"] == ""


def test_fit_report_refuses_a_name_that_is_no_html_before_the_fit(tmp_path):
    # fit(report="fit.json") wrote HTML into a .json (the CLI's --report writes JSON there)
    x = decaying_sine()
    y = hysteron.Model(GPI).simulate(x)
    path = tmp_path / "fit.json"
    with pytest.raises(hysteron.Error, match=r"fit: report: .*fit\.json.* \.html or \.htm"):
        hysteron.fit(x, y, model="pi", num_starts=1, report=str(path))
    assert not path.exists()
    html = tmp_path / "fit.HTM"
    hysteron.fit(x, y, model="pi", num_starts=1, report=str(html))
    assert html.read_text().lstrip().lower().startswith("<!doctype html")


def test_unknown_pwm_and_guard_keys_raise_hysteron_error_with_the_closest_name():
    model = dict(GPI, input_limits=[0.0, 0.6])
    with pytest.raises(hysteron.Error, match=r"CascadePwmController: pwm: unknown key 'gian', did you mean 'gain'\?"):
        hysteron.CascadePwmController(model, pwm={"gian": 1.0})
    with pytest.raises(hysteron.Error, match=r"Pid: guard: unknown key 'perod', did you mean 'period'\?"):
        hysteron.Pid(kp=1.0, guard={"perod": 1.0})


def test_invalid_input_has_no_metrics():
    r = hysteron.fit([1.0, np.nan], [1.0, 2.0])
    assert r["status"] == "invalid_input" and r["train"] is None and r["reference"] is None


@pytest.mark.parametrize("kind", ["preisach", "kp"])
def test_fit_of_a_huge_input_returns_a_status_not_an_exception(kind):
    # preisach and kp fitted on an input of 1e200 refused it in their own simulation: fit raised
    x = decaying_sine()
    y = hysteron.Model(GPI).simulate(x)
    r = hysteron.fit(x * 1e200, y, model=kind, num_threads=1)
    assert r["status"] == "invalid_input" and not r["ok"]
    assert kind in r["message"] and "input bound" in r["message"] and "rescale" in r["message"]
    assert r["train"] is None and r["reference"] is None  # nothing fitted: no metrics, not zeros


def test_auto_goes_on_when_one_candidate_cannot_run_on_the_record():
    x = decaying_sine()
    y = hysteron.Model(GPI).simulate(x)
    r = hysteron.fit(x * 1e200, y, model="auto", num_threads=1)
    by_kind = {c["kind"]: c for c in r["candidates"]}
    assert by_kind["preisach"]["status"] == "invalid_input" and "input bound" in by_kind["preisach"]["message"]
    assert r["model_kind"] not in ("preisach", "kp") and r["status"] in ("converged", "poor_fit", "no_convergence")


def test_signals_refuse_a_sample_count_they_cannot_hold_with_a_clear_error():
    with pytest.raises(hysteron.Error, match=r"gpi_identification_pressure: 30 s at dt = 1e-09 s is 3e\+10 samples"):
        hysteron.gpi_identification_pressure(1e-9)
    with pytest.raises(hysteron.Error, match=r"gpi_sinusoid_reference: .*larger dt or a shorter duration"):
        hysteron.gpi_sinusoid_reference(1e-3, 1e12)
    assert len(hysteron.gpi_identification_pressure(1e-3)) == 30000


def test_a_non_finite_value_in_a_model_dict_is_named_by_its_key():
    """A model dict with an infinite input limit (or a NaN weight) names the key and says None is
    an unbounded side; before 2026-12-01 it said only 'a value is NaN or infinite'."""
    import numpy as np
    with pytest.raises(hysteron.Error, match=r"input_limits\[0\] = -inf is NaN or infinite.*None"):
        hysteron.Model({"model": "pi", "r": [0, 0.1], "p": [1, 0.5], "input_limits": [-np.inf, 600]})
    with pytest.raises(hysteron.Error, match=r"p\[1\] = nan"):
        hysteron.Model({"model": "pi", "r": [0, 0.1], "p": np.array([1, np.nan])})
