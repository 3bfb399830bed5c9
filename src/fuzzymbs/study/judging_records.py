"""The outcomes of a study's judging runs, kept in its store so that a rerun makes them once.

A time-integrated study runs more than its plan: a pilot, with the reference and logging
runs of shared steps, chooses its integrator tolerance
(:func:`~fuzzymbs.study.integration_check.choose_tolerance`), and its time-integration
check re-runs the samples that give the bounds
(:func:`~fuzzymbs.study.integration_check.check_time_integration`); on the brake's study
1 they take a third of its CPU. Their outcomes are small records (a
:class:`~fuzzymbs.study.integration_check.ToleranceChoice`, an
:class:`~fuzzymbs.study.integration_check.IntegrationCheck`), written to
``STORE/judging/`` once made, each under a digest of everything it follows from: the
study's identity (plan fingerprint, model, options), the code version, the options the
runs read and, for the check, the samples it re-runs. A study that resumes from the store
takes them instead of the runs, and the model a stored choice took is built only when a
run is missing (:class:`DeferredModel`): a finished study run again makes no run at all,
and an interrupted one makes no pilot again. The chunks of the plan's runs are the
store's (:mod:`fuzzymbs.study.store`); these records only spare the runs that judge them.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
import tempfile
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fuzzymbs.study.integration_check import IntegrationCheck, ToleranceChoice, chosen_model
from fuzzymbs.study.store import json_safe

__all__ = ["CHECK", "CHOICE", "DeferredModel", "JudgingRecords"]

logger = logging.getLogger(__name__)

#: sub-folder of the store that holds the records
FOLDER = "judging"
#: the kinds of record: the integrator tolerance's choice, the time-integration check
CHOICE, CHECK = "integration-choice", "integration-check"
_FORMAT = "fuzzymbs-judging-record"
_KINDS = {CHOICE: ToleranceChoice, CHECK: IntegrationCheck}


class JudgingRecords:
    """The judging records of one study run in its store (none without a store).

    Parameters
    ----------
    store : the study's store folder, or None (nothing is kept).
    resume : take the records found (False: make every run again and write them anew,
        as ``resume=False`` does with the chunks).
    code : the code version the store records (:func:`fuzzymbs.study.code_version`):
        records of other code are never taken.
    """

    def __init__(self, store: str | Path | None, resume: bool, code: Mapping[str, Any]) -> None:
        self.folder = None if store is None else Path(store) / FOLDER
        self.resume = resume
        self.code = dict(code)
        #: the kinds of record taken from the store (a result's provenance lists them)
        self.taken: set[str] = set()

    def _path(self, kind: str, description: Mapping[str, Any]) -> Path:
        assert self.folder is not None
        key = {"kind": kind, "code": self.code, **description}
        text = json.dumps(json_safe(key), sort_keys=True, allow_nan=False)
        return self.folder / f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:32]}.json"

    def load(self, kind: str, description: Mapping[str, Any]) -> tuple[Any, dict] | None:
        """The record of ``kind`` made under ``description``, and its extras; None if there
        is none (or it cannot be read: then the runs are made again, with a warning)."""
        if self.folder is None or not self.resume:
            return None
        path = self._path(kind, description)
        if not path.exists():
            return None
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("format") != _FORMAT or data.get("kind") != kind:
                raise ValueError("not a judging record of this kind")
            cls = _KINDS[kind]
            fields = data["record"]
            if cls is ToleranceChoice:
                fields = {**fields, "recipe": tuple(float(f) for f in fields["recipe"])}
            record = cls(**fields)
        except (OSError, ValueError, KeyError, TypeError) as error:
            logger.warning("judging record %s unreadable (%s): made again", path, error)
            return None
        self.taken.add(kind)
        return record, dict(data.get("extras", {}))

    def save(
        self,
        kind: str,
        description: Mapping[str, Any],
        record: ToleranceChoice | IntegrationCheck,
        extras: Mapping[str, Any] | None = None,
    ) -> None:
        """Write ``record`` (and JSON ``extras``) atomically; a store that cannot be written
        only loses the record (the study's result does not depend on it)."""
        if self.folder is None:
            return
        data = {
            "format": _FORMAT,
            "kind": kind,
            "record": dataclasses.asdict(record),
            "extras": dict(extras or {}),
        }
        path = self._path(kind, description)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            handle, temporary = tempfile.mkstemp(dir=self.folder, prefix=".tmp-", suffix=".json")
            with os.fdopen(handle, "w", encoding="utf-8") as file:
                json.dump(data, file)  # NaN as JSON's NaN literal, read back by json.loads
            os.replace(temporary, path)
        except OSError as error:
            logger.warning("judging record %s not written (%s)", path, error)


def _same(model: Any) -> Any:
    return model


class DeferredModel:
    """The model a stored :class:`~fuzzymbs.study.integration_check.ToleranceChoice` took,
    built (:func:`~fuzzymbs.study.integration_check.chosen_model`: its shared steps'
    logging and reference runs) only when something needs it: a run, or an attribute
    not known without it.

    Known without building: ``shares_steps`` and ``time_integration`` (from the choice),
    ``identity()`` (the chosen model's, stored with the choice; absent where it had
    none), and what ``share_steps`` and ``tightened`` leave as they were: the
    descriptions a study reads (``outputs``, ``coords``, ``output_dims``, ``coord_units``,
    ``reference``, ``reference_labels``, ``check_parameters``) and ``differentiable``,
    ``scalable_tolerance``, ``gradient_cost``, read off the model the choice started
    from. Pickled, it is the built model.

    Parameters
    ----------
    model : the model the choice started from (the study's own).
    modal : the modal point's parameter columns.
    choice : the stored choice.
    identity : the chosen model's ``identity()``; None if it has none.
    """

    _UNCHANGED = (
        "outputs",
        "coords",
        "output_dims",
        "coord_units",
        "reference",
        "reference_labels",
        "check_parameters",
        "differentiable",
        "scalable_tolerance",
        "gradient_cost",
    )

    def __init__(
        self,
        model: Any,
        modal: Mapping[str, np.ndarray],
        choice: ToleranceChoice,
        identity: Any = None,
    ) -> None:
        self._origin = model
        self._modal = dict(modal)
        self._choice = choice
        self._identity = identity
        self._model: Any = None
        self._lock = threading.Lock()

    def built(self) -> Any:
        """The chosen model (built on the first call; every thread gets the same one)."""
        with self._lock:
            if self._model is None:
                logger.info("building the model of the stored choice: %s", self._choice.method)
                self._model = chosen_model(self._origin, self._modal, self._choice)
            return self._model

    @property
    def shares_steps(self) -> bool:
        return self._choice.shared_steps

    @property
    def time_integration(self) -> str:
        return self._choice.method

    def tightened(self, *args: Any, **kwargs: Any) -> Any:
        return self.built().tightened(*args, **kwargs)

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return self.built()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        # only for what the instance and the class do not hold
        if name.startswith("__") or name in ("_origin", "_modal", "_choice", "_identity"):
            raise AttributeError(name)
        if name == "identity":
            if self._identity is None:
                raise AttributeError(name)
            stored = self._identity
            return lambda: stored
        if name in self._UNCHANGED:
            return getattr(self._origin, name)
        return getattr(self.built(), name)

    def __reduce__(self) -> tuple[Callable[[Any], Any], tuple[Any]]:
        return _same, (self.built(),)
