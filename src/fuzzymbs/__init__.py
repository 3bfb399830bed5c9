"""fuzzymbs: fuzzy-arithmetical uncertainty analysis of multibody contact models.

The data flow (see docs/ and the design notes)::

    fuzzy parameters --transform--> sample points --model (batched)--> outputs
                     --retransform--> fuzzy outputs + influence --> store / plots

Public names are imported lazily so that ``import fuzzymbs`` stays cheap and
the heavy stages (Numba kernels, scikit-fem) load only when used.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fuzzymbs._lazy import lazy_exports
from fuzzymbs.numba_cache import drop_stale_kernel_caches
from fuzzymbs.version import __version__

# before any kernel loads from Numba's cache: a kernel compiled against a helper that
# has changed since must be compiled again (fuzzymbs.numba_cache)
drop_stale_kernel_caches()

# public name -> module that defines it
_LAZY: dict[str, str] = {
    "FuzzyNumber": "fuzzymbs.fuzzy.numbers",
    "Triangular": "fuzzymbs.fuzzy.numbers",
    "Trapezoidal": "fuzzymbs.fuzzy.numbers",
    "Gaussian": "fuzzymbs.fuzzy.numbers",
    "PiecewiseLinear": "fuzzymbs.fuzzy.numbers",
    "plan": "fuzzymbs.fuzzy.transform",
    "Plan": "fuzzymbs.fuzzy.transform",
    "FuzzyResult": "fuzzymbs.fuzzy.retransform",
    "Influence": "fuzzymbs.fuzzy.influence",
    "inverse": "fuzzymbs.fuzzy.inverse",
    "InverseResult": "fuzzymbs.fuzzy.inverse",
    "Study": "fuzzymbs.study.study",
    "StudyOptions": "fuzzymbs.study.options",
    "StudyResult": "fuzzymbs.study.study",
    "Tolerance": "fuzzymbs.tolerance",
}

__all__ = [
    "FuzzyNumber",
    "FuzzyResult",
    "Gaussian",
    "Influence",
    "InverseResult",
    "PiecewiseLinear",
    "Plan",
    "Study",
    "StudyOptions",
    "StudyResult",
    "Tolerance",
    "Trapezoidal",
    "Triangular",
    "__version__",
    "inverse",
    "plan",
]

if TYPE_CHECKING:  # pragma: no cover - for static analysers only
    from fuzzymbs.fuzzy.influence import Influence
    from fuzzymbs.fuzzy.inverse import InverseResult, inverse
    from fuzzymbs.fuzzy.numbers import (
        FuzzyNumber,
        Gaussian,
        PiecewiseLinear,
        Trapezoidal,
        Triangular,
    )
    from fuzzymbs.fuzzy.retransform import FuzzyResult
    from fuzzymbs.fuzzy.transform import Plan, plan
    from fuzzymbs.study.options import StudyOptions
    from fuzzymbs.study.study import Study, StudyResult
    from fuzzymbs.tolerance import Tolerance


__getattr__, __dir__ = lazy_exports("fuzzymbs", globals(), _LAZY)
