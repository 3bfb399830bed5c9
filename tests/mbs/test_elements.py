"""Springs (node-node, 3D), modal damping and forces on rotating bodies vs closed forms."""

import numpy as np
import pytest

from fuzzymbs.mbs.bodies import FixedBody, RotatingBody, TranslatingBody, rotation_matrix
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import evaluate_rhs, simulate
from fuzzymbs.mbs.linearize import eigenanalysis
from fuzzymbs.mbs.lumped import lumped_modal_body, rigid_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.profiles import TimeProfile
from fuzzymbs.mbs.system import Coordinate, System


def test_node_to_node_spring_two_masses():
    # two free masses joined by k along y, one held by k_g to ground:
    # M = diag(m1, m2), K = [[k + k_g, -k], [-k, k]] -> generalised eigenvalues (closed 2x2)
    m1, m2, k, kg = 2.0, 0.5, 3e4, 1e3
    system = System()
    system.add_body(TranslatingBody(rigid_body("a", m1), ["y"]))
    system.add_body(TranslatingBody(rigid_body("b", m2, [(0.0, 0.1, 0.0)]), ["y"]))
    system.add(Spring("ab", "a", [0], "b", [0], stiffness=Parameter("k", k), direction="y"))
    system.add(Spring("ag", "a", [0], stiffness=kg, direction="y"))
    result = eigenanalysis(system, {"k": np.array([k, 2 * k])})
    for i, kk in enumerate((k, 2 * k)):
        stiff = np.array([[kk + kg, -kk], [-kk, kk]])
        ref = np.sort(np.sqrt(np.linalg.eigvals(np.linalg.solve(np.diag([m1, m2]), stiff))))
        lam = result.eigenvalues[i]
        np.testing.assert_allclose(np.sort(lam.imag[lam.imag > 0]), ref, rtol=1e-9)


def test_isotropic_3d_spring():
    # a mass free in x, y, z on an isotropic bushing k: three modes at sqrt(k/m)
    system = System()
    system.add_body(TranslatingBody(rigid_body("m", 0.8), ["x", "y", "z"]))
    system.add(Spring("bush", "m", [0], stiffness=2e3))
    lam = eigenanalysis(system).eigenvalues[0]
    np.testing.assert_allclose(lam.imag[lam.imag > 0], np.sqrt(2e3 / 0.8), rtol=1e-9)


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_modal_damping_free_decay(kernel):
    # one mode, omega = 100 rad/s, zeta = 0.05: q(t) = q0 e^(-zeta w t) (cos w_d t
    # + zeta / sqrt(1 - zeta^2) sin w_d t), w_d = w sqrt(1 - zeta^2)
    body = lumped_modal_body("osc", [(0, 0, 0)], [1.0], np.diag([1e4, 0, 0]), free_dofs=[0])
    system = System()
    system.add_body(FixedBody(body, damping_ratio=0.05))
    x0 = np.array([1e-3, 0.0])
    res = simulate(
        system,
        t_end=0.2,
        dt=1e-4,
        record_interval=1e-3,
        initial_state=x0,
        outputs={"q": Coordinate("osc")},
        kernel=kernel,
    )
    w, z = 100.0, 0.05
    wd = w * np.sqrt(1 - z**2)
    t = res.time
    ref = 1e-3 * np.exp(-z * w * t) * (np.cos(wd * t) + z / np.sqrt(1 - z**2) * np.sin(wd * t))
    np.testing.assert_allclose(res.outputs["q"][0], ref, atol=1e-9)
    # the linearisation gives -zeta w +- i w_d
    lam = eigenanalysis(system).eigenvalues[0]
    lam = lam[np.argsort(lam.imag)]
    np.testing.assert_allclose(lam, [-z * w - 1j * wd, -z * w + 1j * wd], rtol=1e-9)


@pytest.mark.parametrize("t", [0.0, 0.3, 1.7])
def test_inertial_force_on_rotating_body(t):
    # generalised force of an inertial-frame force F d on node k: Psi_k^T A(theta)^T F d
    # (A from Rodrigues in NumPy), compared with the kernel's three-vector form
    rng = np.random.default_rng(3)
    nodes = rng.normal(size=(3, 3))
    stiff = np.diag(rng.uniform(1e3, 2e3, 9))
    body = lumped_modal_body("rot", nodes, [1.0, 2.0, 0.5], stiff)
    axis = np.array([0.3, 1.0, -0.2]) / np.linalg.norm([0.3, 1.0, -0.2])
    direction = np.array([1.0, -0.5, 0.25])
    speed = 0.7
    system = System()
    system.add_body(RotatingBody(body, axis, speed=speed, profile=TimeProfile([0, 1], [1, 2])))
    system.add(NodalForce("f", "rot", [0, 2], direction, 5.0))
    compiled = system.compile()
    params = compiled.parameters.values({})
    n = compiled.n_dofs
    accel = evaluate_rhs(compiled, params, np.array([0]), np.array([t]), np.zeros((1, 2 * n)))
    # theta = speed * int_0^t p with p = 1 + t on [0, 1], 2 after; Omega, Omega' from p
    # (the slope is right-continuous: p'(0) = 1, p'(1) = 0)
    theta = speed * (t + t * t / 2) if t <= 1 else speed * (1.5 + 2 * (t - 1))
    omega = speed * (1 + t if t <= 1 else 2.0)
    alpha = speed * (1.0 if t < 1 else 0.0)
    a_mat = rotation_matrix(axis, theta)
    unit = direction / np.linalg.norm(direction)
    q_force = sum(body.mode_shapes[k].T @ a_mat.T @ (5.0 * unit) for k in (0, 2))
    mats = system.bodies["rot"].rotated_matrices()
    expected = q_force - omega**2 * mats["centrifugal_load"] - alpha * mats["euler_load"]
    np.testing.assert_allclose(accel[0, n:], expected, rtol=1e-10, atol=1e-10)
