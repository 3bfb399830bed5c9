"""Where the planar engine's time goes, and how its index-1 solve behaves at singular
positions: the figures docs/benchmarks.md ("Mechanisms") and docs/mechanisms.md
("Singular configurations") quote.

    python benchmarks/planar_mechanism_costs.py

1. One evaluation of the constrained accelerations of the registered ``slider-crank``
   (15 coordinates, 9 joint rows) at its start, timed over 50,000 calls inside a
   compiled loop, with its parts: the body terms, the joint terms, the force terms;
   the steps its run at the defaults takes; and the largest eigenvalue modulus with
   the steps, time and error of both Runge-Kutta pairs at rtol 1e-3 to 1e-7 (what
   limits Dormand-Prince 5(4)'s steps, and why DOP853 is the default).
2. The N-four-bar (IFToMM A02, :mod:`tests.mbs.planar.test_n_four_bar`'s mechanism) over
   20 s at several tolerances: whether the run passes its singular positions, and B0's
   largest error against the exact one-degree-of-freedom motion.
3. At a crank angle delta from the singular position of the one-window four-bar, the
   change of the accelerations when the state is off the joints by 1e-12 (the
   amplification a Runge-Kutta stage meets there).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numba as nb
import numpy as np

from fuzzymbs.mbs.planar import kernels, simulate
from fuzzymbs.mbs.planar.linearization import linearize
from fuzzymbs.mbs.planar.system import pack_batch
from fuzzymbs.models.mechanisms.outputs import deflection_in_frame
from fuzzymbs.models.mechanisms.slider_crank import slider_crank

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests" / "mbs" / "planar"))
from test_n_four_bar import n_four_bar, parallelogram_reference

CALLS = 50_000


@nb.njit
def _accelerations(count, x, layout, data, user, n, c):
    system = np.empty((n + c, n + c))
    solution = np.empty(n + c)
    for _ in range(count):
        kernels.accelerations(0.01, x[:n], x[n:], layout, data, user, system, solution)
    return solution


@nb.njit
def _bodies(count, x, layout, data, n):
    mass = np.zeros((n, n))
    forces = np.zeros(n)
    for _ in range(count):
        mass[:, :] = 0.0
        kernels.body_terms(layout[0], data, x[:n], x[n:], mass, forces)
    return forces


@nb.njit
def _joints(count, x, layout, data, n, c):
    jac = np.zeros((c, n))
    rows = [np.empty(c) for _ in range(4)]
    for _ in range(count):
        jac[:, :] = 0.0
        kernels.joint_terms(
            0.01, layout, data, x[:n], x[n:], jac, rows[0], rows[1], rows[2], rows[3]
        )
    return jac


@nb.njit
def _forces(count, x, layout, data, user, n):
    forces = np.zeros(n)
    for _ in range(count):
        kernels.force_terms(0.01, layout, data, x[:n], x[n:], user, forces)
    return forces


def evaluation_cost() -> dict[str, float]:
    """Microseconds per call of each part, the smaller of two timed repeats."""
    model = slider_crank()
    batch = pack_batch([model.build(model.sample_parameters({})[0])])
    layout, data, x = batch.layout.arrays(), batch.data[0], batch.initial[0].copy()
    n, c = (int(s) for s in batch.layout.sizes)
    calls = {
        "accelerations": lambda k: _accelerations(k, x, layout, data, batch.user_force, n, c),
        "body terms": lambda k: _bodies(k, x, layout, data, n),
        "joint terms": lambda k: _joints(k, x, layout, data, n, c),
        "force terms": lambda k: _forces(k, x, layout, data, batch.user_force, n),
    }
    out = {}
    for name, call in calls.items():
        call(10)  # compile
        best = np.inf
        for _ in range(2):
            start = time.perf_counter()
            call(CALLS)
            best = min(best, time.perf_counter() - start)
        out[name] = best / CALLS * 1e6
    return out


def four_bar_tolerances() -> list[tuple[int, float, str]]:
    """(windows, rtol, outcome) over 20 s: B0's largest error [m] or the failure."""
    rows = []
    times = np.linspace(0.0, 20.0, 401)
    for windows, rtol in [
        (1, 1e-10),
        (2, 1e-8),
        (2, 1e-9),
        (4, 1e-5),
        (4, 1e-6),
        (4, 1e-7),
        (4, 3e-8),
        (40, 1e-6),
    ]:
        result = simulate(n_four_bar(windows), times, rtol=rtol, atol=rtol * 1e-2)
        if result.failed[0]:
            rows.append((windows, rtol, result.failure(0)))
            continue
        angle = result.coordinates("crank0")[0, :, 2]
        phi = parallelogram_reference(windows, times)
        error = max(
            np.abs(np.cos(angle) - np.cos(phi)).max(), np.abs(np.sin(angle) - np.sin(phi)).max()
        )
        rows.append((windows, rtol, f"B0 within {error:.2g} m"))
    return rows


