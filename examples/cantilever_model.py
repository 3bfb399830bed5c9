"""A user model for study files: tip deflection of a cantilever (closed form).

Referenced from examples/cantilever.toml as ``"cantilever_model:make_cantilever"``;
run with the examples folder on the import path::

    PYTHONPATH=examples fuzzymbs run examples/cantilever.toml --out cantilever-out

Tip deflection under an end load (Euler-Bernoulli): delta = F L^3 / (3 E I).
"""

import numpy as np

from fuzzymbs.study.registry import ParameterInfo


class Cantilever:
    """Batched model: {force, length, youngs_modulus} -> {tip_deflection}.

    Parameters
    ----------
    second_moment : float
        Second moment of area I of the cross-section [m^4].
    """

    #: Declared parameters let a study check names and fill in defaults.
    parameters = {  # noqa: RUF012
        "force": ParameterInfo("N", "end load F", 100.0),
        "length": ParameterInfo("m", "beam length L", 1.0),
        "youngs_modulus": ParameterInfo("Pa", "Young's modulus E", 210e9),
    }
    outputs = {"tip_deflection": "m"}  # noqa: RUF012
    coords = {}  # noqa: RUF012 - scalar output

    def __init__(self, second_moment: float = 1e-8) -> None:
        if not second_moment > 0:
            raise ValueError(f"second_moment must be > 0 m^4, got {second_moment!r}")
        self.second_moment = float(second_moment)

    def __call__(self, samples):
        force = np.asarray(samples["force"], dtype=float)
        length = np.asarray(samples["length"], dtype=float)
        modulus = np.asarray(samples["youngs_modulus"], dtype=float)
        return {"tip_deflection": force * length**3 / (3.0 * modulus * self.second_moment)}


def make_cantilever(second_moment: float = 1e-8) -> Cantilever:
    """Factory named in the study file; options come from [model.options]."""
    return Cantilever(second_moment)
