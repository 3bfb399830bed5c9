"""The Rosenbrock methods of :mod:`fuzzymbs.mbs.kernels.rosenbrock`, as its kernel takes them.

A method is a tuple ``(at, c, m, m - mhat, alpha, gamma_i, settings)`` of the
transformed form (Hairer & Wanner, Solving ODEs II, Sec. IV.7; the kernel's module
docstring gives the stage equations): ROS34PW2 (:data:`COEFFICIENTS`, the default, a
W-method of order 3) from the paper's tableau by :func:`transformed`, and RODAS4
(:func:`rodas4_coefficients`, order 4, the exact Jacobian) from the published
transformed coefficients; :func:`tableau` rebuilds the W-form for the order
conditions' tests. :data:`METHODS` names them for
:func:`fuzzymbs.mbs.integrate.simulate`'s ``integrator``.
"""

from __future__ import annotations

import numpy as np

# ROS34PW2, Rang & Angermann (2005), Table "ROS34PW2" (W-method form: a_ij, gamma_ij, b, bhat)
GAMMA = 4.3586652150845900e-1
TABLEAU_A = np.array(
    [
        [0.0, 0.0, 0.0, 0.0],
        [8.7173304301691801e-1, 0.0, 0.0, 0.0],
        [8.4457060015369423e-1, -1.1299064236484185e-1, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ]
)
TABLEAU_GAMMA = np.array(
    [
        [GAMMA, 0.0, 0.0, 0.0],
        [-8.7173304301691801e-1, GAMMA, 0.0, 0.0],
        [-9.0338057013044082e-1, 5.4180672388095326e-2, GAMMA, 0.0],
        [2.4212380706095346e-1, -1.2232505839045147, 5.4526025533510214e-1, GAMMA],
    ]
)
TABLEAU_B = np.array([2.4212380706095346e-1, -1.2232505839045147, 1.5452602553351020, GAMMA])
TABLEAU_BHAT = np.array([3.7810903145819369e-1, -9.6042292212423178e-2, 0.5, 2.1793326075422950e-1])


def transformed(tableau_a, tableau_gamma, b, bhat, jacobian_age, embedded_order):
    """The kernel's coefficients of a Rosenbrock method given as ``(A, Gamma, b, bhat)``
    (Hairer & Wanner, Sec. IV.7): ``(at, c, m, m - mhat, alpha, gamma_i, settings)`` with
    ``at = A Gamma^-1`` (s, s), ``c = -Gamma^-1`` below the diagonal (s, s), ``m = b
    Gamma^-1``, ``mhat = bhat Gamma^-1``, ``alpha`` the row sums of A, ``gamma_i`` those
    of Gamma, and ``settings = (gamma, 1 / (embedded order + 1), Jacobian age)``."""
    ginv = np.linalg.inv(tableau_gamma)
    return (
        tableau_a @ ginv,
        -np.tril(ginv, -1),
        b @ ginv,
        (b - bhat) @ ginv,
        tableau_a.sum(axis=1),
        tableau_gamma.sum(axis=1),
        np.array([tableau_gamma[0, 0], 1.0 / (embedded_order + 1.0), float(jacobian_age)]),
    )


#: accepted steps a Jacobian (and f_t) is used for before it is evaluated again (a
#: W-method keeps its order with an aged Jacobian). On the brake over 10 ms, 10 steps
#: gave 0.27 % of the peak in 3.1 s at rtol 1e-2, against 0.42 % in 5.8 s at rtol 3e-3
#: with a fresh Jacobian every step (benchmarks/ros_accuracy.py); on study 1's shared
#: steps at rtol 1e-3 ages 5 to 30 cost the same CPU within 7 %, the older ones more
#: steps (benchmarks/jacobian_age.py, docs/benchmarks.md)
JACOBIAN_AGE = 10
#: ROS34PW2 as the kernel takes it (:func:`transformed`)
COEFFICIENTS = transformed(
    TABLEAU_A, TABLEAU_GAMMA, TABLEAU_B, TABLEAU_BHAT, JACOBIAN_AGE, embedded_order=2
)
# RODAS4 (Hairer & Wanner, Solving ODEs II, 2nd ed. 1996, Sec. VI.4: "RODAS", order
# 4 with an embedded order-3 solution, 6 stages, stiffly accurate and L-stable; the two
# last stages at t + h), given in the transformed form the book's RODAS uses: gamma, the
# stage times alpha_i, gamma_i = sum_j gamma_ij, a_ij = (A Gamma^-1)_ij and c_ij =
# -(Gamma^-1)_ij (i > j), the coefficient set published with the book's code. Stiffly
# accurate: stage 6 is at y + sum_{j<5} a_5j u_j + u_5 and y_new = Y_6 + u_6, whose last
# term u_6 is the error estimate (y_new minus the embedded solution Y_6). Not a W-method:
# its order 4 needs the exact Jacobian (tests/mbs/test_rosenbrock.py checks the order
# conditions of the tableau reconstructed from these numbers).
RODAS4_GAMMA = 0.25
RODAS4_ALPHA = np.array([0.0, 0.386, 0.21, 0.63, 1.0, 1.0])
RODAS4_GAMMA_SUMS = np.array([0.25, -0.1043, 0.1035, -0.3620000000000023e-01, 0.0, 0.0])
_RODAS4_A5 = [
    0.1221224509226641e01,
    0.6019134481288629e01,
    0.1253708332932087e02,
    -0.6878860361058950,
]
RODAS4_AT = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.1544e01, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.9466785280815826, 0.2557011698983284, 0.0, 0.0, 0.0, 0.0],
        [0.3314825187068521e01, 0.2896124015972201e01, 0.9986419139977817, 0.0, 0.0, 0.0],
        [*_RODAS4_A5, 0.0, 0.0],
        [*_RODAS4_A5, 1.0, 0.0],
    ]
)
RODAS4_C = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-0.56688e01, 0.0, 0.0, 0.0, 0.0, 0.0],
        [-0.2430093356833875e01, -0.2063599157091915, 0.0, 0.0, 0.0, 0.0],
        [-0.1073529058151375, -0.9594562251023355e01, -0.2047028614809616e02, 0.0, 0.0, 0.0],
        [
            0.7496443313967647e01,
            -0.1024680431464352e02,
            -0.3399990352819905e02,
            0.1170890893206160e02,
            0.0,
            0.0,
        ],
        [
            0.8083246795921522e01,
            -0.7981132988064893e01,
            -0.3152159432874371e02,
            0.1631930543123136e02,
            -0.6058818238834054e01,
            0.0,
        ],
    ]
)
RODAS4_M = np.array([*_RODAS4_A5, 1.0, 1.0])
RODAS4_ERROR = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])


