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

import math
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from fuzzymbs.errors import InvalidPlanError, PlanTooLargeError
from fuzzymbs.fuzzy.methods.base import CountRequest, Method, NumberShape
from fuzzymbs.fuzzy.methods.registry import method_named
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.fuzzy.plan_options import checked_parameters, make_levels

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


class _Request(NamedTuple):
    """A checked plan request: what :func:`run_count` and the refusals work on."""

    names: tuple[str, ...]
    shapes: list[NumberShape]
    method: Method
    steps: int
    numbers: tuple[FuzzyNumber, ...]
    levels: int | ArrayLike

    def _counting(self, steps: int | None) -> CountRequest:
        steps = self.steps if steps is None else steps
        levels = self.levels if steps == self.steps else steps
        return CountRequest(self.names, self.shapes, self.numbers, levels, steps)

    def count(self, method: str | None = None, steps: int | None = None, **options: Any) -> int:
        """The closed-form count of this or another method (alternatives in a refusal:
        cheap, from the numbers' shapes alone)."""
        scheme = self.method if method is None else method_named(method, **options)
        return scheme.checked(self.names).closed_form(self._counting(steps))

    def exact_count(self) -> tuple[int, bool]:
        """The plan's own count (:meth:`~fuzzymbs.fuzzy.methods.base.Method.count`, from the
        builder's own sample sets) and whether it is exact (else an upper bound)."""
        return self.method.count(self._counting(None))


def _request(
    parameters: Mapping[str, FuzzyNumber],
    method: str | Method,
    levels: int | ArrayLike,
    nonmonotonic: Iterable[str] | str | None = None,
    sparse_level: int | None = None,
    **options: Any,
) -> _Request:
    """Validate like :class:`~fuzzymbs.fuzzy.transform.Plan` (same errors), without building."""
    scheme = method_named(method, nonmonotonic=nonmonotonic, sparse_level=sparse_level, **options)
    numbers = checked_parameters(parameters)
    names = tuple(numbers)
    steps = _level_steps(levels)
    scheme = scheme.checked(names)
    shapes = [NumberShape.of(number) for number in numbers.values()]
    return _Request(names, shapes, scheme, steps, tuple(numbers.values()), levels)


def run_count(
    parameters: Mapping[str, FuzzyNumber],
    method: str | Method = "reduced",
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
        for ``"sparse"``); ``method`` a name or a method object
        (:mod:`fuzzymbs.fuzzy.methods`), whose :meth:`~fuzzymbs.fuzzy.methods.base.Method.count`
        this is.
    max_runs : int, optional
        The adaptive method's run budget (default 2,000, at least ``2 n + 2``); only
        for a method whose option it is (``method="adaptive"``), whose count it is.

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
    >>> three = {name: twelve[name] for name in ("p0", "p1", "p2")}
    >>> run_count(three, "adaptive", 4)  # its budget: the most it runs
    2000
    """
    if max_runs is not None:
        # a method whose own option max_runs is its run budget counts that budget
        request = _request(
            parameters, method, levels, nonmonotonic, sparse_level, max_runs=max_runs
        )
    else:
        request = _request(parameters, method, levels, nonmonotonic, sparse_level)
    return request.exact_count()[0]


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
    sparse_level = getattr(request.method, "sparse_level", None)
    options: list[tuple[str, int]] = []
    if steps != request.steps:
        label = {"sparse": f"'sparse' (sparse_level = {sparse_level})"}.get(
            request.method.name, f"{request.method.name!r}"
        )
        options.append((label, request.count(steps=steps)))
    if request.method.name != "reduced":
        options.append(("'reduced'", request.count("reduced", steps=steps)))
    if len(request.names) > 1 and not (
        request.method.name == "extended" and len(getattr(request.method, "nonmonotonic", ())) <= 1
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
    sparse_levels = [3] if request.method.name != "sparse" else []
    if request.method.name == "sparse" and sparse_level and sparse_level > 1:
        sparse_levels = [min(sparse_level - 1, 3)]
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
        f"the {method or repr(request.method.name)} method with {count} fuzzy "
        f"parameter{'s' if count != 1 else ''} and {_levels_text(levels, request.steps)}"
    )
    sparse_level = getattr(request.method, "sparse_level", None)
    if sparse_level is not None:
        what += f" (sparse_level = {sparse_level})"
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
    least = request.method.least_runs()
    if limit is not None and least > limit:  # refused without the count (too costly to make)
        _refuse(request, least, limit, _what(request, levels), "more than ")
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
