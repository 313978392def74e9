"""Every public function, method and property of the module has a docstring beyond pybind11's
signature line, and the stateful classes have a __repr__ that names their parameters
(issue 13, item 5). The experiment bindings (py_experiment.cpp) are checked by their own tests."""
import inspect

import hysteron

EXPERIMENT = {"experiment_names", "run_experiment", "run_sweep", "write_report", "plot", "plot_hysteresis_loops",
              "plot_identification_input", "plot_tracking", "plot_tracking_error", "plot_desired_vs_actual",
              "plot_fit_residuals", "sweep", "sweep_names"}


def _described(doc):
    """True if doc holds a sentence, not only pybind11's signature lines `name(args) -> type`."""
    if not doc:
        return False
    for line in doc.strip().splitlines():
        line = line.strip()
        if not line:
            continue
        is_signature = "(" in line and ")" in line and (" -> " in line or line.endswith(")")) and line[0].isalpha() \
            and line.split("(")[0].replace("_", "").replace(".", "").isalnum() and not line.endswith(".")
        if not is_signature and not line.startswith("Overloaded function"):
            return True
    return False


def _public():
    mod = hysteron._hysteron if hasattr(hysteron, "_hysteron") else hysteron
    for name in sorted(dir(mod)):
        if name.startswith("_") or name in EXPERIMENT:
            continue
        yield name, getattr(mod, name)


def test_every_public_function_method_and_property_has_a_docstring():
    missing = []
    for name, obj in _public():
        if inspect.isclass(obj):
            if not (obj.__doc__ or "").strip():
                missing.append(name)
            for attr, value in vars(obj).items():
                if attr.startswith("_"):
                    continue
                doc = value.__doc__ if isinstance(value, property) else getattr(value, "__doc__", None)
                if isinstance(value, property) or callable(value) or hasattr(value, "__func__"):
                    if not _described(doc):
                        missing.append(f"{name}.{attr}")
        elif callable(obj) and not _described(obj.__doc__):
            missing.append(name)
    assert missing == []


def test_the_signature_check_sees_a_missing_docstring():
    assert not _described("reset(self: hysteron._hysteron.Pid) -> None\n")
    assert _described("reset(self: hysteron._hysteron.Pid) -> None\n\nBack to the virgin state.\n")


def test_repr_names_the_parameters():
    pid = hysteron.Pid(kp=2.5, ki=0.5, out_min=-1.0, out_max=1.0, anti_windup="back_calculation")
    assert repr(pid) == ("Pid(kp=2.5, ki=0.5, kd=0, sample_time=0.001, out_min=-1, out_max=1, "
                         "anti_windup='back_calculation')")
    gpi = {"model": "gpi", "envelope": "tanh", "c": [1.2, 0.8, 0.1, 0.05], "q": 0.5, "n": 10, "rho": 0.3,
           "tau": 1.5, "alpha": 0.05}
    ff = hysteron.InverseFeedforward(gpi, pressure_limits=(0.0, 0.5), model_scale=1000.0)
    assert repr(ff) == ("InverseFeedforward(pressure_limits=(0, 0.5), model_scale=1000, lag_time_constant=0, "
                        "sample_time=0.001)")
    ctl = hysteron.FeedforwardPidController(gpi, pressure_limits=(0.0, 0.5))  # gpi has no input_limits
    assert repr(ctl).startswith("FeedforwardPidController(")
    pi = {"model": "pi", "q": 0.4, "r": [0.05, 0.1, 0.25], "p": [0.3, 0.2, 0.15]}  # q and 3 weights
    assert repr(hysteron.Rls(pi, lam=0.99)) == "Rls(model='pi', weights=4, lam=0.99)"
    rig = hysteron.PamRig(seed=7)
    assert repr(rig).startswith("PamRig(seed=7, dt=")
    assert repr(rig).endswith("time=0, ok=True)")
