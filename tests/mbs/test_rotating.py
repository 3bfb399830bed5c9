"""Rotating elastic bodies: gyroscopic splitting, spin softening, centrifugal and Euler loads.

Reference: a point mass m on springs in a frame rotating at Omega about y
(e.g. Meirovitch, Methods of Analytical Dynamics, 1970, ch. 4; also any
rotordynamics text): in rotating coordinates
    x'' - 2 Omega z'' ... i.e.  q'' + 2 Omega G q' + (diag(w1^2, w2^2) - Omega^2 I) q = 0,
whose eigenvalues lambda = i w satisfy
    w^4 - (w1^2 + w2^2 + 2 Omega^2) w^2 + (w1^2 - Omega^2)(w2^2 - Omega^2) = 0,
(w = w0 +- Omega for w1 = w2 = w0). A mass at radius R0 on a radial spring k
deflects by u = m Omega^2 R0 / (k - m Omega^2); spinning up at Omega' it lags
tangentially by u = Omega' R0 / (k/m - Omega^2).
"""

import numpy as np
import pytest

from fuzzymbs.mbs.bodies import RotatingBody
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.linearize import eigenanalysis, steady_state
from fuzzymbs.mbs.lumped import lumped_modal_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.profiles import TimeProfile
from fuzzymbs.mbs.system import NodeDisplacement, System

MASS = 0.5


def point_mass(kx: float, kz: float, position=(0.0, 0.0, 0.0), free=(0, 2)):
    stiff = np.diag([kx, 0.0, kz])
    return lumped_modal_body("pm", [position], [MASS], stiff, free_dofs=list(free))


def closed_form_frequencies(w1: float, w2: float, omega: float) -> np.ndarray:
    b = w1**2 + w2**2 + 2 * omega**2
    c = (w1**2 - omega**2) * (w2**2 - omega**2)
    s = np.roots([1.0, -b, c])
    return np.sort(np.sqrt(s.real))


@pytest.mark.parametrize(("kx", "kz"), [(5000.0, 5000.0), (5000.0, 8000.0)])
def test_gyroscopic_splitting_and_spin_softening(kx, kz):
    system = System()
    system.add_body(RotatingBody(point_mass(kx, kz), "y", speed=Parameter("omega", 0.0)))
    omegas = np.array([0.0, 30.0, 60.0])
    result = eigenanalysis(system, {"omega": omegas})
    w1, w2 = np.sqrt(kx / MASS), np.sqrt(kz / MASS)
    for i, om in enumerate(omegas):
        lam = result.eigenvalues[i]
        freq = np.sort(lam.imag[lam.imag > 0])
        ref = closed_form_frequencies(w1, w2, om)
        np.testing.assert_allclose(freq, ref, rtol=1e-9)  # closed form, see module doc
        np.testing.assert_allclose(lam.real, 0.0, atol=1e-9 * abs(lam).max())
    if kx == kz:  # isotropic: w0 -+ Omega exactly
        lam = result.eigenvalues[1]
        np.testing.assert_allclose(
            np.sort(lam.imag[lam.imag > 0]), [w1 - 30.0, w1 + 30.0], rtol=1e-9
        )


@pytest.mark.parametrize("kernel", ["samples", "lanes"])
def test_centrifugal_deflection_static_and_dynamic(kernel):
    radius, k, om = 0.2, 5000.0, 40.0
    body = point_mass(k, 0.0, position=(radius, 0.0, 0.0), free=(0,))
    system = System()
    system.add_body(RotatingBody(body, "y", speed=om))
    u_static = MASS * om**2 * radius / (k - MASS * om**2)
    st = steady_state(system)
    assert st.converged.all()
    assert st.x[0, 0] / np.sqrt(MASS) == pytest.approx(u_static, rel=1e-9)
    # from rest: u(t) = u_s (1 - cos(w_e t)), w_e^2 = k/m - Omega^2 (undamped, linear)
    res = simulate(
        system,
        t_end=0.2,
        dt=1e-4,
        record_interval=1e-3,
        outputs={"u": NodeDisplacement("pm", 0, "x")},
        kernel=kernel,
    )
    w_e = np.sqrt(k / MASS - om**2)
    ref = u_static * (1 - np.cos(w_e * res.time))
    # RK4 global error ~ (w dt)^4 w t / 120 ~ 1e-8 relative here
    np.testing.assert_allclose(res.outputs["u"][0], ref, atol=1e-7 * u_static)


def test_euler_load_of_a_speed_ramp():
    radius, k = 0.2, 5000.0
    body = point_mass(0.0, k, position=(radius, 0.0, 0.0), free=(2,))
    system = System()
    # Omega(t) = 20 t rad/s for t in [0, 1]: angular acceleration 20 rad/s^2
    system.add_body(RotatingBody(body, "y", speed=20.0, profile=TimeProfile([0.0, 1.0], [0, 1])))
    st = steady_state(system, t_lin=0.5)
    u = st.x[0, 0] / np.sqrt(MASS)
    assert u == pytest.approx(20.0 * radius / (k / MASS - 10.0**2), rel=1e-9)
