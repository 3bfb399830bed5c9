"""A study's own options, declared once: its checks of itself and its limits.

The transformation method holds its own options (:mod:`fuzzymbs.fuzzy.methods`);
what a study adds around the method's runs is held here, in the same pattern: a
frozen dataclass whose fields are declared with :func:`fuzzymbs.options.option`.
From this one declaration come the ``[study]`` keys of a study file
(:mod:`fuzzymbs.study.studyfile`), the keyword options of
:class:`~fuzzymbs.study.study.Study`, the check of every value (an
:class:`~fuzzymbs.errors.InvalidParameterError` naming the option) and the list
``fuzzymbs info`` prints::

    Study("brake", parameters, options=StudyOptions(validation_runs=0))
    Study("brake", parameters, validation_runs=0)      # the same
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy.plan_size import DEFAULT_MAX_RUNS
from fuzzymbs.fuzzy.screening import DEFAULT_RTOL
from fuzzymbs.options import Declared, option
from fuzzymbs.study.method_check import DEFAULT_METHOD_TOLERANCE

__all__ = ["StudyOptions"]


@dataclass(frozen=True)
class StudyOptions(Declared):
    """What a study checks of itself and how large it may get (beside its method's options).

    Attributes
    ----------
    screening_rtol : float or None
        With ``nonmonotonic="auto"``: reversals along a parameter's axis up to this
        fraction of an output element's range are ignored (:mod:`fuzzymbs.fuzzy.screening`).
    integration_tolerance : float
        The largest time-integration error accepted without a
        :class:`~fuzzymbs.study.integration_check.TimeIntegrationWarning`, as a fraction
        of the cut width: a time-integrated model re-runs the samples that give the cuts'
        bounds at its tolerance tightened (its :class:`~fuzzymbs.tolerance.Tolerance`'s
        ``tightening``; RK4: a divided step) and stores the bounds' largest deviation
        as ``time_integration_error`` (:mod:`fuzzymbs.study.integration_check`).
    integration_runs : int
        How many samples that check re-runs (the modal one and those that give the most
        bounds).
    choose_integration : bool
        With a model whose integrator tolerance scales (``scalable_tolerance``, e.g. the
        brake with ROS34PW2), a pilot (the corners of the innermost cut and the modal
        point) first tightens the model's tolerance so that the time-integration error
        is expected below ``integration_tolerance``
        (:func:`~fuzzymbs.study.integration_check.choose_tolerance`).
    shared_steps : bool
        With a model that offers ``share_steps`` and ``choose_integration``: every sample
        takes the modal sample's step sequence and the modal sample's error, measured
        against a tight reference run, is removed from every sample's outputs, so that
        the bands settle at a far looser tolerance (:mod:`fuzzymbs.mbs.shared_steps`).
    validation_runs : int or None
        Extra runs that check the method (:mod:`fuzzymbs.study.method_check`): points
        inside the cut boxes no run of the method covers, in four rounds, compared with
        the retransformed cuts (``method_error``, a lower bound). None: a fifth of the
        method's runs, at least 12 per fuzzy parameter; 0 turns the check off.
    method_tolerance : float or None
        The fixed methods: the largest method error (cut-width scale) without a
        :class:`~fuzzymbs.fuzzy.retransform.NonMonotonicWarning`. Method ``"adaptive"``:
        the certified error at which its rounds stop (given, it replaces the method
        object's own).
    widen_with_validation : bool
        Widen the cuts to the validation outputs (each point's level and the levels
        below); by default they are reported (``o_validation``), never merged silently.
    max_runs : int or None
        Refuse a plan needing more model runs than this before anything is built
        (:class:`~fuzzymbs.errors.PlanTooLargeError`, naming cheaper methods' runs); for
        method ``"adaptive"`` its run budget (this default: the method's own). None: no
        limit.
    """

    screening_rtol: float | None = option(
        None,
        'with nonmonotonic = "auto": reversals up to this fraction of an output\'s range '
        "are ignored",
        must="a finite number >= 0",
        minimum=0.0,
        inclusive=True,
        default_text=f"{DEFAULT_RTOL:g}",
    )
    integration_tolerance: float = option(
        0.01,
        "time-integrated models: the largest time-integration error without a warning, "
        "of the cut width",
        must="a positive number",
        minimum=0.0,
    )
    integration_runs: int = option(
        8,
        "samples the time-integration check re-runs at a tighter tolerance",
        must="a whole number >= 1",
        minimum=1,
    )
    choose_integration: bool = option(
        True,
        "a pilot chooses a scalable integrator tolerance for the cut widths",
        must="true or false",
    )
    shared_steps: bool = option(
        True,
        "with choose_integration: the samples take the modal sample's steps, its error removed",
        must="true or false",
    )
    validation_runs: int | None = option(
        None,
        "runs that check the method inside the cut boxes (0: no method check)",
        must="a whole number >= 0 (0: no method check)",
        minimum=0,
        default_text="a fifth of the method's runs, at least 12 per fuzzy parameter",
    )
    method_tolerance: float | None = option(
        None,
        "the largest method error without a warning, of the cut width (method adaptive: "
        "where its rounds stop)",
        must="a positive number",
        minimum=0.0,
        default_text=f"{DEFAULT_METHOD_TOLERANCE:g}; method adaptive: its own",
    )
    widen_with_validation: bool = option(
        False,
        "widen the cuts to the validation runs' outputs instead of reporting them",
        must="true or false",
    )
    max_runs: int | None = option(
        DEFAULT_MAX_RUNS,
        "refuse a plan of more model runs before it is built (method adaptive: its run "
        "budget, 2,000 at this default)",
        must="a whole number >= 1 (None: no limit)",
        minimum=1,
    )

    @classmethod
    def given(
        cls, options: StudyOptions | None = None, values: Mapping[str, Any] | None = None
    ) -> StudyOptions:
        """``options`` (default: all defaults) with the options in ``values`` replaced.

        Raises
        ------
        InvalidParameterError
            A name that is not a study option (naming the study options), or an invalid
            value (naming the option and what is valid).
        """
        base = cls() if options is None else options
        if not isinstance(base, cls):
            raise InvalidParameterError(f"options must be a {cls.__name__}, got {base!r}")
        values = dict(values or {})
        unknown = sorted(name for name in values if not cls.declares(name))
        if unknown:
            valid = ", ".join(item.name for item in cls.options())
            raise InvalidParameterError(
                f"unknown study option(s) {', '.join(map(repr, unknown))}; study options: {valid}"
            )
        return replace(base, **values) if values else base
