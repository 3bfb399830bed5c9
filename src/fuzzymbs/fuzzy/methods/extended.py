"""The extended method: the reduced corners plus interior points of the named parameters.

For the parameters named ``nonmonotonic`` the general method's points ``P_j``:
at level j the full factorial of ``P_j`` for those parameters and
``{a^(j), b^(j)}`` for all others.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from fuzzymbs.errors import InvalidPlanError
from fuzzymbs.fuzzy.methods.base import option
from fuzzymbs.fuzzy.methods.level_scheme import LevelScheme

__all__ = ["Extended"]


@dataclass(frozen=True)
class Extended(LevelScheme):
    """The extended transformation method.

    Parameters
    ----------
    nonmonotonic : tuple of str
        Parameters that get the general method's interior points.
    """

    name = "extended"
    summary = "the reduced corners plus interior points of the nonmonotonic parameters"
    supports_influence = True
    has_corners = True
    guards_monotonicity = True

    nonmonotonic: tuple[str, ...] = option(
        (),
        "parameters that get interior points (a study: a list, or 'auto' for a screening)",
        must="a list of parameter names",
    )

    def checked(self, names: tuple[str, ...]) -> Extended:
        """The named parameters must exist; kept in the parameters' order, repeats dropped."""
        known, named = set(names), set(self.nonmonotonic)  # sets: linear in the parameters
        unknown = [name for name in self.nonmonotonic if name not in known]
        if unknown:
            raise InvalidPlanError(
                f"nonmonotonic names unknown parameters {unknown}; parameters: {list(names)}"
            )
        return replace(self, nonmonotonic=tuple(n for n in names if n in named))

    def describe(self) -> dict[str, list[str]]:
        return {"nonmonotonic": list(self.nonmonotonic)} if self.nonmonotonic else {}

    def interior_flags(self, names: tuple[str, ...]) -> list[bool]:
        named = set(self.nonmonotonic)
        return [name in named for name in names]