#: RODAS4's Jacobian age (measured in benchmarks/rodas_work_precision.py)
RODAS4_JACOBIAN_AGE = 1


def rodas4_coefficients(jacobian_age: int) -> tuple:
    """RODAS4 as the kernel takes it, its Jacobian renewed every ``jacobian_age`` accepted
    steps (1: every step, as its order needs)."""
    return (
        RODAS4_AT,
        RODAS4_C,
        RODAS4_M,
        RODAS4_ERROR,
        RODAS4_ALPHA,
        RODAS4_GAMMA_SUMS,
        np.array([RODAS4_GAMMA, 1.0 / 4.0, float(jacobian_age)]),
    )


def tableau(coefficients: tuple) -> tuple:
    """``(A, Gamma, b, bhat, alpha, gamma_i)`` of the W-form (Hairer & Wanner, Sec. IV.7)
    from the kernel's transformed coefficients (the inverse of :func:`transformed`)."""
    at, cc, m, me, alpha, gsum, settings = coefficients
    gamma_inverse = np.diag(np.full(m.size, 1.0 / settings[0])) - cc
    gamma_matrix = np.linalg.inv(gamma_inverse)
    return at @ gamma_matrix, gamma_matrix, m @ gamma_matrix, (m - me) @ gamma_matrix, alpha, gsum


#: the Rosenbrock methods by name (:func:`fuzzymbs.mbs.integrate.simulate`'s integrator)
METHODS = {
    "ros34pw2": COEFFICIENTS,
    "rodas4": rodas4_coefficients(RODAS4_JACOBIAN_AGE),
}
