"""A deliberately slow closed-form model for resume tests (named "slow_closed_form:make").

Not collected by pytest (no test_ prefix). Referenced from study files as
``"slow_closed_form:make"`` with ``tests/study`` on ``PYTHONPATH``.
"""

from __future__ import annotations

import json
import os
import time

import numpy as np

#: If set, every model call appends one JSON line with its x1 column to this file.
LOG_VARIABLE = "FUZZYMBS_TEST_CALL_LOG"


class SlowProduct:
    """z = x1 * x2, sleeping ``delay`` seconds per call (one call per chunk)."""

    coords: dict = {}  # noqa: RUF012

    def __init__(self, delay: float) -> None:
        self.delay = float(delay)

    def __call__(self, samples):
        time.sleep(self.delay)
        x1 = np.asarray(samples["x1"], dtype=float)
        x2 = np.asarray(samples["x2"], dtype=float)
        log = os.environ.get(LOG_VARIABLE)
        if log:
            with open(log, "a") as handle:
                handle.write(json.dumps(x1.tolist()) + "\n")
        return {"z": x1 * x2}


def make(delay: float = 0.2) -> SlowProduct:
    """Factory: ``[model] name = "slow_closed_form:make"``, option ``delay`` [s]."""
    return SlowProduct(delay)
