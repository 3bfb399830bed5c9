"""A study's model gradients: which ones it asks for, and gathering them from the chunks.

A model that can differentiate its outputs declares ``differentiable``, a tuple of
the parameter names it can differentiate with respect to, and accepts
``model(samples, wrt=names)``: it returns its usual outputs plus, under
:data:`~fuzzymbs.study.evaluation.GRADIENTS_KEY` (``"gradients"``), ``{output:
(B, *output_shape, len(wrt))}`` with the last axis in ``wrt`` order, in the
parameters' units. A study of a method that uses them (the adaptive method's
option ``gradients``) asks for the gradients with respect to its fuzzy parameters
(:func:`gradient_parameters`); every other study, and every model without
``differentiable``, calls the model as before.

Gradients are not free everywhere: a model may also declare ``gradient_cost``, the
CPU a run takes for each parameter differentiated, as a fraction of the run without
(the brake's forward sensitivities: about 0.72 with ROS34PW2, 0.40 with RODAS4,
docs/benchmarks.md, "Forward sensitivities"). Gradients pay where the runs they save,
``runs without / runs with``, exceed what a run with them costs. ``"auto"`` decides
before the runs, so it asks for gradients only where a run with them costs at most
:data:`AUTO_MAX_RUN_COST` times one without: the run cost at which the measured cases
take on average as much CPU with gradients as without. A model that declares no cost
is taken to give them for free (its own closed form).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError, ModelOutputError
from fuzzymbs.study.evaluation import ChunkResult, rows_in_order

__all__ = [
    "AUTO_MAX_RUN_COST",
    "assemble_gradients",
    "declared_differentiable",
    "gradient_parameters",
    "run_cost",
]

#: ``gradients = "auto"`` asks for a model's gradients only where a run with them costs at
#: most this many runs without (``1 + n gradient_cost``). The break-even is the harmonic
#: mean of the measured savings ``runs without / runs with`` (at that run cost the cases
#: take on average as much CPU with gradients as without): 2.13 on the nine closed-form
#: cases of docs/fuzzy.md (1.28 for ringing3 to 3.48 for bump3); with the brake's studies 1
#: and 2 (76 and 89 runs without; with gradients 71 or 100 and 187 or 277, measured paths
#: that hang on round-off: docs/benchmarks.md, "The brake's studies with gradients") 1.27
#: to 1.52. Within that range one model of the package only is decided by where the
#: threshold lies: the brake integrated by RODAS4 with one fuzzy parameter (1.40 runs, so
#: with its gradients at 1.4); the closed-form cases' gradients are free, the brake's
#: with ROS34PW2 cost 1.72 runs or more, a mechanism's 3 or more
AUTO_MAX_RUN_COST = 1.4


def declared_differentiable(model: Any, model_name: str) -> tuple[str, ...]:
    """The parameters ``model`` declares it can differentiate with respect to (its
    ``differentiable`` attribute; none when it has none).

    Raises
    ------
    InvalidParameterError
        ``differentiable`` is not a sequence of parameter names.
    """
    declared = getattr(model, "differentiable", None)
    if declared is None:
        return ()
    if isinstance(declared, str) or not isinstance(declared, Sequence):
        declared = None
    elif not all(isinstance(name, str) for name in declared):
        declared = None
    if declared is None:
        raise InvalidParameterError(
            f"model {model_name!r}: differentiable must be a tuple of parameter names, "
            f"got {getattr(model, 'differentiable', None)!r}"
        )
    return tuple(declared)


def gradient_parameters(
    model: Any, names: Sequence[str], setting: Any, model_name: str
) -> tuple[str, ...]:
    """The fuzzy parameters a study asks its model's gradients for (``wrt``), or none.

    Parameters
    ----------
    model : the study's model.
    names : its fuzzy parameters, in the plan's order.
    setting : {"auto", True, False}
        The method's option ``gradients``: ``"auto"`` asks where the model declares
        every fuzzy parameter differentiable and a run with their gradients costs at
        most :data:`AUTO_MAX_RUN_COST` runs without (:func:`run_cost`), ``True``
        always, ``False`` never.
    model_name : the model's name, for the message.

    Returns
    -------
    tuple of str
        ``names`` when the gradients are used, else ``()``.

    Raises
    ------
    InvalidParameterError
        ``setting`` is True and the model cannot differentiate with respect to some
        fuzzy parameters (naming them).
    """
    if setting is False:
        return ()
    declared = declared_differentiable(model, model_name)
    missing = [name for name in names if name not in declared]
    if not missing:
        if setting == "auto" and run_cost(model, len(names)) > AUTO_MAX_RUN_COST:
            return ()  # dearer than the runs they save (the brake's three: about 3.2)
        return tuple(names)
    if setting is True:
        can = f"only {', '.join(declared)}" if declared else "none (no differentiable attribute)"
        raise InvalidParameterError(
            f"gradients = true, but model {model_name!r} cannot differentiate its outputs with "
            f"respect to the fuzzy parameter(s) {', '.join(missing)} (it declares {can}); set "
            'gradients = "auto" to use them only where the model gives them all, or false'
        )
    return ()


def run_cost(model: Any, parameters: int) -> float:
    """What a run with the gradients for ``parameters`` parameters costs, in runs without:
    ``1 + parameters x model.gradient_cost`` (no ``gradient_cost``: 1, free gradients)."""
    cost = float(getattr(model, "gradient_cost", 0.0) or 0.0)
    return 1.0 + parameters * cost


def assemble_gradients(
    chunks: Sequence[ChunkResult], count: int, wrt: Sequence[str]
) -> dict[str, np.ndarray]:
    """Every output's gradients ``(count, *shape, len(wrt))`` in row order (NaN rows for
    failed samples) from a table's chunks.

    Raises
    ------
    ModelOutputError
        A chunk with successful runs holds no gradient of one of its outputs (a store
        written without them).
    """
    shapes: dict[str, tuple[int, ...]] = {}
    for chunk in chunks:
        if chunk.failed.all():
            continue
        for name in chunk.outputs:
            if name not in chunk.gradients:
                raise ModelOutputError(
                    f"samples {chunk.start} to {chunk.stop - 1} have no gradient of output "
                    f"{name!r} with respect to {list(wrt)}; the model (or the stored chunk) "
                    "did not return it"
                )
            shapes.setdefault(name, chunk.gradients[name].shape[1:])
    return rows_in_order(chunks, count, shapes, lambda chunk: chunk.gradients)
