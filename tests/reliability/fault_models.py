"""Models that misbehave on purpose, for the fault-injection tests (tests/reliability).

Each is a module-level class (picklable, so it also runs on process workers) and
is reachable from a study file as ``"fault_models:make"`` with ``tests/reliability``
on ``PYTHONPATH``. The fault strikes only in batches holding a sample with
``x1 > 2.5`` (the upper end of the support), so most samples of a plan succeed.
"""

from __future__ import annotations

import os
import signal
import sys
import time

import numpy as np

THRESHOLD = 2.5


class Faulty:
    """``z = x1 * x2`` with the fault ``fault`` where ``x1 > 2.5`` (or, ``everywhere``, always)."""

    outputs = None  # undeclared: the runner learns the outputs from the first chunk

    def __init__(self, fault: str, everywhere: bool = False) -> None:
        self.fault = fault
        self.everywhere = everywhere

    def __call__(self, samples):
        x1 = np.asarray(samples["x1"], float)
        x2 = np.asarray(samples["x2"], float)
        z = x1 * x2
        if not (self.everywhere or (x1 > THRESHOLD).any()):
            return {"z": z}
        fault = self.fault
        if fault == "exit":
            sys.exit(0)
        if fault == "os_exit":
            os._exit(0)
        if fault == "kill":
            os.kill(os.getpid(), signal.SIGKILL)
        if fault == "hang":
            time.sleep(3600)
        if fault == "string":
            return {"z": [str(v) for v in z]}
        if fault == "ragged":
            return {"z": [[1.0, 2.0]] + [[1.0]] * (len(z) - 1)}
        if fault == "empty":
            return {}
        if fault == "reason_only":
            return {"failure_reason": ["none"] * len(z)}
        if fault == "shape":  # (B, 4) elsewhere, (B, 1) here
            return {"z": z[:, None]}
        if fault == "new_key":
            return {"z": z, "extra": z}
        if fault == "bad_name":
            return {"../escape": z}
        raise ValueError(f"unknown fault {fault!r}")


class Shaped(Faulty):
    """Like :class:`Faulty`, but a regular output of trailing shape (4,)."""

    def __call__(self, samples):
        raw = super().__call__(samples)
        if self.fault == "shape" and raw["z"].ndim == 2:
            return raw
        return {"z": np.repeat(np.asarray(raw["z"], float)[:, None], 4, axis=1)}


def make(fault: str = "none", everywhere: bool = False, shaped: bool = False) -> Faulty:
    """Factory for study files: ``[model] name = "fault_models:make"``."""
    return (Shaped if shaped else Faulty)(fault, everywhere)
