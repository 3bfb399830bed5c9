"""The adaptive method's extrema confirmed on the model: local searches along flat directions.

The adaptive method (:mod:`fuzzymbs.fuzzy.adaptive`) reports, per alpha-cut,
output element and side, the extremum of its surrogate, and certifies it by
running the model at that point. That run checks the surrogate's *value* at
its extremum, not its *location*: on a resonance ridge (a forced oscillator's
amplitude, high along ``k = m Omega^2`` and narrow across it) the surrogate
can put its maximum anywhere along the crest, the model agrees with it there,
and the ridge's highest point, at one end of it, is never run.

What this module adds, once the certified error is within the tolerance: for
every extremum ``x*`` of the surrogate ``s`` (level ``j``, element ``e``, side
``sigma = +1`` for the maximum, ``-1`` for the minimum),

1. the *free* directions: the coordinates where ``x*`` lies inside the level's
   box, or on a face whose slope there could not hold it (``|ds/dx_i|`` times
   the box's width below ``FLAT`` times the cut-width scale);
2. the surrogate's Hessian over them (central differences of its gradient),
   and its eigenvectors ``v``: along a ridge's crest the curvature is small,
   across it large;
3. *face probes*: along each eigenvector, both ways, the line from ``x*`` to the
   box's boundary, then the surrogate climbed within the face that line leaves
   by (:func:`fuzzymbs.fuzzy.box_search.climb`): the end of a ridge; a candidate
   where the surrogate predicts it at most ``PROMISING`` of the cut width short
   of its extremum, and the same point moved onto every other face of the box
   closer than ``SNAP`` and climbed again over the coordinates still inside (the
   corner a ridge runs into, where the surrogate, with no run near, can bend away
   from it, and where the crest's place moves with the coordinates pinned);
4. *local probes*: ``x* +- h v``, ``h`` where the surrogate's quadratic model
   changes by ``LOCAL`` of the cut width (shorter than ``MIN_STEP``): the
   crest's exact place and height;
5. the candidates least supported by runs first (distance to the nearest run
   over the candidate's own scale: a local probe's ``h``; a face point's
   ``MIN_STEP``, or less where the surrogate bends within its face), each farther
   than ``min(near, scale / 2)`` from every run and every probe chosen, at most
   ``limit``;
6. then the near ties: face points the surrogate puts within ``NEAR_TIE`` of the
   cut width of its extremum, not yet supported in that sense, the most promising
   first, at most ``tie_limit`` more;
7. then the isolated extrema: the surrogate's extremal points themselves (every
   level, element and side), each the farthest from every run and probe chosen so
   far while farther than ``ISOLATED``, at most ``isolated_limit`` more: a signal has
   hundreds of extrema, of which the rounds' certification ran the most doubtful
   few; these spread a sample over the rest. Steps 5 to 7 are one batch for the
   model.

The probes join the surrogate like any run off its grid (its kernel
correction), so the next round's surrogate, and its extremum, move towards a
higher point the model showed; a probe above the reported bound widens it at
once. The method's certified error then includes how far the bounds moved:
within the tolerance the extrema are confirmed, above it the rounds go on and
confirm again later. It is a local search on the model, started from the
surrogate's extremum and restarted from the next one, one batch a round
(docs/fuzzy.md, "Confirming the extrema on the model").

Everything is a deterministic function of the surrogate and the runs, so a
replay proposes the same probes bit for bit.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.fuzzy.box_search import climb, values_at
from fuzzymbs.fuzzy.chebyshev_grid import basis_gradient
from fuzzymbs.fuzzy.grids import nearest_distances
from fuzzymbs.fuzzy.residual_correction import KernelCorrection

__all__ = [
    "FLAT",
    "ISOLATED",
    "MIN_STEP",
    "NEAR_TIE",
    "confirmation_probes",
    "surrogate_gradient",
    "surrogate_hessian",
]

#: the change (cut-width scale) the surrogate's quadratic model may predict over a probe step
FLAT = 0.1
#: a face point is a candidate when the surrogate predicts it at most this far (cut-width
#: scale) from its extremum
PROMISING = 0.25
#: a local probe's step: where the surrogate's quadratic model changes by this (cut-width scale)
LOCAL = 0.01
#: a direction is flat when that change takes a step longer than this (unit cube [-1, 1]^n)
MIN_STEP = 0.1
#: a face point this close to other faces of its box (unit cube) is tried on them too.
#: Measured (benchmarks/gradient_adaptive.py, 2026-12-02): the oscillator at 0.5 % with
#: gradients 3 % of the cut width off (--gradient-error 0.03, three seeds) was falsely
#: certified with 0, 0.1 (3.1-3.3 % missed, 0.5-0.8 % reported), honest with 0.2 and 0.3; the
#: chain at 0.5 % with 1 % off (seed 1) only with 0.3; the values-only chain at 0.5 % missed
#: 1.43 / 1.43 / 0.93 / 1.02 % with 0 / 0.1 / 0.2 / 0.3; the other cases' runs within 3
SNAP = 0.3
#: a face point the surrogate predicts within this (cut-width scale) of its extremum is a
#: near tie: every one not yet supported by a run is probed, beyond ``limit`` (up to
#: ``tie_limit`` more). Measured (benchmarks/gradient_adaptive.py, 2026-12-02): without it
#: the chain at 0.5 % without gradients ends 1.02 % (1.43 % on a round-off variant of the
#: kernel distances) off its crest's highest end, which ranks below the batch's local probes;
#: 0.01 and 0.05 make the same runs within 4 on every closed-form case, with the same misses
NEAR_TIE = 0.02
#: an extremal point farther than this from every run and probe (unit cube, max norm) is
#: isolated (step 7). Measured (benchmarks/random_honesty.py and gradient_adaptive.py,
#: 2026-12-02): 0.1 and 0.02 end the same four of five false certificates on the random
#: models, 0.02 taking valley4 with gradients 48 runs instead of 46; 0.2 leaves the
#: 3-parameter signal without gradients 1.72 % off
ISOLATED = 0.1
#: central-difference step of the Hessian (unit cube)
_STEP = 1e-4
#: a coordinate closer than this to its box bound lies on the face (unit cube)
_ON_FACE = 1e-9


def surrogate_gradient(
    degrees: NDArray[np.int64],
    coefficients: NDArray[np.float64],
    correction: KernelCorrection | None,
    points: NDArray[np.float64],
    element: NDArray[np.intp],
) -> NDArray[np.float64]:
    """(K, n) the gradient of element ``element[k]`` of the surrogate at ``points[k]``."""
    _, gradient = basis_gradient(degrees, points)  # (n, K, D)
    slope = np.einsum("ikd,dk->ki", gradient, coefficients[:, element])
    if correction is not None:
        slope = slope + correction.gradient_at(points, element)
    return slope


def surrogate_hessian(
    surrogate: tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None],
    points: NDArray[np.float64],
    element: NDArray[np.intp],
    sign: NDArray[np.float64],
    free: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """(K, n, n) the Hessian of ``sign[k]`` times element ``element[k]`` of the surrogate at
    ``points[k]`` over its ``free`` coordinates (central differences of the gradient,
    symmetrised; zero in the rows and columns of the other coordinates)."""
    degrees, coefficients, correction = surrogate
    count, dimension = points.shape
    hessian = np.zeros((count, dimension, dimension))
    for i in range(dimension):
        if not free[:, i].any():
            continue
        shift = np.zeros(dimension)
        shift[i] = _STEP
        forward = surrogate_gradient(degrees, coefficients, correction, points + shift, element)
        backward = surrogate_gradient(degrees, coefficients, correction, points - shift, element)
        hessian[:, i, :] = sign[:, None] * (forward - backward) / (2.0 * _STEP)
    hessian = 0.5 * (hessian + hessian.transpose(0, 2, 1))
    mask = free[:, :, None] & free[:, None, :]
    return np.where(mask, hessian, 0.0)


def _on_near_faces(
    points: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    moving: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The face points moved onto every face of their box closer than ``SNAP`` (M, n), and
    which of the P points moved (P,): the corner a ridge runs into, where the surrogate,
    with no run near, can bend away from it; where both faces of a coordinate are that
    close (a box narrower than ``2 SNAP``), onto the nearer."""
    width = (high > low) & moving
    below, above = points - low, high - points
    moved = np.where(width & (below <= SNAP) & (below <= above), low, points)
    moved = np.where(width & (above <= SNAP) & (above < below), high, moved)
    did = np.any(moved != points, axis=1)
    return moved[did], did


