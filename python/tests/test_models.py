import math

import numpy as np
import pytest

import hysteron

GPI = {"model": "gpi", "n": 10, "c": [1.0, 2.0, -0.6, 0.6], "q": 0.8, "rho": 0.4, "tau": 5.0,
       "alpha": 0.03, "input_limits": [0.0, 0.6]}


def triangle(amplitudes, n=200):
    x = []
    for a in amplitudes:
        x += list(np.linspace(0, a, n)) + list(np.linspace(a, 0, n))
    return np.array(x)


def test_gpi_matches_direct_evaluation():
    x = triangle([0.6, 0.4, 0.2])
    y = hysteron.Model(GPI).simulate(x)
    c = GPI["c"]
    yi = np.zeros(GPI["n"])
    r = GPI["alpha"] * np.arange(1, GPI["n"] + 1)
    p = GPI["rho"] * np.exp(-GPI["tau"] * r)
    ref = []
    for xk in x:
        g = c[0] * math.tanh(c[1] * xk + c[2]) + c[3]
        yi = np.maximum(g - r, np.minimum(g + r, yi))
        ref.append(GPI["q"] * g + p @ yi)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-13)


@pytest.mark.parametrize("spec", [
    GPI,
    {"model": "pi", "q": 0.5, "r": [0.05, 0.1, 0.2], "p": [0.3, 0.2, 0.1], "input_limits": [0, 0.6]},
    {"model": "mpi-deadzone", "q": 0.5, "r": [0.05, 0.1], "p": [0.3, 0.2], "g0": 1.0, "z": [0.2, -0.1],
     "g": [0.3, 0.2], "input_limits": [0, 0.6]},
    {"model": "mpi-asym", "q": 0.5, "r": [0.05, 0.1], "p": [0.3, 0.2],
     "ascending": {"envelope": "tanh", "c": [1, 2, -0.6, 0.6]},
     "descending": {"envelope": "affine", "c": [1.2, 0.0]}, "input_limits": [0, 0.6]},
])
def test_inverse_round_trip(spec):
    x = triangle([0.6, 0.5, 0.3, 0.45])
    model = hysteron.Model(spec)
    y = model.simulate(x)
    xr = hysteron.Inverse(spec).simulate(y)
    np.testing.assert_allclose(xr, x, rtol=0, atol=1e-12)


def test_inverse_saturates_at_limits():
    inv = hysteron.Inverse(GPI, limits=(0.0, 0.5))
    x = inv.simulate(np.array([0.0, 100.0, -100.0]))
    assert x[1] == 0.5 and x[2] == 0.0 and np.all(np.isfinite(x))
    assert inv.saturated


def test_bad_parameters_raise_with_key():
    bad = dict(GPI, tau=-1.0)
    with pytest.raises(hysteron.Error, match="tau"):
        hysteron.Model(bad)


def test_nan_input_rejected():
    with pytest.raises(hysteron.Error, match="sample 1"):
        hysteron.Model(GPI).simulate(np.array([0.1, np.nan]))


def test_model_dict_with_nan_is_hysteron_error():
    # Issue 13: NaN in a dict raised nlohmann's RuntimeError, not hysteron.Error.
    bad = dict(GPI, q=float("nan"))
    with pytest.raises(hysteron.Error, match="NaN or infinite"):
        hysteron.Model(bad)


def test_model_dict_accepts_numpy_scalars_and_arrays():
    # Issue 13: numpy integers in dicts were refused.
    spec = dict(GPI, n=np.int64(10), q=np.float64(0.8), c=np.array([1.0, 2.0, -0.6, 0.6]))
    x = np.linspace(0.0, 0.5, 50)
    np.testing.assert_array_equal(hysteron.Model(spec).simulate(x), hysteron.Model(GPI).simulate(x))
    with pytest.raises(hysteron.Error, match="cannot convert"):
        hysteron.Model(dict(GPI, q=object()))


def test_public_methods_have_docstrings_and_repr():
    # Issue 13: Inverse.simulate, Inverse.step, Model.save and Model.to_dict had none.
    # pybind11 writes the signature on the first line; a docstring follows after a blank line.
    for cls, names in ((hysteron.Model, ("step", "simulate", "reset", "save", "to_dict")),
                       (hysteron.Inverse, ("step", "simulate", "reset"))):
        for name in names:
            lines = [l for l in (getattr(cls, name).__doc__ or "").splitlines() if l.strip()]
            assert len(lines) >= 2, f"{cls.__name__}.{name} has no docstring: {lines}"
    assert repr(hysteron.Model(GPI)) == "<hysteron.Model gpi with 10 operators>"
    assert repr(hysteron.Inverse(GPI)).startswith("<hysteron.Inverse limits=(0")
