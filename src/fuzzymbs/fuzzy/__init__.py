"""Fuzzy engine: fuzzy numbers, transformation methods, retransformation, influence.

The engine never imports a model: a model is any callable
``model({name: (B,) array}) -> {output: (B, ...) array}``.
"""

from fuzzymbs.fuzzy.influence import Influence
from fuzzymbs.fuzzy.methods import Method, method_named
from fuzzymbs.fuzzy.numbers import FuzzyNumber, Gaussian, PiecewiseLinear, Trapezoidal, Triangular
from fuzzymbs.fuzzy.retransform import FuzzyResult, NonMonotonicWarning
from fuzzymbs.fuzzy.screening import (
    Screening,
    ScreeningWarning,
    nonmonotonic_parameters,
    screening_samples,
)
from fuzzymbs.fuzzy.sparse_grid import SparseGrid, sparse_grid
from fuzzymbs.fuzzy.transform import DEFAULT_MAX_RUNS, METHODS, Plan, RoundsPlan, plan, run_count

__all__ = [
    "DEFAULT_MAX_RUNS",
    "METHODS",
    "FuzzyNumber",
    "FuzzyResult",
    "Gaussian",
    "Influence",
    "Method",
    "NonMonotonicWarning",
    "PiecewiseLinear",
    "Plan",
    "RoundsPlan",
    "Screening",
    "ScreeningWarning",
    "SparseGrid",
    "Trapezoidal",
    "Triangular",
    "method_named",
    "nonmonotonic_parameters",
    "plan",
    "run_count",
    "screening_samples",
    "sparse_grid",
]