def confirmation_probes(
    surrogate: tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None],
    arg_lower: NDArray[np.float64],
    arg_upper: NDArray[np.float64],
    box_low: NDArray[np.float64],
    box_high: NDArray[np.float64],
    scale: NDArray[np.float64],
    runs: NDArray[np.float64],
    moving: NDArray[np.bool_],
    *,
    near: float,
    limit: int,
    tie_limit: int = 0,
    isolated_limit: int = 0,
) -> NDArray[np.float64]:
    """The probes (P, n) that confirm the surrogate's extrema on the model (module docstring).

    Parameters
    ----------
    surrogate : (degrees, coefficients, correction)
        The adaptive method's surrogate: a Chebyshev series (D, n), (D, E) and its
        kernel correction (or None).
    arg_lower, arg_upper : ndarray (L, E, n)
        The surrogate's extremal points per level and element (unit cube).
    box_low, box_high : ndarray (L, n)
        The cut boxes (unit cube).
    scale : ndarray (L, E)
        The cut-width scale of each level and element (inf: nothing to confirm).
    runs : ndarray (N, n)
        Every run so far (unit cube).
    moving : ndarray (n,) of bool
        Parameters that vary.
    near : float
        A probe closer than this to a run or another probe (max norm over the moving
        coordinates) is dropped.
    limit : int
        Probes at most, least supported first.
    tie_limit : int
        Near ties (face points within ``NEAR_TIE`` of their extremum) not yet supported,
        at most, beyond ``limit``.
    isolated_limit : int
        Extremal points farther than ``max(near, ISOLATED)`` from every run and probe,
        the farthest first, at most, beyond those.

    Returns
    -------
    ndarray (P, n)
        The probes in the unit cube, the longest flat steps first; none when every
        extremum is confirmed (its flat directions end near runs).
    """
    degrees, coefficients, correction = surrogate
    count_levels, elements, dimension = arg_lower.shape
    if limit <= 0 or not moving.any():
        return np.empty((0, dimension))
    points = np.concatenate((arg_lower.reshape(-1, dimension), arg_upper.reshape(-1, dimension)))
    level = np.tile(np.repeat(np.arange(count_levels), elements), 2)
    element = np.tile(np.arange(elements), 2 * count_levels)
    sign = np.repeat([-1.0, 1.0], count_levels * elements)
    width = scale[level, element]
    low, high = box_low[level], box_high[level]
    keep = np.isfinite(width) & np.any(high > low, axis=1)
    points, level, element, sign, width = (a[keep] for a in (points, level, element, sign, width))
    low, high = low[keep], high[keep]
    if not len(points):
        return np.empty((0, dimension))
    extrema = points
    # 1. free coordinates: inside the box, or on a face the slope cannot hold it to
    slope = sign[:, None] * surrogate_gradient(degrees, coefficients, correction, points, element)
    inside = (points > low + _ON_FACE) & (points < high - _ON_FACE)
    weak = np.abs(slope) * (high - low) <= FLAT * width[:, None]
    free = (inside | weak) & (high > low) & moving[None, :]
    some = free.any(axis=1)
    points, level, element, sign, width, low, high, free = (
        a[some] for a in (points, level, element, sign, width, low, high, free)
    )
    if not len(points):
        return _isolated(extrema, runs, np.empty((0, dimension)), moving, near, isolated_limit)
    # 2. the Hessian of sigma s over the free coordinates (central differences of the gradient)
    count = len(points)
    hessian = surrogate_hessian(surrogate, points, element, sign, free)
    # a fixed coordinate gets a large positive sentinel: its eigenvector is its own axis
    sentinel = 1e300
    diagonal = np.arange(dimension)
    hessian[:, diagonal, diagonal] = np.where(free, hessian[:, diagonal, diagonal], sentinel)
    curvature, vectors = np.linalg.eigh(hessian)  # (K, n), (K, n, n): columns
    own = np.arange(count)
    value = values_at(degrees, coefficients, points, element, correction)
    # 3. along each eigenvector, both ways, to the box's boundary; climb the surrogate
    # there on the face the line leaves by: the end of a ridge, a valley's floor
    starts, faces_low, faces_high, rows = [], [], [], []
    # and the local probes x* +- h v, h where the quadratic model changes by LOCAL
    local, reach = [], []
    for q in range(dimension):
        for way in (1.0, -1.0):
            step = way * vectors[:, :, q]
            step = np.where(free, step, 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                room = np.where(
                    step > 1e-12,
                    (high - points) / step,
                    np.where(step < -1e-12, (low - points) / step, np.inf),
                )
            exit_axis = np.argmin(room, axis=1)
            length = room[own, exit_axis]
            bend = np.maximum(-curvature[:, q], 0.0)
            with np.errstate(divide="ignore"):
                h = np.minimum(np.sqrt(2.0 * LOCAL * width / bend), length)
            short = (curvature[:, q] < 1e299) & (h < MIN_STEP) & (h > 0.0)
            local.append(
                np.clip(points[short] + h[short, None] * step[short], low[short], high[short])
            )
            reach.append(h[short])
            go = np.isfinite(length) & (length > MIN_STEP)
            if not go.any():
                continue
            end = np.clip(points + np.where(go, length, 0.0)[:, None] * step, low, high)
            face_low, face_high = low.copy(), high.copy()
            face_low[own, exit_axis] = face_high[own, exit_axis] = end[own, exit_axis]
            starts.append(end[go])
            faces_low.append(face_low[go])
            faces_high.append(face_high[go])
            rows.append(own[go])
    if not starts:
        starts, faces_low, faces_high, rows = [points[:0]], [low[:0]], [high[:0]], [own[:0]]
    row = np.concatenate(rows)
    found, predicted = climb(
        degrees,
        coefficients,
        np.concatenate(starts),
        element[row],
        sign[row],
        np.concatenate(faces_low),
        np.concatenate(faces_high),
        correction,
    )
    # a candidate where the surrogate predicts at most PROMISING of the cut width below its
    # extremum (far from the runs it can be off by that much)
    shortfall = sign[row] * (value[row] - predicted) / width[row]
    promising = shortfall <= PROMISING
    row = row[promising]
    corners, moved = _on_near_faces(found[promising], box_low[level[row]],
                                    box_high[level[row]], moving)  # fmt: skip
    # a corner's other coordinates climbed again within it: where a crest meets a face
    # depends on the coordinates pinned there (the two-mass chain's crest in k1 moves with k2)
    corners = _climb_within_faces(surrogate, corners, row[moved], element, sign,
                                  box_low[level], box_high[level])  # fmt: skip
    faces = np.concatenate((found[promising], corners))
    face_row = np.concatenate((row, row[moved]))
    face_shortfall = (
        sign[face_row]
        * (value[face_row] - values_at(degrees, coefficients, faces, element[face_row], correction))
        / width[face_row]
    )
    candidates = np.concatenate((faces, *local))
    # a face point's scale: MIN_STEP, or shorter where the surrogate bends within the face
    # (a run 0.03 off across a crest 0.02 wide does not support it)
    bent = _bend_scale(surrogate, faces, face_row, element, sign, width, box_low[level],
                       box_high[level], moving)  # fmt: skip
    scale_of = np.concatenate((bent, *reach))
    # 5. the candidates least supported by runs first: the distance to the nearest run over
    # the candidate's own scale (a face point's, a local probe's h); a candidate nearer to a
    # run or a chosen probe than min(near, scale / 2) is known already
    chosen: list[NDArray[np.float64]] = []
    placed = candidates[:, moving]
    far = nearest_distances(placed, runs[:, moving])
    enough = np.minimum(near, scale_of / 2.0)
    while len(chosen) < limit and len(candidates):
        best = int(np.argmax(np.where(far > enough, far / scale_of, -1.0)))
        if far[best] <= enough[best]:
            break
        chosen.append(candidates[best])
        far = np.minimum(far, nearest_distances(placed, placed[best : best + 1]))
    # 6. then every near tie still unsupported, the most promising first: a face point the
    # surrogate puts within NEAR_TIE of its extremum decides the bound if the surrogate is
    # a little low there, however well the runs nearby seem to support it
    tie = np.full(len(candidates), np.inf)
    tie[: len(faces)] = np.where(face_shortfall <= NEAR_TIE, face_shortfall, np.inf)
    for _ in range(tie_limit if len(candidates) else 0):
        best = int(np.argmin(np.where(far > enough, tie, np.inf)))
        if not (far[best] > enough[best] and np.isfinite(tie[best])):
            break
        chosen.append(candidates[best])
        far = np.minimum(far, nearest_distances(placed, placed[best : best + 1]))
    # 7. then the extremal points farthest from every run and probe
    probes = np.array(chosen).reshape(-1, dimension)
    return _isolated(extrema, runs, probes, moving, near, isolated_limit)


def _isolated(
    extrema: NDArray[np.float64],
    runs: NDArray[np.float64],
    probes: NDArray[np.float64],
    moving: NDArray[np.bool_],
    near: float,
    limit: int,
) -> NDArray[np.float64]:
    """``probes`` and, after them, up to ``limit`` of the ``extrema`` (K, n), each the
    farthest (max norm over the ``moving`` coordinates) from every run, probe and
    extremum chosen before it, as long as that is more than ``max(near, ISOLATED)``."""
    if limit <= 0 or not len(extrema):
        return probes
    placed = extrema[:, moving]
    known = np.concatenate((runs, probes))[:, moving]
    far = nearest_distances(placed, known)
    chosen = [probes]
    for _ in range(limit):
        best = int(np.argmax(far))
        if not far[best] > max(near, ISOLATED):
            break
        chosen.append(extrema[best : best + 1])
        far = np.minimum(far, nearest_distances(placed, placed[best : best + 1]))
    return np.concatenate(chosen)


def _climb_within_faces(
    surrogate: tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None],
    points: NDArray[np.float64],
    rows: NDArray[np.intp],
    element: NDArray[np.intp],
    sign: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
) -> NDArray[np.float64]:
    """The points (M, n) climbed on the surrogate (``sign`` times element ``element``
    of row ``rows[m]``) over the coordinates that lie inside their box (``low``,
    ``high`` per row), the others pinned on their faces."""
    if not len(points):
        return points
    degrees, coefficients, correction = surrogate
    box_low, box_high = low[rows], high[rows]
    pinned = (points <= box_low) | (points >= box_high)
    face_low = np.where(pinned, points, box_low)
    face_high = np.where(pinned, points, box_high)
    climbed, _ = climb(
        degrees, coefficients, points, element[rows], sign[rows], face_low, face_high, correction
    )
    return climbed


def _bend_scale(
    surrogate: tuple[NDArray[np.int64], NDArray[np.float64], KernelCorrection | None],
    points: NDArray[np.float64],
    rows: NDArray[np.intp],
    element: NDArray[np.intp],
    sign: NDArray[np.float64],
    width: NDArray[np.float64],
    low: NDArray[np.float64],
    high: NDArray[np.float64],
    moving: NDArray[np.bool_],
) -> NDArray[np.float64]:
    """(M,) the face points' scale: the step over which the surrogate's quadratic model
    along its sharpest downward curvature within the face (the coordinates inside the
    box) changes by ``LOCAL`` of the cut width, at most ``MIN_STEP``."""
    if not len(points):
        return np.empty(0)
    inside = (points > low[rows] + _ON_FACE) & (points < high[rows] - _ON_FACE) & moving
    hessian = surrogate_hessian(surrogate, points, element[rows], sign[rows], inside)
    bend = np.maximum(-np.linalg.eigvalsh(hessian)[:, 0], 0.0)
    with np.errstate(divide="ignore"):
        return np.minimum(MIN_STEP, np.sqrt(2.0 * LOCAL * width[rows] / bend))
