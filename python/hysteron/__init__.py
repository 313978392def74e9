"""hysteron: hysteresis models, exact inverses, identification and control of
pneumatic artificial muscles (and other hysteretic actuators).

>>> import hysteron, numpy as np
>>> m = hysteron.Model({"model": "gpi", "n": 10, "c": [1, 2, -0.6, 0.6], "q": 0.8,
...                     "rho": 0.4, "tau": 5, "alpha": 0.03})
>>> y = m.simulate(np.linspace(0, 0.6, 100))
"""
from ._hysteron import *  # noqa: F401,F403
from ._hysteron import Error, Inverse, Model  # noqa: F401

__all__ = [name for name in dir() if not name.startswith("_")]
