"""How many model runs a plan needs, in closed form, and the limit every plan checks first.

A plan's size follows from the number of parameters n, the level steps m and
three facts per parameter read from its support and core (two alpha-cuts):
whether the core is one point, and whether the lower or upper branch is flat
(``a^(0) == a^(m)``: the cut bound is the same at every level, e.g.
``Triangular(1, 1, 2)``). :func:`run_count` turns them into the number of
unique sample points ``len(plan(...))`` without computing a single cut of the
intermediate levels or building any sample array; :func:`check_run_limit`
refuses a plan beyond ``max_runs`` with the counts of the cheaper methods.
Derivations: docs/theory.md, "Sampling schemes and their counts".

The closed forms treat two sample points as the same run only where the scheme
makes them equal by construction: the same cut bound (flat branches, the point
core), the core midpoint that is the all-modal value. Values that coincide by
accident of their numbers (the midpoints of a symmetric number in the general
method, cut bounds rounding to the same float) merge further, so for the
reduced, extended, general and grid methods ``run_count`` counts the distinct
points of the builder's own value sets
(:func:`~fuzzymbs.fuzzy.level_values.union_size`, linear in the parameters):
exactly ``len(plan(...))``. Only beyond ``_EXACT_CUTS`` parameters x levels does
the closed form, an upper bound never below ``len(plan(...))``, stand in.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from fuzzymbs.errors import InvalidPlanError, PlanTooLargeError
from fuzzymbs.fuzzy.level_values import level_value_sets, union_size
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import METHODS, checked_parameters, make_levels, sparse_options
from fuzzymbs.fuzzy.sparse_grid import node_count, nodes_1d

__all__ = [
    "DEFAULT_MAX_RUNS",
    "LEVEL_TABLE_FACTOR",
    "check_run_limit",
    "check_screening_run_limit",
    "run_count",
    "screening_run_count",
]

#: default limit on the model runs of a plan (docs/fuzzy.md, "How many runs a plan may need")
DEFAULT_MAX_RUNS = 1_000_000
#: a plan's level bookkeeping (membership levels x runs) may hold this many entries per allowed run
LEVEL_TABLE_FACTOR = 10
#: level steps suggested when a plan is refused for its levels
SUGGESTED_LEVELS = 10
#: beyond this many level steps the refusal also suggests SUGGESTED_LEVELS
_MANY_LEVELS = 100
#: run counts above this cannot be run by any computer: no limit is suggested
_IMPRACTICAL_RUNS = 10**12
#: a refusal names the extended method's count with one non-monotonic parameter only for
#: plans of at most this many distinct fuzzy numbers (it takes one count per number)
_DISTINCT_SHAPES = 64
#: the modal point's search over the 1-D sparse nodes stops at this sparse level (2^20 nodes)
_MODAL_SEARCH_LEVEL = 20


class _Shape(NamedTuple):
    """What the counts need of one fuzzy number: cut bounds at mu = 0 and 1, and the modal value."""

    support_lower: float
    support_upper: float
    core_lower: float
    core_upper: float
    modal: float

    @property
    def point_core(self) -> bool:
        return self.core_lower == self.core_upper

    @property
    def flat_left(self) -> bool:
        return self.support_lower == self.core_lower

    @property
    def flat_right(self) -> bool:
        return self.support_upper == self.core_upper

    @property
    def crisp(self) -> bool:
        """A single value at every level (zero-width support)."""
        return self.point_core and self.flat_left and self.flat_right

    @property
    def core_size(self) -> int:
        """Distinct values of the core: 1 for a point core, else 2."""
        return 1 if self.point_core else 2

    @property
    def shared(self) -> int:
        """Values every level holds: the bound of a flat branch (both: 1 or 2 values)."""
        if self.flat_left and self.flat_right:
            return self.core_size
        return int(self.flat_left or self.flat_right)

    def bounds(self, steps: int) -> int:
        """Distinct cut bounds over all m + 1 levels (the grid's coordinates at level 0)."""
        lower = 1 if self.flat_left else steps + 1
        upper = 1 if self.flat_right else steps + 1
        return lower + upper - int(self.point_core)

    def modal_levels(self, general: bool) -> str:
        """Levels whose points hold the modal value: "all", "top" (m), "next" (m - 1) or "none"."""
        if self.point_core:  # the core point is a cut bound
            return "all" if self.flat_left or self.flat_right else "top"
        # the core midpoint is the general method's first inner point (level m - 1)
        return "next" if general else "none"


def _shape(number: FuzzyNumber) -> _Shape:
    support = number.alpha_cut(0.0)
    core = number.alpha_cut(1.0)
    return _Shape(support[0], support[1], core[0], core[1], number.modal)


def _level_steps(levels: int | ArrayLike) -> int:
    """m: the number of level steps, without building the levels of an int ``levels``."""
    if isinstance(levels, int | np.integer) and not isinstance(levels, bool):
        if levels < 1:
            raise InvalidPlanError(f"levels must be an int >= 1 (number of steps), got {levels!r}")
        return int(levels)

    return len(make_levels(levels)) - 1


def _levels_text(levels: int | ArrayLike, steps: int) -> str:
    if isinstance(levels, int | np.integer) and not isinstance(levels, bool):
        return f"levels = {steps}"
    return f"{steps + 1} membership levels"


def _power_product_sum(steps: int, p: int, q: int) -> int:
    """``sum_(k=1)^m (k + 1)^p (k + 2)^q``, exactly, in O((p + q)^2) operations.

    The partial sum is a polynomial of degree ``d = p + q + 1`` in m; Newton's
    forward-difference formula ``S(m) = sum_t Delta^t S(0) binom(m, t)`` extends
    it from ``S(0..d)``.
    """
    degree = p + q + 1
    partial = [0]
    for k in range(1, min(steps, degree) + 1):
        partial.append(partial[-1] + (k + 1) ** p * (k + 2) ** q)
    if steps <= degree:
        return partial[steps]
    total = 0
    differences = partial
    for t in range(degree + 1):
        total += differences[0] * math.comb(steps, t)
        differences = [b - a for a, b in itertools.pairwise(differences)]
    return total


def _modal_is_level_point(kinds: Iterable[str]) -> bool:
    """Whether the all-modal point is one of the points of some level."""
    found = set(kinds)
    if "none" in found:
        return False
    return len(found - {"all"}) <= 1  # "top" and "next" name different levels


def _product(values: Iterable[int]) -> int:
    return math.prod(values, start=1)


def _level_scheme_count(shapes: list[_Shape], interior: list[bool], steps: int) -> int:
    """Runs of the reduced, extended and general schemes.

    Level j = m - k evaluates the product of per-parameter value sets: the two
    bounds ``{a^(j), b^(j)}`` (one at a point core or a crisp value), or the
    general method's ``P_j`` with ``k + 1`` or ``k + 2`` values (point or
    interval core; a crisp value: one). A value is either held by one level only
    or, the bound of a flat branch, by all, so the union of the levels is
    ``sum_j |X_j| - m H`` with ``H = prod_i shared_i`` points common to every
    level; the all-modal point adds one run unless it is a level's point.
    """
    corner = [s for s, inner in zip(shapes, interior, strict=True) if not inner]
    general = [s for s, inner in zip(shapes, interior, strict=True) if inner]
    top = _product(s.core_size for s in shapes)  # level m: the core values (P_m = core)
    corners_below = _product(1 if s.crisp else 2 for s in corner)
    points = sum(1 for s in general if not s.crisp and s.point_core)
    intervals = sum(1 for s in general if not s.crisp and not s.point_core)
    below = corners_below * _power_product_sum(steps, points, intervals)
    common = _product(s.shared for s in shapes)
    kinds = [s.modal_levels(inner) for s, inner in zip(shapes, interior, strict=True)]
    return top + below - steps * common + (0 if _modal_is_level_point(kinds) else 1)


def _grid_count(shapes: list[_Shape], steps: int) -> int:
    """Runs of the grid: level j's bounds are a subset of level 0's, so the union is level 0."""
    modal_extra = any(not s.point_core for s in shapes)  # a core midpoint is no cut bound
    return _product(s.bounds(steps) for s in shapes) + int(modal_extra)


def _sparse_count(shapes: list[_Shape], level: int) -> tuple[int, bool]:
    """Runs of a sparse plan: Smolyak nodes mapped to the support box, plus the modal point.

    A crisp parameter whose support maps every 1-D node onto its value drops
    out of the grid (the nodes project onto a grid of the same level in the
    other parameters). The modal point is a node when every parameter's modal
    value is a mapped 1-D node of level ``l_i`` and ``sum (l_i - 1) <= level``.
    Vectorised over the parameters: linear in n.

    Returns
    -------
    count : int
    exact : bool
        False where a support so narrow that two of its mapped 1-D nodes round to
        the same float (but not all of them) merges nodes: then an upper bound.
    """
    searched = level <= _MODAL_SEARCH_LEVEL
    if searched:
        unit, first_level = nodes_1d(level)
    else:  # only the midpoint is looked at: an upper bound if the modal point is another node
        unit, first_level = np.array([0.5]), np.array([1])
    table = np.array([(s.support_lower, s.support_upper, s.modal, s.crisp) for s in shapes])
    low, high, modal, crisp = table[:, 0:1], table[:, 1:2], table[:, 2:3], table[:, 3] > 0
    # the same arithmetic as Plan.to_parameter_space
    mapped = low * (1.0 - unit) + high * unit
    collapsed = crisp & np.all(mapped == modal, axis=1) if searched else np.zeros(len(shapes), bool)
    dimension = int(np.count_nonzero(~collapsed))
    hits = mapped == modal
    has_hit = hits.any(axis=1)
    first_hit = np.where(hits, first_level[None, :], np.iinfo(np.int64).max).min(axis=1)
    kept = ~collapsed
    modal_is_node = bool(np.all(has_hit[kept])) and int((first_hit[kept] - 1).sum()) <= level
    exact = True
    if searched and len(unit) > 1:
        ordered = np.sort(mapped[kept], axis=1)
        exact = bool(np.all(ordered[:, 1:] != ordered[:, :-1]))
    return node_count(dimension, level) + (0 if modal_is_node else 1), exact


#: exact counts of the level schemes build each parameter's value sets: at most this
#: many cuts (parameters x levels), and this many values over all parameters and levels
_EXACT_CUTS = 100_000
_EXACT_VALUES = 2_000_000


def _count(
    shapes: list[_Shape],
    names: tuple[str, ...],
    method: str,
    steps: int,
    nonmonotonic: tuple[str, ...],
    sparse_level: int | None,
) -> tuple[int, bool]:
    """The closed-form count and whether it is exact (else an upper bound)."""
    if method == "sparse":
        assert sparse_level is not None
        return _sparse_count(shapes, sparse_level)
    if method == "grid":
        return _grid_count(shapes, steps), False
    interior = [method == "general" or name in nonmonotonic for name in names]
    return _level_scheme_count(shapes, interior, steps), False


def _exact_level_count(
    numbers: tuple[FuzzyNumber, ...],
    levels: int | ArrayLike,
    method: str,
    interior: list[bool],
    steps: int,
) -> int | None:
    """``len(plan(...))`` of a level scheme from the builder's own value sets, or None when
    computing them would cost more than :data:`_EXACT_CUTS` / :data:`_EXACT_VALUES`."""
    count_levels = steps + 1
    per_level = steps + 2 if any(interior) or method == "grid" else 2
    if (
        len(numbers) * count_levels > _EXACT_CUTS
        or len(numbers) * count_levels * per_level > _EXACT_VALUES
    ):
        return None
    mu = make_levels(levels)
    cuts = np.stack([number.cuts(mu) for number in numbers], axis=1)
    values = level_value_sets(cuts[:, :, 0], cuts[:, :, 1], method, interior)
    return union_size(values, [number.modal for number in numbers])


class _Request(NamedTuple):
    """A checked plan request: what :func:`run_count` and the refusals work on."""

    names: tuple[str, ...]
    shapes: list[_Shape]
    method: str
    steps: int
    nonmonotonic: tuple[str, ...]
    sparse_level: int | None
    numbers: tuple[FuzzyNumber, ...]
    levels: int | ArrayLike

    def count(self, method: str | None = None, **changes: Any) -> int:
        """The closed-form count of this or another method (alternatives in a refusal)."""
        method = method or self.method
        return _count(
            self.shapes,
            self.names,
            method,
            changes.get("steps", self.steps),
            changes.get("nonmonotonic", self.nonmonotonic if method == "extended" else ()),
            changes.get("sparse_level", self.sparse_level if method == "sparse" else None),
        )[0]

    def exact_count(self) -> tuple[int, bool]:
        """The plan's own count and whether it is exact (else an upper bound).

        The level schemes count the distinct points of the builder's value sets
        (:func:`~fuzzymbs.fuzzy.level_values.union_size`), where the closed form
        would miss points that coincide by accident of the numbers (the general
        method's midpoints of symmetric numbers); for absurdly many levels the
        closed form, an upper bound, stands in.
        """
        count, exact = _count(
            self.shapes,
            self.names,
            self.method,
            self.steps,
            self.nonmonotonic,
            self.sparse_level,
        )
        if exact or self.method == "sparse":
            return count, exact
        interior = [self.method == "general" or name in self.nonmonotonic for name in self.names]
        found = _exact_level_count(self.numbers, self.levels, self.method, interior, self.steps)
        return (count, False) if found is None else (found, True)


def _request(
    parameters: Mapping[str, FuzzyNumber],
    method: str,
    levels: int | ArrayLike,
    nonmonotonic: Iterable[str] | str | None,
    sparse_level: int | None,
) -> _Request:
    """Validate like :class:`~fuzzymbs.fuzzy.transform.Plan` (same errors), without building."""

    if not isinstance(method, str) or method not in METHODS:
        raise InvalidPlanError(f"unknown method {method!r}; valid methods: {list(METHODS)}")
    numbers = checked_parameters(parameters)
    names = tuple(numbers)
    steps = _level_steps(levels)
    if nonmonotonic is None:
        nonmonotonic = ()
    if isinstance(nonmonotonic, str):
        nonmonotonic = (nonmonotonic,)
    named = tuple(nonmonotonic)
    unknown = [name for name in named if name not in numbers]
    if unknown:
        raise InvalidPlanError(
            f"nonmonotonic names unknown parameters {unknown}; parameters: {list(names)}"
        )
    if named and method != "extended":
        raise InvalidPlanError(
            f"nonmonotonic={list(named)} is only used by method='extended', not {method!r}"
        )
    # the sparse options exactly as a plan checks them (search_points only matters there)
    sparse_level, _ = sparse_options(method, len(names), sparse_level, None)
    shapes = [_shape(number) for number in numbers.values()]
    return _Request(
        names,
        shapes,
        method,
        steps,
        tuple(n for n in names if n in named),
        sparse_level,
        tuple(numbers.values()),
        levels,
    )


def run_count(
    parameters: Mapping[str, FuzzyNumber],
    method: str = "reduced",
    levels: int | ArrayLike = 4,
    nonmonotonic: Iterable[str] | str | None = None,
    sparse_level: int | None = None,
    *,
    max_runs: int | None = None,
) -> int:
    """Model runs of ``plan(parameters, method, levels, ...)``, before building it.

    No sample array is computed. The level schemes count the distinct points of
    the builder's value sets (each parameter's cuts at every level; linear in the
    parameters and levels); beyond 100,000 parameters x levels, and for the
    sparse method, closed forms that read each parameter's support and core only
    stand in, so absurd requests (``levels = 10**6``) cost microseconds. The
    closed forms, with n parameters, m level steps, p of them with a point core
    and q = n - p with an interval core (all branches sloped):

    - reduced: ``m 2^n + 2^q + [q > 0]``
    - extended (K named, k of them with a point core): ``2^(n-|K|) sum_(j=1)^m
      (j + 1)^k (j + 2)^(|K|-k) + 2^q + [q > 0]``
    - general: ``sum_(j=0)^m (j + 1)^p (j + 2)^q + [p > 0 and q > 0]``
    - grid: ``(2m + 1)^p (2m + 2)^q + [q > 0]``
    - sparse: the Smolyak node count ``[z^k] (1 - 2z^2)^n / ((1 - 2z)^n (1 - z))``
      for ``sparse_level = k``, plus 1 unless the modal point is a node
    - adaptive: no fixed count (the model's outputs decide its rounds); its run
      budget ``max_runs`` (default 2,000), the most it runs

    Flat branches and crisp values are counted too (docs/theory.md).

    Parameters
    ----------
    parameters, method, levels, nonmonotonic, sparse_level
        As for :func:`~fuzzymbs.fuzzy.transform.plan` (``sparse_level`` defaults to 3
        for ``"sparse"``).
    max_runs : int, optional
        The adaptive method's run budget (default 2,000, at least ``2 n + 2``); only
        for ``method="adaptive"``, whose count it is.

    Returns
    -------
    int
        ``len(plan(...))``, also where points coincide by accident of their
        numbers (symmetric numbers in the general method: their midpoints
        recur at lower levels and are run once). An upper bound only where the
        closed form stands in for absurdly many levels, or for a sparse
        support so narrow that two of its mapped nodes round to the same float.

    Raises
    ------
    InvalidPlanError
        The settings :func:`~fuzzymbs.fuzzy.transform.plan` refuses (unknown
        method, bad levels, misplaced options, parameters that are not fuzzy numbers).

    Examples
    --------
    >>> from fuzzymbs.fuzzy.numbers import Triangular
    >>> twelve = {f"p{i}": Triangular(i, i + 0.3, i + 1.0) for i in range(12)}
    >>> run_count(twelve, "reduced", 4)
    16385
    >>> run_count(twelve, "general", 4)
    261453379
    >>> run_count(twelve, "adaptive", 4)  # its budget: the most it runs
    2000
    """
    if method == "adaptive":
        return _adaptive_budget(parameters, levels, nonmonotonic, sparse_level, max_runs)
    if max_runs is not None:
        raise InvalidPlanError(
            f"run_count takes max_runs only for method='adaptive' (its run budget); the "
            f"{method!r} method's count follows from the parameters and levels"
        )
    request = _request(parameters, method, levels, nonmonotonic, sparse_level)
    return request.exact_count()[0]


def _adaptive_budget(
    parameters: Mapping[str, FuzzyNumber],
    levels: int | ArrayLike,
    nonmonotonic: Iterable[str] | str | None,
    sparse_level: int | None,
    max_runs: int | None,
) -> int:
    """The adaptive method's run budget, its inputs checked as its plan checks them."""
    from fuzzymbs.fuzzy.adaptive import (
        DEFAULT_ADAPTIVE_MAX_RUNS,
        DEFAULT_ADAPTIVE_TOLERANCE,
        check_adaptive_options,
    )

    numbers = checked_parameters(parameters)
    _level_steps(levels)
    if nonmonotonic:
        raise InvalidPlanError(
            f"nonmonotonic={list(nonmonotonic)} is only used by method='extended', not 'adaptive'"
        )
    if sparse_level is not None:
        raise InvalidPlanError("sparse_level is only used by method='sparse', not 'adaptive'")
    budget = DEFAULT_ADAPTIVE_MAX_RUNS if max_runs is None else max_runs
    return check_adaptive_options(DEFAULT_ADAPTIVE_TOLERANCE, budget, len(numbers))[1]


def screening_run_count(parameters: Mapping[str, FuzzyNumber], levels: int | ArrayLike = 4) -> int:
    """Runs of :func:`~fuzzymbs.fuzzy.screening.screening_samples`, in closed form.

    ``1 + sum_i (c_i - 1)`` with ``c_i`` the distinct cut bounds of parameter i
    over all levels plus its modal value (``2m + 1`` for a triangle, ``2m + 3``
    for a trapezoid); exact under the same condition as :func:`run_count`.
    """
    request = _request(parameters, "reduced", levels, None, None)
    return 1 + sum(s.bounds(request.steps) + (0 if s.point_core else 1) - 1 for s in request.shapes)


def _checked_limit(max_runs: Any) -> int | None:
    if max_runs is None:
        return None
    if isinstance(max_runs, bool) or not isinstance(max_runs, int | np.integer) or max_runs < 1:
        raise InvalidPlanError(
            f"max_runs must be an int >= 1 (or None: no limit), got {max_runs!r}"
        )
    return int(max_runs)


def _approx(count: int) -> str:
    """``2.6e+08`` for any int, also beyond the float range (and Python's int-to-str limit)."""
    if count < 1000:
        return str(count)
    shift = max(count.bit_length() - 60, 0)
    log10 = math.log10(count >> shift) + shift * math.log10(2.0)
    exponent = math.floor(log10)
    mantissa = f"{10.0 ** (log10 - exponent):.1f}"
    if mantissa == "10.0":
        mantissa, exponent = "1.0", exponent + 1
    return f"{mantissa}e+{exponent:02d}"


def _runs_text(count: int) -> str:
    return f"{count:,}" if count < _IMPRACTICAL_RUNS else f"about {_approx(count)}"


def _alternatives(request: _Request, max_runs: int, fewer_levels: bool) -> str:
    """The run counts of cheaper choices for the same parameters (by the same closed forms)."""
    steps = SUGGESTED_LEVELS if fewer_levels else request.steps
    options: list[tuple[str, int]] = []
    if steps != request.steps:
        label = {"sparse": f"'sparse' (sparse_level = {request.sparse_level})"}.get(
            request.method, f"{request.method!r}"
        )
        options.append((label, request.count(steps=steps)))
    if request.method != "reduced":
        options.append(("'reduced'", request.count("reduced", steps=steps)))
    if len(request.names) > 1 and not (
        request.method == "extended" and len(request.nonmonotonic) <= 1
    ):
        # the count depends on the chosen parameter's shape only: one count per distinct
        # shape (each count is linear in the parameters; per name it would be quadratic)
        representatives = {
            shape: name for name, shape in zip(request.names, request.shapes, strict=True)
        }
        if len(representatives) <= _DISTINCT_SHAPES:
            worst = max(
                request.count("extended", steps=steps, nonmonotonic=(name,))
                for name in representatives.values()
            )
            options.append(("'extended' with one non-monotonic parameter", worst))
    sparse_levels = [3] if request.method != "sparse" else []
    if request.method == "sparse" and request.sparse_level and request.sparse_level > 1:
        sparse_levels = [min(request.sparse_level - 1, 3)]
    for level in sparse_levels:
        options.append(
            (f"'sparse' (sparse_level = {level})", request.count("sparse", sparse_level=level))
        )
    if not options:
        return ""
    where = (
        "the same parameters and levels"
        if steps == request.steps
        else f"the same parameters with levels = {steps}"
    )
    parts = [
        f"{label} {_runs_text(count)}{' (also over the limit)' if count > max_runs else ''}"
        for label, count in options
    ]
    return f" Runs for {where}: {', '.join(parts)}."


def _raise_limit_text(needed: int) -> str:
    if needed >= _IMPRACTICAL_RUNS:
        return " No limit makes this plan practical: use fewer parameters or levels."
    return (
        f" To run it anyway, raise the limit to {needed:,}: max_runs={needed} (plan or Study), "
        f"max_runs = {needed} under [study] in a study file, or fuzzymbs run --max-runs {needed}."
    )


def _refuse(
    request: _Request,
    runs: int,
    max_runs: int,
    what: str,
    runs_phrase: str,
) -> None:
    """Raise PlanTooLargeError if ``runs`` or the level bookkeeping exceed the limit."""
    levels = request.steps + 1
    table = levels * runs
    table_limit = LEVEL_TABLE_FACTOR * max_runs
    if runs <= max_runs and table <= table_limit:
        return
    needed = max(runs, -(-table // LEVEL_TABLE_FACTOR))
    if runs > max_runs:
        message = (
            f"{what} needs {runs_phrase}{_runs_text(runs)} model runs"
            f"{f' ({_approx(runs)})' if runs < _IMPRACTICAL_RUNS else ''}, more than "
            f"max_runs = {max_runs:,}."
        )
    else:
        message = (
            f"{what} needs {runs_phrase}{runs:,} model runs on {levels:,} membership levels: "
            f"its level bookkeeping (which runs serve which level, kept with the result) would "
            f"hold {_approx(table)} entries, more than {LEVEL_TABLE_FACTOR} x max_runs = "
            f"{_approx(table_limit)}."
        )
    fewer_levels = request.steps > _MANY_LEVELS or (
        runs <= max_runs and request.steps > SUGGESTED_LEVELS
    )
    message += _alternatives(request, max_runs, fewer_levels) + _raise_limit_text(needed)
    raise PlanTooLargeError(message, runs=runs, max_runs=max_runs, needed=needed)


def _what(request: _Request, levels: int | ArrayLike, method: str | None = None) -> str:
    count = len(request.names)
    what = (
        f"the {method or repr(request.method)} method with {count} fuzzy "
        f"parameter{'s' if count != 1 else ''} and {_levels_text(levels, request.steps)}"
    )
    if request.method == "sparse":
        what += f" (sparse_level = {request.sparse_level})"
    return what[0].upper() + what[1:]


def check_run_limit(
    parameters: Mapping[str, FuzzyNumber],
    method: str = "reduced",
    levels: int | ArrayLike = 4,
    nonmonotonic: Iterable[str] | str | None = None,
    sparse_level: int | None = None,
    *,
    max_runs: int | None = DEFAULT_MAX_RUNS,
) -> int:
    """The run count of a plan, after refusing a plan too large to build.

    Two limits, both checked from the closed forms of :func:`run_count` before
    anything is allocated:

    - the runs: at most ``max_runs``;
    - the level bookkeeping: ``(m + 1) x runs`` entries (which samples serve
      which level; kept with the result as ``level_usage``) at most
      ``LEVEL_TABLE_FACTOR x max_runs``. It refuses absurdly fine levels of a
      small plan (``levels = 100000``) and bounds the points a grid builds
      before merging (at most this many).

    Parameters
    ----------
    parameters, method, levels, nonmonotonic, sparse_level
        As for :func:`~fuzzymbs.fuzzy.transform.plan`.
    max_runs : int or None
        The limit (default :data:`DEFAULT_MAX_RUNS`); None: no limit.

    Returns
    -------
    int
        :func:`run_count` of the plan.

    Raises
    ------
    PlanTooLargeError
        Over a limit. The one-line message gives the count, the limit, the
        runs of the reduced, extended and sparse methods for the same parameters
        (and levels = 10 when more than 100 were asked for) and how to raise the
        limit; ``error.runs``, ``error.max_runs`` and ``error.needed`` hold the numbers.
    InvalidPlanError
        Invalid settings (as :func:`~fuzzymbs.fuzzy.transform.plan`), or a
        ``max_runs`` that is not an int >= 1 or None.
    """
    limit = _checked_limit(max_runs)
    request = _request(parameters, method, levels, nonmonotonic, sparse_level)
    if (
        limit is not None
        and request.method == "sparse"
        and request.sparse_level is not None
        and request.sparse_level > 60
        and limit < 2**60
    ):
        # the grid holds a 1-D axis of 2^level + 1 nodes: refuse without the exact count
        runs = 2**request.sparse_level + 1
        _refuse(request, runs, limit, _what(request, levels), "more than ")
    runs, exact = request.exact_count()
    if limit is not None:
        _refuse(request, runs, limit, _what(request, levels), "" if exact else "up to ")
    return runs


def check_screening_run_limit(
    parameters: Mapping[str, FuzzyNumber],
    levels: int | ArrayLike = 4,
    *,
    max_runs: int | None = DEFAULT_MAX_RUNS,
) -> int:
    """Refuse a ``nonmonotonic="auto"`` study whose screening and reduced corners exceed the limit.

    The extended plan is only known after the screening run, but it holds at
    least the reduced corners: ``screening_run_count + run_count(reduced)`` is
    checked as :func:`check_run_limit` checks a plan.

    Returns
    -------
    int
        The screening runs.
    """
    limit = _checked_limit(max_runs)
    screening = screening_run_count(parameters, levels)
    # the extended plan holds at least the reduced corners: the alternatives follow "reduced"
    request = _request(parameters, "reduced", levels, None, None)
    if limit is not None:
        corners = request.count()
        what = _what(request, levels, "'extended' (nonmonotonic = 'auto')")
        _refuse(
            request,
            screening + corners,
            limit,
            what
            + f" ({screening:,} screening runs, then at least the {corners:,} reduced corners)",
            "at least ",
        )
    return screening
