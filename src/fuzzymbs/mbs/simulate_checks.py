"""The checks of :func:`fuzzymbs.mbs.integrate.simulate`'s arguments: each raises
:class:`~fuzzymbs.errors.InvalidParameterError` naming the argument and what it allows."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.kernels.simd import LANES
from fuzzymbs.tolerance import Tolerance

#: Kernel choices of :func:`~fuzzymbs.mbs.integrate.simulate`.
KERNELS = ("auto", "lanes", "samples")
#: Integrators of :func:`~fuzzymbs.mbs.integrate.simulate`: the paper's fixed-step RK4, and
#: the Rosenbrock methods with error control (:mod:`fuzzymbs.mbs.kernels.rosenbrock`;
#: opt-in): ROS34PW2 (the brake model's default) and RODAS4
INTEGRATORS = ("rk4", "ros34pw2", "rodas4")


def check_timing(t_end: float, dt: float, record_interval: float | None) -> tuple[int, int]:
    """``(steps, steps per record)`` of a fixed step ``dt`` over ``t_end`` recorded every
    ``record_interval`` (default every step); both must be whole numbers."""
    if not (np.isfinite(dt) and dt > 0):
        raise InvalidParameterError(f"time step dt must be > 0 s, got {dt!r}")
    if not (np.isfinite(t_end) and t_end > 0):
        raise InvalidParameterError(f"t_end must be > 0 s, got {t_end!r}")
    n_steps = round(t_end / dt)
    if abs(n_steps * dt - t_end) > 1e-9 * t_end:
        raise InvalidParameterError(f"t_end = {t_end} s is not a whole number of steps dt = {dt} s")
    interval = dt if record_interval is None else record_interval
    every = round(interval / dt)
    if every < 1 or abs(every * dt - interval) > 1e-9 * interval:
        raise InvalidParameterError(
            f"record_interval = {interval} s must be a positive multiple of dt = {dt} s"
        )
    return n_steps, every


def check_integrator(
    integrator: str, tolerance: Tolerance
) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """``(rtol, atol, smallest step)`` for ROS34PW2 after checking the settings; rtol and
    atol as 1-D arrays (one value, or one per sample; the tolerance checked its values)."""
    if integrator not in INTEGRATORS:
        raise InvalidParameterError(f"integrator must be one of {INTEGRATORS}, got {integrator!r}")
    if not isinstance(tolerance, Tolerance):
        raise InvalidParameterError(
            f"tolerance must be a fuzzymbs.tolerance.Tolerance, got {tolerance!r}"
        )
    return (*tolerance.arrays(), 1e-14)


def per_sample(values: NDArray[np.float64], batch: int, name: str) -> NDArray[np.float64]:
    """A tolerance for every sample of the batch (one value for all, or one each)."""
    if values.size not in (1, batch):
        raise InvalidParameterError(
            f"{name} must be one value or one per sample ({batch}), got {values.size}"
        )
    return np.array(np.broadcast_to(values, (batch,)))  # writable: one kernel signature


def check_kernel(kernel: str) -> None:
    """``kernel`` is one of :data:`KERNELS`."""
    if kernel not in KERNELS:
        raise InvalidParameterError(f"kernel must be one of {KERNELS}, got {kernel!r}")


def checked_log_samples(log_samples: int, batch: int, per_block: int) -> int:
    """The rows of the step log: ``log_samples`` of the batch's first samples, which
    must lie in its first block of ``per_block`` lanes (the kernel logs there)."""
    limit = min(batch, per_block)
    if isinstance(log_samples, bool) or not isinstance(log_samples, (int, np.integer)):
        raise InvalidParameterError(f"log_samples must be a whole number, got {log_samples!r}")
    if not 1 <= log_samples <= limit:
        raise InvalidParameterError(
            f"log_samples must be 1 to {limit} (the batch's first block of lanes), "
            f"got {log_samples}"
        )
    return int(log_samples)


def samples_per_block(kernel: str) -> int:
    """Samples that share one block of lanes for the ``kernel`` option of
    :func:`~fuzzymbs.mbs.integrate.simulate`."""
    check_kernel(kernel)
    return 1 if kernel == "samples" else LANES


def checked_initial_state(compiled: Any, initial_state: Any, batch: int) -> NDArray[np.float64]:
    """The (batch, 2n) initial states of ``simulate``: the system's own (None), or
    ``initial_state`` of one row or ``batch`` rows, finite, as a writable copy."""
    if initial_state is None:
        return compiled.initial_state(batch)
    x0 = np.asarray(initial_state, dtype=float)
    if x0.ndim == 1:
        x0 = np.broadcast_to(x0, (batch, x0.size))
    if x0.shape != (batch, compiled.n_state) or not np.isfinite(x0).all():
        raise InvalidParameterError(
            f"initial_state must be finite of shape ({compiled.n_state},) or "
            f"({batch}, {compiled.n_state}), got {np.shape(initial_state)}"
        )
    # a writable copy: a read-only array (a broadcast row) is another kernel signature,
    # compiled again at the full cost
    return np.array(x0, dtype=np.float64, order="C")