def singular_amplification() -> list[tuple[float, float]]:
    """(delta, change of the crank's angular acceleration) for a 1e-12 offset."""
    batch = pack_batch([n_four_bar(1)])
    layout, data = batch.layout.arrays(), batch.data[0]
    n, c = (int(s) for s in batch.layout.sizes)
    system, solution = np.empty((n + c, n + c)), np.empty(n + c)
    rows = []
    for delta in (1e-1, 1e-3, 1e-5, 1e-7):
        rate = -5.0
        # bodies: crank0, crank1, coupler0; the parallelogram at crank angle delta
        z = np.array([0, 0, delta, 1, 0, delta, np.cos(delta), np.sin(delta), 0.0])
        v = np.array([0, 0, rate, 0, 0, rate, -np.sin(delta) * rate, np.cos(delta) * rate, 0.0])
        answers = []
        for offset in (0.0, 1e-12):
            zz, vv = z.copy(), v.copy()
            vv[5] += offset
            zz[7] += offset
            kernels.accelerations(0.0, zz, vv, layout, data, batch.user_force, system, solution)
            answers.append(solution[2])
        rows.append((delta, abs(answers[1] - answers[0])))
    return rows


def step_limit() -> tuple[float, list[tuple[str, float, int, int, float, float]]]:
    """The slider-crank's largest eigenvalue modulus [rad/s] (linearised at rest), and for
    each pair and rtol (atol = rtol / 100) its steps over the default run, the time of one
    run [s] (the smaller of two) and the midpoint deflection's largest error over the run,
    of its peak, against DOP853 at rtol 1e-12."""
    model = slider_crank()
    mechanism = model.build(model.sample_parameters({})[0])
    largest = float(np.abs(linearize(mechanism).eigenvalues).max())
    times = model.times
    reference = simulate([mechanism], times, rtol=1e-12, atol=1e-14, method="dop853")
    exact = deflection_in_frame(reference, "rod", "midpoint")[0]
    rows = []
    for method in ("dopri5", "dop853"):
        for rtol in (1e-3, 1e-4, 1e-5, 1e-6, 1e-7):
            seconds = np.inf
            for _ in range(2):
                start = time.perf_counter()
                run = simulate([mechanism], times, rtol=rtol, atol=rtol * 1e-2, method=method)
                seconds = min(seconds, time.perf_counter() - start)
            error = np.abs(deflection_in_frame(run, "rod", "midpoint")[0] - exact).max()
            rows.append(
                (
                    method,
                    rtol,
                    int(run.accepted[0]),
                    int(run.rejected[0]),
                    seconds,
                    float(error / np.abs(exact).max()),
                )
            )
    return largest, rows


def main() -> None:
    print("one evaluation of the slider-crank's constrained accelerations [us]:")
    for name, value in evaluation_cost().items():
        print(f"  {name:15s} {value:6.2f}")
    run = slider_crank().run({})
    print(f"  steps at the defaults: {run.accepted[0]} accepted, {run.rejected[0]} rejected")
    largest, rows = step_limit()
    print(f"  largest eigenvalue modulus {largest:.0f} rad/s; by pair and tolerance:")
    for method, rtol, accepted, rejected, seconds, error in rows:
        print(
            f"    {method} rtol {rtol:g}: {accepted} accepted, {rejected} rejected, "
            f"{seconds * 1e3:.1f} ms, midpoint deflection within {error:.2g} of its peak"
        )
    print("N-four-bar over 20 s:")
    for windows, rtol, outcome in four_bar_tolerances():
        print(f"  N = {windows:2d}, rtol {rtol:g}: {outcome}")
    print("one-window four-bar, a state 1e-12 off the joints, delta from the singular position:")
    for delta, change in singular_amplification():
        print(f"  delta {delta:g}: the crank's angular acceleration moves by {change:.2g} rad/s^2")


if __name__ == "__main__":
    main()
