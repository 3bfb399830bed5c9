"""The Jacobians of a logging run, kept for the runs on its step sequence (ROS34PW2).

Samples on a shared step sequence renew their Jacobian where the logging run did
(:mod:`fuzzymbs.mbs.shared_steps`). ROS34PW2 is a W-method (Rang & Angermann 2005):
its order holds with any matrix in the Jacobian's place, so a sample at a point of
the sequence can take the Jacobian the logging run's step took there instead of
evaluating its own (docs/theory.md, "Shared steps"). The logging run's lane 0 writes
each Jacobian it evaluates as one row (da/dq, da/dv, f_t: ``2 n^2 + 2 n`` values) and,
per accepted step, the row that step took; a run on the sequence reads them.

The kernel's argument ``jacobians = (rows, step_rows, control)``: ``control[0]`` 0 (off),
1 (write) or 2 (read), ``control[1]`` the rows written so far.
"""

from __future__ import annotations

from typing import Any

import numba as nb
import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.kernels import simd as V

L = V.LANES

#: no Jacobians logged or read (the kernel's ``jacobians``)
NO_JACOBIANS = (np.zeros((0, 0)), np.zeros(0), np.zeros(2))
#: the most memory one log's rows may take, in bytes (1 GiB: about 39,000 of the brake's
#: 27.5 kB rows, more than its 24,096-row bound). A row grows as the square of the
#: degrees of freedom, so a model ten times the brake's size would otherwise hold 2.7 MB
#: per renewal; past the bound the logging run keeps no more rows and the samples on its
#: sequence evaluate their own Jacobians there
LOG_BYTES = 2**30


@nb.njit(cache=True)
def log_jacobian(jq, jv, ft, n, nstate, jac_log, jac_ctl):
    """Lane 0's Jacobian (da/dq, da/dv, f_t) into row ``jac_ctl[1]`` of ``jac_log``, and
    the count up by one (rows past the log's end are counted, not written)."""
    row = int(jac_ctl[1])
    if row < jac_log.shape[0]:
        for e in range(n * n):
            jac_log[row, e] = jq[L * e]
            jac_log[row, n * n + e] = jv[L * e]
        for k in range(nstate):
            jac_log[row, 2 * n * n + k] = ft[L * k]
    jac_ctl[1] = row + 1


@nb.njit(cache=True)
def lanes_from_log(renew, reading, place, jac_rows, from_log, own):
    """(any own, any from the log): of the lanes that ``renew``, those at a point of the
    sequence (``place = (h, grid, t, t0)``: the step proposal is the whole next interval,
    infinite, or the lane has not left the start) whose step has a logged row take it
    (``from_log``, when ``reading``), the others evaluate their own (``own``)."""
    h, grid, t, t0 = place
    any_own = False
    any_logged = False
    for lane in range(L):
        from_log[lane] = False
        point = int(grid[lane])
        at_point = h[lane] == np.inf or (point == 0 and t[lane] == t0)
        if renew[lane] and reading and at_point:
            from_log[lane] = jac_rows[point] >= 0.0
        own[lane] = renew[lane] and not from_log[lane]
        any_own = any_own or own[lane]
        any_logged = any_logged or from_log[lane]
    return any_own, any_logged


@nb.njit(cache=True)
def take_logged(from_log, grid, jacobians, n, nstate, jq, jv, ft, control_rows):
    """Each lane in ``from_log`` takes the row its step at point ``grid[lane]`` took into
    its Jacobian and f_t; its age, need and LU step (``control_rows``) are reset as after
    an evaluation of its own."""
    jac_log, jac_rows = jacobians[0], jacobians[1]
    need_jac, jac_age, lu_step = control_rows
    for lane in range(L):
        if from_log[lane]:
            row = int(jac_rows[int(grid[lane])])
            for e in range(n * n):
                jq[L * e + lane] = jac_log[row, e]
                jv[L * e + lane] = jac_log[row, n * n + e]
            for k in range(nstate):
                ft[L * k + lane] = jac_log[row, 2 * n * n + k]
            need_jac[lane] = 0.0
            jac_age[lane] = 0.0
            lu_step[lane] = -1.0


def jacobian_arrays(compiled, integrator, log, log_steps, logged, sequence, n_steps) -> tuple:
    """The kernel's ``jacobians`` for :func:`fuzzymbs.mbs.integrate.simulate`: writing the
    first sample's (``log``, its ``log_jacobians``), reading ``logged`` (its
    ``logged_jacobians``), or :data:`NO_JACOBIANS`."""
    width = 2 * compiled.n_dofs * compiled.n_dofs + compiled.n_state
    if log:
        if integrator != "ros34pw2" or log_steps is False:
            raise InvalidParameterError("log_jacobians needs integrator='ros34pw2' and log_steps")
        # rows are touched only as they are written (np.empty): a generous log costs no
        # memory it does not use
        steps = max(20 * n_steps, 10**6) if log_steps is True else int(log_steps)
        rows = max(1, min(2 * n_steps + 4096, LOG_BYTES // (8 * width)))
        return np.empty((rows, width)), np.full(steps, -1.0), np.array([1.0, 0.0])
    if logged is None:
        return NO_JACOBIANS
    if integrator != "ros34pw2" or sequence.size == 0:
        raise InvalidParameterError(
            "logged_jacobians need integrator='ros34pw2' and a step_sequence"
        )
    rows, step_rows = (np.ascontiguousarray(a, dtype=np.float64) for a in logged)
    if rows.ndim != 2 or rows.shape[1] != width or step_rows.shape != sequence.shape:
        raise InvalidParameterError(
            f"logged_jacobians: rows must be (J, {width}) and step_rows one per step of the "
            f"sequence ({sequence.size}), got {rows.shape} and {step_rows.shape}"
        )
    if step_rows.size and step_rows.max() >= rows.shape[0]:
        raise InvalidParameterError("logged_jacobians: a step names a row past the log")
    return rows, step_rows, np.array([2.0, 0.0])


def logged_rows(jacobians: tuple, logs: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A written log trimmed to its rows and the first sample's logged steps.

    The rows are a view: those past the written ones were never touched and hold no
    memory (:func:`jacobian_arrays`), while a copy would fault the written ones in a
    second time (the brake's study 1 logs about 350 MB). The step rows, filled in
    whole, are copied, so that their unused end is freed.
    """
    rows, step_rows, control = jacobians
    count = min(int(control[1]), rows.shape[0])
    steps = 0 if logs is None or logs[0] is None else logs[0].shape[0]
    return rows[:count], step_rows[:steps].copy()
