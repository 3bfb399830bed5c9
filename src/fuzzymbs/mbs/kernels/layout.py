"""Layout of the compiled system's tables, and the kernels' status codes.

:meth:`fuzzymbs.mbs.system.System.compile` writes these tables and the kernels
read them; this module is the one place that names their columns (see
:mod:`fuzzymbs.mbs.system` for the whole ``data`` tuple).
"""

from __future__ import annotations

# body table ``bi`` columns
B_KIND, B_DOF0, B_NTR, B_NM, B_NODE0, B_NODE1, B_PSI0, B_MAT0, B_SPEED, B_PROF, B_PSIT0 = range(11)
KIND_FIXED, KIND_TRANSLATING, KIND_ROTATING = 0, 1, 2
# contact table ``ci`` columns
(
    C_SBODY,
    C_MBODY,
    C_SLAVE0,
    C_NSLAVE,
    C_KIND,
    C_NU,
    C_NV,
    C_U0,
    C_V0,
    C_GRID0,
    C_NORMAL0,
    C_PEN,
    C_MU,
    C_PERIODIC,
) = range(14)
# contact float table ``cf`` columns beyond the chart frame (0-8: origin, u axis, v axis),
# eps (9) and normal damping (10): per-pass constants of the cell look-up, computed once
# by System.compile
CF_EPS, CF_DAMPING, CF_USCALE, CF_UUNIFORM, CF_VSCALE, CF_VUNIFORM = range(9, 15)
# per-sample status codes of the integrators
OK, NONFINITE, OUT_OF_BOUND, STEP_TOO_SMALL = 0, 1, 2, 3
FAILURE_REASONS = {
    OK: "",
    NONFINITE: "non-finite state (NaN or inf)",
    OUT_OF_BOUND: "output beyond the displacement bound",
    STEP_TOO_SMALL: "error control needed a step below the smallest allowed",
}
# rows of the float scratch array of the work tuple (each LANES wide): Schur right-hand
# sides / cos, sin of the rotation angle; per-lane cell coordinates and on-patch flags;
# the four master nodes' positions and velocities gathered per lane (row S_XM + 6 q + d:
# corner q, component d: x0..x2 then v0..v2); the cells' normals
S_SCHUR, S_COS, S_SIN = 0, 0, 1
S_XI, S_ETA, S_ON, S_XM, S_NRM = 3, 4, 5, 6, 30
SCRATCH = 33
# rows of the integer cell table of the work tuple: cell id, i, j, then the four master
# nodes' offsets
I_CELL, I_U, I_V, I_NODES = 0, 1, 2, 3
