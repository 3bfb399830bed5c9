"""The rounds of an adaptive study, each a table of points run through the executor and store.

A study with ``method="adaptive"`` drives its
:class:`~fuzzymbs.fuzzy.transform.RoundsPlan` round by round: the plan
proposes the round's points, the study evaluates them chunk by chunk on its
executor into ``STORE/adaptive-<round>-<fingerprint>/`` (``...-gradients/`` for a round
run with the model's gradients; like the screening and
validation runs), and hands the outputs back. The points of round k follow
from the outputs of rounds 0..k-1 alone, so after an interruption (even
``kill -9``) a rerun replays the stored rounds, proposes the same points bit
for bit, finds their chunks, and evaluates only what is missing.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.errors import IncompleteResultError

__all__ = ["ROUND_FOLDER", "run_rounds"]

logger = logging.getLogger("fuzzymbs.study.study")

#: prefix of the store's sub-folders holding an adaptive round (``adaptive-<k>-<fingerprint>``)
ROUND_FOLDER = "adaptive"


def run_rounds(
    study: Any,
    settings: tuple[Any, int, bool, bool, dict[str, Any] | None],
    store: str | Path | None,
    wrt: Sequence[str] = (),
) -> tuple[dict[str, np.ndarray], int, int]:
    """Run the adaptive plan of ``study`` from its first round to its last.

    Parameters
    ----------
    study : the :class:`~fuzzymbs.study.study.Study` (its plan, model identity and
        ``run_table``).
    settings : executor, chunk size, resume, progress, code version (as the study's
        other extra runs take them).
    store : the study's store folder, or None.
    wrt : the fuzzy parameters (in the plan's order) the model's gradients are asked for
        with every round's outputs; empty: none (the model is called as ever).

    Returns
    -------
    ``(outputs of every run in round order, runs evaluated, runs reused from the store)``

    Raises
    ------
    IncompleteResultError
        A run failed: every run enters the surrogate, so the study stops there (its
        round's chunks are stored; a rerun resumes from them).
    """
    plan = study.plan
    plan.reset()
    pieces: dict[str, list[np.ndarray]] = {}
    evaluated = reused = 0
    round_number = 0
    while True:
        points = plan.next_batch()  # judges the last round's runs first
        if round_number > 0:
            logger.info(
                "study %s: certified error after round %d: %.3g of the cut width (tolerance %.3g)",
                study.name,
                round_number - 1,
                plan.engine.error,
                plan.engine.tolerance,
            )
        if len(points) == 0:
            break
        digest = hashlib.sha256(np.ascontiguousarray(points, dtype="<f8").tobytes()).hexdigest()
        identity = {
            "adaptive_round": round_number,
            "round_fingerprint": digest,
            "plan_fingerprint": plan.fingerprint(),
            **study.model_identity(),
        }
        if wrt:  # chunks with gradients apart from chunks without
            identity["gradients_wrt"] = list(wrt)
        # a round run with gradients has a folder of its own beside the same points' without
        name = f"{ROUND_FOLDER}-{round_number:03d}-{digest[:12]}" + ("-gradients" if wrt else "")
        folder = None if store is None else Path(store) / name
        outputs, failed, reasons, done, from_store, gradients = study.run_table(
            points,
            identity,
            folder,
            (f"round {round_number}", f"adaptive round {round_number}"),
            settings,
            wrt=wrt,
        )
        if failed.any():
            first = int(np.flatnonzero(failed)[0])
            where = ", ".join(
                f"{name}={value:.6g}" for name, value in zip(plan.names, points[first], strict=True)
            )
            raise IncompleteResultError(
                f"{int(failed.sum())} of {len(points)} runs of adaptive round {round_number} of "
                f"study {study.name!r} failed (first at {where}: "
                f"{reasons[first] or 'non-finite output'}); every run of the adaptive method "
                "enters its surrogate, so it cannot go on. Fix the model's failing runs or use "
                "a fixed method (e.g. 'general') with on_failure='partial'"
            )
        plan.add(points, outputs, gradients=gradients if wrt else None)
        for name, value in outputs.items():
            pieces.setdefault(name, []).append(value)
        check_ahead = getattr(study, "check_ahead", None)
        if plan.confirming and callable(check_ahead):
            # most likely the last round: the time-integration check's re-runs start on the
            # runs so far while the method judges them (kept; the check takes those it needs)
            check_ahead({name: np.concatenate(value) for name, value in pieces.items()})
        evaluated += done
        reused += from_store
        logger.info(
            "study %s: adaptive round %d, %d runs (%d from the store); %d runs so far",
            study.name,
            round_number,
            len(points),
            from_store,
            plan.engine.runs,
        )
        round_number += 1
    return {name: np.concatenate(value) for name, value in pieces.items()}, evaluated, reused
