"""What every transformation method is: its options, its capabilities, its builder, its count.

A method is a frozen dataclass whose fields are its options, declared once with
:func:`fuzzymbs.options.option` (type from the annotation, default, what a valid
value is, one line of help), as a study's own options are
(:class:`fuzzymbs.study.options.StudyOptions`). Its capabilities are class
attributes the rest of the package asks (``plan.scheme.supports_influence``)
instead of comparing method names. A fixed method builds a plan's samples
(:meth:`Method.build`, returning a :class:`Sampling`) and counts them from the
same sample sets (:meth:`Method.count`); a method that runs in rounds starts an
engine instead (:meth:`Method.start`). docs/architecture.md, "Adding a transformation method",
shows a new method's module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar, NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.numbers import FuzzyNumber
from fuzzymbs.options import Declared, OptionInfo, option

__all__ = [
    "CountRequest",
    "Method",
    "NumberShape",
    "OptionInfo",
    "Sampling",
    "option",
    "to_parameter_space",
]


class NumberShape(NamedTuple):
    """What the closed-form counts need of a fuzzy number: its support and core bounds and
    its modal value (two alpha-cuts, however many levels a plan has)."""

    support_lower: float
    support_upper: float
    core_lower: float
    core_upper: float
    modal: float

    @classmethod
    def of(cls, number: FuzzyNumber) -> NumberShape:
        """The shape of ``number``."""
        support = number.alpha_cut(0.0)
        core = number.alpha_cut(1.0)
        return cls(support[0], support[1], core[0], core[1], number.modal)

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


class CountRequest(NamedTuple):
    """What a method counts a plan's runs from, before anything is built.

    ``shapes`` serve the closed forms (cost linear in the parameters, whatever the
    levels); ``numbers`` and ``levels`` the exact counts from the builder's own
    value sets.
    """

    names: tuple[str, ...]
    shapes: list[NumberShape]
    numbers: tuple[FuzzyNumber, ...]
    levels: int | ArrayLike
    steps: int


@dataclass
class Sampling:
    """The samples a fixed method builds and their level bookkeeping (what a plan holds).

    Attributes
    ----------
    samples : ndarray, shape (N, n)
        Unique sample points (read-only).
    level_index : list of ndarray
        Per level, the sample indices of its points (generation order, repeats kept).
    nominal_index : int
        Row of the all-modal point.
    points_without_reuse : int
        Runs if every level were evaluated on its own.
    level_usage : ndarray, shape (L, N)
        Sample i is a point of level j (read-only).
    corner_index : ndarray (L, 2^n) or None
        Sample index of every cut-box corner (methods with ``has_corners``).
    extras : dict
        What else the method's retransformation reads (the sparse grid and its nodes).
    """

    samples: NDArray[np.float64]
    level_index: list[NDArray[np.intp]]
    nominal_index: int
    points_without_reuse: int
    level_usage: NDArray[np.bool_]
    corner_index: NDArray[np.intp] | None = None
    extras: dict[str, Any] = field(default_factory=dict)


def to_parameter_space(
    unit_points: ArrayLike, low: NDArray[np.float64], high: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Map points of the unit cube [0, 1]^n to the box [low, high] (0 and 1 exactly onto
    the bounds)."""
    unit = np.asarray(unit_points, dtype=float)
    return low * (1.0 - unit) + high * unit


@dataclass(frozen=True)
class Method(Declared):
    """A transformation method: options (the dataclass fields), capabilities, builder, count.

    Subclasses set :attr:`name`, :attr:`summary` and the capabilities they have, declare
    their options with :func:`option`, and implement :meth:`build` and :meth:`count` (or,
    running in rounds, :meth:`start` and :meth:`count` as the most it runs).

    Attributes
    ----------
    name : str
        The public name (``method = "..."`` in a study file).
    summary : str
        One line for ``fuzzymbs info``.
    supports_influence : bool
        Its results give influence measures (gain factors).
    supports_streaming : bool
        Its bounds accumulate chunk by chunk (else from every sample at once).
    supports_validation : bool
        A study checks it with validation runs (else it certifies itself).
    runs_in_rounds : bool
        Its points follow from the outputs of earlier rounds (no samples in advance).
    has_corners : bool
        Its plans hold every level's cut-box corners (corner bookkeeping).
    guards_monotonicity : bool
        Its bounds assume monotonic outputs: retransformation warns where they are not.
    interpolates : bool
        Its bounds are those of an interpolant, found by a search of every cut box.
    """

    invalid: ClassVar[type[Exception]] = InvalidPlanError  # a bad option: a bad plan
    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    supports_influence: ClassVar[bool] = False
    supports_streaming: ClassVar[bool] = True
    supports_validation: ClassVar[bool] = True
    runs_in_rounds: ClassVar[bool] = False
    has_corners: ClassVar[bool] = False
    guards_monotonicity: ClassVar[bool] = False
    interpolates: ClassVar[bool] = False

    def checked(self, names: tuple[str, ...]) -> Method:
        """This method with the options that depend on the parameters checked and their
        defaults filled in (unchanged by default).

        Raises
        ------
        InvalidPlanError
            An option that does not fit the parameters (names it and what would be valid).
        """
        return self

    def describe(self) -> dict[str, Any]:
        """What a plan's description (``Plan.to_dict``) records of the options."""
        return {}

    def check_bounds(self, count_parameters: int) -> None:
        """Refuse, before any run, a plan whose bounds could never be computed (none by
        default)."""

    # ------------------------------------------------------------------ work
    def count(self, request: CountRequest) -> tuple[int, bool]:
        """``(runs, exact)``: ``len(plan)`` from the builder's own sample sets, or, where
        ``exact`` is False, an upper bound (a method in rounds: its run budget)."""
        raise NotImplementedError

    def least_runs(self) -> int:
        """A lower bound of the runs, known without counting, where counting would cost too
        much (a plan over the limit is refused from it); 0 by default."""
        return 0

    def closed_form(self, request: CountRequest) -> int:
        """A cheap count from the numbers' shapes alone, never below :meth:`count` (what a
        refused plan's message suggests for other methods); by default :meth:`count`."""
        return self.count(request)[0]

    def build(
        self, parameters: dict[str, FuzzyNumber], cut_lower: NDArray, cut_upper: NDArray
    ) -> Sampling:
        """The samples and their bookkeeping of a fixed method."""
        raise NotImplementedError(f"method {self.name!r} runs in rounds: it builds no samples")

    def start(self, parameters: dict[str, FuzzyNumber], levels: NDArray[np.float64]) -> Any:
        """The engine of a method that runs in rounds (``next_batch`` / ``add`` / ``done``
        / ``outcome``)."""
        raise NotImplementedError(f"method {self.name!r} does not run in rounds")
