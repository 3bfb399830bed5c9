"""Exception types raised by fuzzymbs.

Every error names the offending input and says what would be valid. All are
subclasses of :class:`ValueError` or :class:`TypeError` so that callers who do
not know fuzzymbs still catch them with the built-in types.
"""

from __future__ import annotations


class FuzzymbsError(Exception):
    """Base class of every error fuzzymbs raises on purpose."""


class InvalidFuzzyNumberError(FuzzymbsError, ValueError):
    """A fuzzy number's definition is inconsistent (bound order, NaN, spread < 0, ...)."""


class InvalidParameterError(FuzzymbsError, ValueError):
    """A physical or numerical parameter is out of its valid range or unknown."""


class InvalidPlanError(FuzzymbsError, ValueError):
    """A transformation-method plan was requested with invalid settings."""


class PlanTooLargeError(InvalidPlanError):
    """A plan needs more model runs (or level bookkeeping) than ``max_runs`` allows; nothing built.

    ``runs`` is its run count (an upper bound for the general method), ``max_runs``
    the limit, ``needed`` the smallest ``max_runs`` that would accept it.
    """

    def __init__(self, message: str, *, runs: int, max_runs: int, needed: int) -> None:
        super().__init__(message)
        self.runs = runs
        self.max_runs = max_runs
        self.needed = needed


class UnsupportedOperationError(FuzzymbsError, TypeError):
    """An operation is not defined for this method or object (e.g. influence of a grid plan)."""


class ModelOutputError(FuzzymbsError, ValueError):
    """A model returned outputs of the wrong shape, type or with non-finite values."""


class SimulationDivergedError(FuzzymbsError, ValueError):
    """A time integration blew up (NaN, inf, or a displacement beyond its bound)."""


class StudyFileError(FuzzymbsError, ValueError):
    """A study file is malformed: names the file, the key and what is allowed."""


class StoreMismatchError(FuzzymbsError, ValueError):
    """A result store belongs to a different study and cannot be resumed."""


class OutputFolderError(InvalidParameterError):
    """An output folder cannot be used: not creatable, not writable, or in use by another run."""


class ResultFileError(FuzzymbsError, ValueError):
    """A result file is unreadable or not a complete fuzzymbs result (names what is wrong)."""


class IncompleteResultError(FuzzymbsError, ValueError):
    """Samples failed, so some alpha levels cannot be bounded."""


class UntrustedCodeError(StudyFileError):
    """A study file names code (a module, an FMU, a program) its user has not allowed."""


class InverseProblemError(FuzzymbsError, ValueError):
    """An inverse fuzzy-arithmetic problem is ill-posed or its model fails (names the cause)."""


class InverseMismatchError(InverseProblemError):
    """The model cannot reproduce the measured uncertainty within the tolerance.

    ``result`` holds the best fit (an :class:`~fuzzymbs.fuzzy.inverse.InverseResult`
    with ``converged = False``) and its residual per output and level.
    """

    def __init__(self, message: str, result: object) -> None:
        super().__init__(message)
        self.result = result


def named(names: list[str], limit: int = 10) -> str:
    """``names`` for an error message: the first ``limit`` and how many more (a study
    file with thousands of wrong names gets a readable line, not all of them)."""
    shown = ", ".join(repr(name) for name in names[:limit])
    more = len(names) - limit
    return f"[{shown}, ... and {more:,} more]" if more > 0 else f"[{shown}]"
