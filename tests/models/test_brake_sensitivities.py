"""The disc brake's outputs' derivatives (``brake(samples, wrt=names)``): the model
protocol, against central differences of whole runs, bit-identical outputs and per-lane
independence. The sensitivities' method is checked against closed forms in
tests/mbs/test_sensitivities.py; here the brake's contact, friction and prescribed
rotation (the disc speed) are differentiated.
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.system import Coordinate
from fuzzymbs.models.brake import DEFAULTS, DiscBrake
from fuzzymbs.tolerance import Tolerance

SIGNALS = ("y_lpad", "y_upad", "y_cali")


@pytest.fixture(scope="module")
def brake() -> DiscBrake:
    return DiscBrake(t_end=1e-4, record_interval=1e-5)


def test_brake_declares_and_returns_gradients(brake):
    # every brake parameter is a column of the kernel's parameter rows (the disc speed
    # through the prescribed rotation), so all six are differentiable
    assert set(brake.differentiable) == set(DEFAULTS)
    rk4 = DiscBrake(t_end=1e-4, integrator="rk4")  # central differences on its steps
    assert set(rk4.differentiable) == set(DEFAULTS) and rk4.gradient_cost == 2.0
    samples = {"nodal_force": np.array([16e3, 16.16e3]), "disc_speed": np.array([1.0, 1.1])}
    plain = brake(samples)
    wrt = ["disc_speed", "pad_spring_stiffness", "nodal_force"]
    asked = brake(samples, wrt=wrt)
    for name in SIGNALS:
        np.testing.assert_array_equal(asked[name], plain[name])
        gradient = asked["gradients"][name]
        assert gradient.shape == (2, brake.coords["time"].size, 3)
        assert np.isfinite(gradient).all()
        np.testing.assert_array_equal(gradient[:, 0], 0.0)  # the initial state is fixed
    # the pads are pressed harder with F_n (dy_lpad/dF_n > 0 once the contact carries)
    assert (asked["gradients"]["y_lpad"][:, -1, 2] > 0).all()
    with pytest.raises(InvalidParameterError, match=r"\['speed'\].*disc_speed"):
        brake(samples, wrt=["speed"])


#: bounds of the comparison with central differences: 3x the measured errors; 1e-4 (6x
#: the largest of the others) else
BOUNDS = {
    ("y_lpad", "pad_spring_stiffness"): 5e-3,
    ("y_lpad", "disc_speed"): 1.5e-2,
    ("y_cali", "disc_speed"): 1e-9,
}
#: derivatives judged on another's peak: the caliper's to the disc speed on the pads'
JUDGED_ON = {("y_cali", "disc_speed"): ("y_lpad", "disc_speed")}


@pytest.mark.slow  # about 15 s: the reference's runs at rtol 1e-6
def test_brake_derivatives_against_central_differences():
    # reference: central differences (1e-3 relative) of whole runs at rtol 1e-6 on one
    # shared step sequence (the nominal sample's, the same steps for both runs) over the
    # first 0.3 ms (contact closing, the first slip reversals); the sensitivities at rtol
    # 1e-4 on their own steps. Measured (largest error over time relative to each
    # derivative's peak): pads k 1.5e-3, F_n 1.7e-5, omega 4.3e-3; caliper k 8.1e-6, k_c
    # 3.0e-7, F_n 8.1e-6 (an AVX-512 host; on an AVX2 host 1.3e-3, 7.0e-5, 4.2e-3, 2.9e-5,
    # 6.6e-6, 4.9e-6). The caliper's derivative to omega is the pads' asymmetry, 7.5e-15 m
    # per rad/s this early, 8e-9 of the pads' derivative to omega: its error, 1.2e-2 and
    # 4.8e-2 of its own peak on the two hosts and not falling with the sensitivities' rtol
    # (1.7e-2 at 1e-5, 2.6e-2 at 1e-6), is round-off on the scale of the pads' derivative
    # (3.8e-10 of it), so it is judged there. The pads' derivative to k_c (1e-16 m per N/m)
    # is left out: the differences' rounding there is a per cent of it. Bounds: 3x.
    t_end = 3e-4
    compiled = DiscBrake(t_end=t_end).compiled
    outputs = {"y_lpad": Coordinate("lower_pad", 0), "y_cali": Coordinate("caliper", 0)}
    nominal = {name: DEFAULTS[name] for name in ("pad_spring_stiffness", "nodal_force")}
    nominal["caliper_spring_stiffness"] = DEFAULTS["caliper_spring_stiffness"]
    nominal["disc_speed"] = DEFAULTS["disc_speed"]
    names = tuple(nominal)
    common = {"t_end": t_end, "dt": 1e-6, "record_interval": 1e-5, "outputs": outputs}
    ros = {"integrator": "ros34pw2"}
    columns = {name: np.array([value]) for name, value in nominal.items()}
    result = simulate(
        compiled, columns, tolerance=Tolerance(1e-4), sensitivities=names, **ros, **common
    )
    log = simulate(compiled, columns, tolerance=Tolerance(1e-6), log_steps=True, **ros, **common)
    rows = {name: [] for name in names}
    for name in names:
        for sign in (1.0, -1.0):
            for other in names:
                rows[other].append(nominal[other] * (1.0 + sign * 1e-3 if other == name else 1.0))
    runs = simulate(
        compiled,
        {name: np.array(values) for name, values in rows.items()},
        tolerance=Tolerance(1e-6),
        step_sequence=log.step_times,
        jacobian_renewals=log.step_renewals,
        **ros,
        **common,
    )
    references = {}
    for output in outputs:
        y = runs.outputs[output].reshape(len(names), 2, -1)
        for k, name in enumerate(names):
            references[output, name] = (y[k, 0] - y[k, 1]) / (2e-3 * nominal[name])
    for (output, name), reference in references.items():
        if (output, name) == ("y_lpad", "caliper_spring_stiffness"):
            continue
        k = names.index(name)
        error = np.abs(result.gradients[output][0, :, k] - reference).max()
        bound = BOUNDS.get((output, name), 1e-4)
        scale = np.abs(references[JUDGED_ON.get((output, name), (output, name))]).max()
        assert error < bound * scale, (output, name)


@pytest.mark.slow  # the brake's lanes: about 5 s
def test_brake_gradients_do_not_depend_on_the_block():
    # six samples that differ in every parameter (frictionless and fast-turning lanes
    # beside ordinary ones: the per-lane contact path), alone and packed with others:
    # derivatives bit for bit the same, outputs the same with and without them
    rng = np.random.default_rng(5)
    n = 6
    samples = {
        "pad_spring_stiffness": 200e3 * rng.uniform(0.8, 1.2, n),
        "caliper_spring_stiffness": 1e3 * rng.uniform(0.8, 1.2, n),
        "nodal_force": 16e3 * rng.uniform(0.9, 1.1, n),
        "disc_speed": np.where(np.arange(n) % 2 == 0, 1.0, 400.0) * rng.uniform(1.0, 1.1, n),
        "penalty_stiffness": 1e8 * rng.uniform(0.8, 1.2, n),
        "friction_coefficient": np.where(np.arange(n) == 2, 0.0, rng.uniform(0.3, 0.9, n)),
    }
    wrt = ["friction_coefficient", "disc_speed", "penalty_stiffness"]
    alone = DiscBrake(t_end=1e-4, record_interval=1e-5, rtol=1e-3, kernel="samples")
    packed = DiscBrake(t_end=1e-4, record_interval=1e-5, rtol=1e-3)
    reference = alone(samples, wrt=wrt)
    assert not reference["failed"].any()
    order = np.array([3, 0, 5, 1, 4, 2])
    picked = {name: values[order] for name, values in samples.items()}
    plain = packed(picked)
    run = packed(picked, wrt=wrt)
    for name in SIGNALS:
        np.testing.assert_array_equal(run[name], reference[name][order])
        np.testing.assert_array_equal(run[name], plain[name])
        np.testing.assert_array_equal(run["gradients"][name], reference["gradients"][name][order])


@pytest.mark.slow  # the shared steps' reference runs: about 10 s
def test_brake_gradients_on_shared_steps():
    # on shared steps the outputs are those of the plain call bit for bit (the modal
    # sample's kept logging run included), the gradients those of simulate on the
    # sequence with the logging run's Jacobians, and a run kept by deviations without
    # gradients is run again for them
    brake = DiscBrake(t_end=1e-4, record_interval=1e-5, rtol=1e-3)
    shared = brake.share_steps({"nodal_force": 16e3, "pad_spring_stiffness": 2e5})
    samples = {"nodal_force": np.array([16e3, 16.16e3]), "pad_spring_stiffness": [2e5, 1.8e5]}
    shared.deviations(samples)  # keeps the runs, without gradients
    plain = shared(samples)
    asked = shared(samples, wrt=["nodal_force"])
    simulation = shared.simulation
    direct = simulation.simulate(
        samples,
        step_sequence=simulation.shared.sequence,
        jacobian_renewals=simulation.shared.renewals,
        logged_jacobians=simulation.shared.jacobians,
        sensitivities=("nodal_force",),
    )
    for name in SIGNALS:
        np.testing.assert_array_equal(asked[name], plain[name])
        np.testing.assert_array_equal(asked["gradients"][name], direct.gradients[name])
    kept = shared.deviations(samples, wrt=["nodal_force"])  # kept now with the gradients
    again = shared(samples, wrt=["nodal_force"])
    for name in SIGNALS:
        np.testing.assert_array_equal(kept["gradients"][name], asked["gradients"][name])
        np.testing.assert_array_equal(again["gradients"][name], asked["gradients"][name])
