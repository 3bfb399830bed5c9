"""Forward sensitivities of the Rosenbrock kernel: the outputs' derivatives with respect to
the bound parameters, integrated with the state on its steps (``simulate(...,
sensitivities=names)``, ``model(samples, wrt=names)``).

References: the closed form of a damped oscillator under a step force, differentiated by
complex step (exact to rounding); central differences of whole brake runs on one shared
step sequence at a tight tolerance (smooth in the parameters). The outputs with and
without sensitivities, and a sample's derivatives alone and beside other samples, are
compared bit for bit. RK4, which integrates no sensitivities, gives its models'
gradients as central differences on its fixed steps
(:func:`fuzzymbs.mbs.central_differences.on_fixed_steps`): against the same closed
form, and against ROS34PW2's forward sensitivities on the sliding block.
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody
from fuzzymbs.mbs.contact import PenaltyContact, PolarChart
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import SimulationModel, simulate
from fuzzymbs.mbs.lumped import rigid_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.system import Coordinate, System
from fuzzymbs.tolerance import Tolerance

from .systems import annulus_nodes

MASS = 2.0  # kg
OSCILLATOR = {"stiffness": 800.0, "damping": 8.0, "force": 10.0}  # N/m, N s/m, N: zeta 0.1


def oscillator() -> System:
    """A mass on a spring and damper to ground, pushed from rest by a constant force."""
    system = System()
    system.add_body(TranslatingBody(rigid_body("mass", MASS), ["x"]))
    system.add(
        Spring(
            "spring",
            "mass",
            [0],
            stiffness=Parameter("stiffness", OSCILLATOR["stiffness"]),
            damping=Parameter("damping", OSCILLATOR["damping"]),
            direction="x",
        )
    )
    system.add(NodalForce("push", "mass", [0], "x", Parameter("force", OSCILLATOR["force"])))
    return system


def step_response(t, stiffness, damping, force):
    """x(t) of m x'' + c x' + k x = F from rest (underdamped; complex arguments allowed)."""
    w = np.sqrt(stiffness / MASS)
    zeta = damping / (2.0 * np.sqrt(stiffness * MASS))
    wd = w * np.sqrt(1.0 - zeta**2)
    decay = np.exp(-zeta * w * t)
    return (
        force
        / stiffness
        * (1.0 - decay * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t)))
    )


def sliding_block() -> System:
    """A block pressed (``press``) on a turning belt with friction (``mu``), held
    tangentially by a spring (``k``): contact, sliding friction and three parameters in
    one tiny system (the belt of Hoffmann's model, tests/mbs/systems.py)."""
    radius = 100.0
    system = System()
    belt = rigid_body("belt", 1.0, annulus_nodes(0.8 * radius, 1.2 * radius, 3, 64))
    system.add_body(RotatingBody(belt, "y", speed=1e-3))
    block = rigid_body("block", 1.0)
    system.add_body(TranslatingBody(block, ["z", "y"], origin=(radius, 0.0, 0.0)))
    system.add(Spring("hold", "block", [0], stiffness=Parameter("k", 2e4), direction="z"))
    system.add(Spring("lift", "block", [0], stiffness=1e4, damping=2.0, direction="y"))
    system.add(NodalForce("press", "block", [0], "y", Parameter("press", -100.0)))
    system.add(
        PenaltyContact(
            "belt-contact",
            "block",
            [0],
            "belt",
            np.arange(belt.n_nodes),
            PolarChart("y", "x"),
            penalty=2e4,
            friction=Parameter("mu", 0.3),
            regularization_velocity=1e-3,
            normal="y",
        )
    )
    return system


@pytest.fixture(scope="module")
def spring_mass():
    return oscillator().compile()


@pytest.fixture(scope="module")
def block():
    return sliding_block().compile()


BLOCK_OUTPUTS = {"z": Coordinate("block", 0), "y": Coordinate("block", 1)}


def _block_samples(n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "k": 2e4 * rng.uniform(0.7, 1.3, n),
        "press": -100.0 * rng.uniform(0.7, 1.3, n),
        "mu": rng.uniform(0.1, 0.6, n),
    }


def _run_block(compiled, samples, order, **options):
    picked = {name: values[order] for name, values in samples.items()}
    settings = {"t_end": 0.02, "dt": 1e-4, "record_interval": 1e-3, "outputs": BLOCK_OUTPUTS}
    settings.update(integrator="ros34pw2", tolerance=Tolerance(1e-4))
    settings.update(options)
    return simulate(compiled, picked, **settings)


def test_oscillator_derivatives_against_the_closed_form(spring_mass):
    # reference: the step response's closed form, differentiated by complex step (exact
    # to rounding). Measured with ROS34PW2, largest error over 0.5 s relative to each
    # derivative's peak, rtol 1e-5 / 1e-7:
    # stiffness 1.5e-4 / 1.4e-4, damping 6.9e-5 / 4.6e-5 (the differences' O(delta) error:
    # the spring force k x is bilinear in the parameter and the state), force 5.7e-6 /
    # 5.8e-8 (linear in the force: the state's own error). Bounds 3x those at 1e-5.
    t = np.arange(501) * 1e-3
    names = ("stiffness", "damping", "force")
    reference = np.empty((t.size, 3))
    for k, name in enumerate(names):
        moved = {**OSCILLATOR, name: OSCILLATOR[name] + 1e-30j}
        reference[:, k] = step_response(t, **moved).imag / 1e-30
    result = simulate(
        spring_mass,
        {name: np.array([value]) for name, value in OSCILLATOR.items()},
        t_end=0.5,
        dt=1e-3,
        outputs={"x": Coordinate("mass")},
        integrator="ros34pw2",
        tolerance=Tolerance(1e-5),
        sensitivities=names,
    )
    assert result.gradients["x"].shape == (1, t.size, 3)
    assert result.gradient_parameters == names
    error = np.abs(result.gradients["x"][0] - reference).max(axis=0) / np.abs(reference).max(axis=0)
    np.testing.assert_array_less(error, [5e-4, 2.5e-4, 2e-5])
    # x is linear in the force from rest, so dx/dF = x / F for the discrete scheme itself
    # (a linear W-method, an exact difference): to rounding
    np.testing.assert_allclose(
        result.gradients["x"][0, :, 2],
        result.outputs["x"][0] / OSCILLATOR["force"],
        rtol=0,
        atol=1e-9 * np.abs(reference[:, 2]).max(),
    )


def test_rodas4_sensitivities_converge_at_first_order(spring_mass):
    # RODAS4 is not a W-method: with the block-diagonal Jacobian of state and
    # sensitivities (the parameter derivative of f_x left out) its sensitivities lose
    # its order. Measured on the oscillator (stiffness, relative to the peak): 1.2e-2 /
    # 3.5e-3 / 1.0e-3 at rtol 1e-3 / 1e-5 / 1e-7 (28 / 74 / 226 steps), while the state
    # is within 8e-5 / 1.3e-6 / 1.5e-8. Checked: they converge, a decade per 3x steps.
    t = np.arange(501) * 1e-3
    moved = {**OSCILLATOR, "stiffness": OSCILLATOR["stiffness"] + 1e-30j}
    reference = step_response(t, **moved).imag / 1e-30
    errors = []
    for rtol in (1e-3, 1e-5, 1e-7):
        result = simulate(
            spring_mass,
            {},
            t_end=0.5,
            dt=1e-3,
            outputs={"x": Coordinate("mass")},
            integrator="rodas4",
            tolerance=Tolerance(rtol),
            sensitivities=("stiffness",),
        )
        errors.append(np.abs(result.gradients["x"][0, :, 0] - reference).max())
    errors = np.array(errors) / np.abs(reference).max()
    assert errors[0] < 3e-2
    assert errors[2] < 3e-3
    assert errors[0] > 3 * errors[1] > 9 * errors[2]


@pytest.mark.parametrize("integrator", ["ros34pw2", "rodas4"])
def test_outputs_bit_for_bit_with_and_without_sensitivities(block, integrator):
    # the sensitivities only read the state's arithmetic: the same outputs, steps and
    # work of the state, on the samples' own steps and on a shared sequence
    samples = _block_samples(5, seed=1)
    order = np.arange(5)
    plain = _run_block(block, samples, order, integrator=integrator, log_steps=True)
    with_sens = _run_block(block, samples, order, integrator=integrator, sensitivities=("mu", "k"))
    assert not plain.failed.any()
    assert plain.gradients is None and with_sens.gradients["z"].shape == (5, 21, 2)
    for name in BLOCK_OUTPUTS:
        np.testing.assert_array_equal(with_sens.outputs[name], plain.outputs[name])
    np.testing.assert_array_equal(with_sens.step_counts, plain.step_counts)
    np.testing.assert_array_equal(with_sens.work_counts, plain.work_counts)
    assert (with_sens.sensitivity_rhs > 0).all()
    shared = {"step_sequence": plain.step_times, "jacobian_renewals": plain.step_renewals}
    replay = _run_block(block, samples, order, integrator=integrator, **shared)
    replay_sens = _run_block(
        block, samples, order, integrator=integrator, sensitivities=("press",), **shared
    )
    for name in BLOCK_OUTPUTS:
        np.testing.assert_array_equal(replay_sens.outputs[name], replay.outputs[name])
    # premise: the samples took different steps (one shared step would hide the lanes)
    assert len(set(plain.step_counts[:, 0].tolist())) > 2


def test_a_samples_derivatives_do_not_depend_on_its_block(block):
    # each sample alone in a block (its lanes repeating it) against packed, permuted and
    # chunked batches: the derivatives bit for bit the same
    samples = _block_samples(7, seed=4)
    names = ("k", "press", "mu")
    alone = _run_block(block, samples, np.arange(7), kernel="samples", sensitivities=names)
    assert not alone.failed.any()
    permutation = np.random.default_rng(3).permutation(7)
    for rows, options in (
        (np.arange(7), {}),
        (permutation, {}),
        (permutation[::-1], {"chunk_size": 3}),
    ):
        packed = _run_block(block, samples, rows, sensitivities=names, **options)
        for name in BLOCK_OUTPUTS:
            np.testing.assert_array_equal(packed.gradients[name], alone.gradients[name][rows])
        np.testing.assert_array_equal(packed.sensitivity_rhs, alone.sensitivity_rhs[rows])


def test_a_failed_sample_leaves_its_block_mates_derivatives_alone(block):
    # a sample pressed beyond the displacement bound fails (NaN derivatives); its lane
    # then repeats a healthy one, and the others' derivatives stay bit for bit their own
    samples = _block_samples(4, seed=6)
    samples["press"][1] = -1e7  # N: 500 m into the belt, beyond the 1 m bound at once
    names = ("mu", "press")
    alone = _run_block(block, samples, np.arange(4), kernel="samples", sensitivities=names)
    packed = _run_block(block, samples, np.arange(4), sensitivities=names)
    assert alone.failed.tolist() == packed.failed.tolist() == [False, True, False, False]
    for name in BLOCK_OUTPUTS:
        assert np.isnan(packed.gradients[name][1]).all()
        healthy = [0, 2, 3]
        assert np.isfinite(packed.gradients[name][healthy]).all()
        np.testing.assert_array_equal(
            packed.gradients[name][healthy], alone.gradients[name][healthy]
        )


def test_sliding_block_derivatives_against_central_differences(block):
    # contact and friction: central differences (1e-4 relative) of whole runs at rtol 1e-8
    # on one shared step sequence (the same steps for both, smooth in the parameters),
    # against the sensitivities at rtol 1e-6 on their own steps. Measured: z 4.8e-5 /
    # 1.0e-4 / 5.3e-5 of each derivative's peak (k, press, mu), y 1.9e-7 (press); the
    # differences' own O(delta) error (delta = 1e-4; 3e-5 with 1e-6, 1.3e-3 at rtol
    # 1e-4: the integration's). Bound 3e-4.
    base = {"k": np.array([2e4]), "press": np.array([-100.0]), "mu": np.array([0.3])}
    names = ("k", "press", "mu")
    result = _run_block(block, {}, np.arange(1), sensitivities=names, tolerance=Tolerance(1e-6))
    log = _run_block(block, {}, np.arange(1), tolerance=Tolerance(1e-8), log_steps=True)
    shared = {"step_sequence": log.step_times, "jacobian_renewals": log.step_renewals}
    rows = {name: [] for name in names}
    for name in names:
        for sign in (1.0, -1.0):
            for other in names:
                factor = 1.0 + sign * 1e-4 if other == name else 1.0
                rows[other].append(base[other][0] * factor)
    moved = {name: np.array(values) for name, values in rows.items()}
    runs = _run_block(block, moved, np.arange(6), tolerance=Tolerance(1e-8), **shared)
    for output in BLOCK_OUTPUTS:
        y = runs.outputs[output].reshape(3, 2, -1)
        for k, name in enumerate(names):
            reference = (y[k, 0] - y[k, 1]) / (2e-4 * base[name][0])
            error = np.abs(result.gradients[output][0, :, k] - reference).max()
            # (the normal motion y does not depend on the tangential spring: both zero)
            assert error <= 3e-4 * np.abs(reference).max(), (output, name)


def test_sensitivity_names_and_integrators_are_checked(block):
    common = {"t_end": 0.01, "dt": 1e-4, "outputs": BLOCK_OUTPUTS, "integrator": "ros34pw2"}
    with pytest.raises(InvalidParameterError, match=r"unknown parameter\(s\) \['speed'\].*binds"):
        simulate(block, {}, sensitivities=("mu", "speed"), **common)
    with pytest.raises(InvalidParameterError, match="named twice"):
        simulate(block, {}, sensitivities=("mu", "mu"), **common)
    with pytest.raises(InvalidParameterError, match="sequence of parameter names"):
        simulate(block, {}, sensitivities="mu", **common)
    with pytest.raises(InvalidParameterError, match=r"Rosenbrock methods.*'rk4'"):
        simulate(block, {}, sensitivities=("mu",), **{**common, "integrator": "rk4"})
    model = SimulationModel(block, outputs=BLOCK_OUTPUTS, t_end=0.01, dt=1e-4, integrator="rk4")
    assert model.differentiable == ("k", "mu", "press")  # central differences (below)
    assert model.gradient_cost == 2.0
    with pytest.raises(InvalidParameterError, match=r"\['speed'\].*\['k', 'mu', 'press'\]"):
        model({}, wrt=["speed"])


def test_model_protocol_gradients(block):
    # model(samples, wrt=names): the usual outputs, bit for bit, plus "gradients" of
    # shape (B, T, len(wrt)) in wrt's order, the same numbers simulate gives
    model = SimulationModel(
        block,
        outputs=BLOCK_OUTPUTS,
        t_end=0.02,
        dt=1e-4,
        record_interval=1e-3,
        integrator="ros34pw2",
        tolerance=Tolerance(1e-4),
    )
    assert model.differentiable == ("k", "mu", "press")
    samples = _block_samples(3, seed=8)
    plain = model(samples)
    asked = model(samples, wrt=["press", "k"])
    assert "gradients" not in plain
    for name in BLOCK_OUTPUTS:
        np.testing.assert_array_equal(asked[name], plain[name])
        assert asked["gradients"][name].shape == (3, 21, 2)
    direct = simulate(block, samples, sensitivities=("press", "k"), **_block_settings(model))
    np.testing.assert_array_equal(asked["gradients"]["z"], direct.gradients["z"])
    with pytest.raises(InvalidParameterError, match=r"\['speed'\].*\['k', 'mu', 'press'\]"):
        model(samples, wrt=["speed"])


def _block_settings(model: SimulationModel) -> dict:
    return {"outputs": model.outputs, **model.settings}


def test_rk4_gradients_against_the_closed_form(spring_mass):
    # RK4 at 1 ms (omega dt = 0.02) by central differences on its fixed steps, against the
    # step response's complex-step derivatives. Measured: 3.7e-8, 1.1e-8, 2.8e-9 of each
    # derivative's peak (stiffness, damping, force); bound 1e-6
    t = np.arange(501) * 1e-3
    names = ("stiffness", "damping", "force")
    model = SimulationModel(
        spring_mass, outputs={"x": Coordinate("mass")}, t_end=0.5, dt=1e-3, integrator="rk4"
    )
    samples = {name: np.array([value]) for name, value in OSCILLATOR.items()}
    out = model(samples, wrt=names)
    np.testing.assert_array_equal(out["x"], model(samples)["x"])  # the outputs unchanged
    assert out["gradients"]["x"].shape == (1, t.size, 3) and not out["failed"].any()
    for k, name in enumerate(names):
        moved = {**OSCILLATOR, name: OSCILLATOR[name] + 1e-30j}
        reference = step_response(t, **moved).imag / 1e-30
        error = np.abs(out["gradients"]["x"][0, :, k] - reference).max()
        assert error < 1e-6 * np.abs(reference).max(), name


def test_rk4_gradients_against_the_forward_sensitivities(block):
    # contact and friction: RK4 at 10 us by central differences against ROS34PW2's forward
    # sensitivities at rtol 1e-8 (a second method). Measured: z 4.7e-5 / 1.0e-4 / 1.0e-4
    # of each derivative's peak (k, press, mu) at dt 10 us and 2 us alike: the
    # sensitivities' own directional differences (O(delta), delta 1e-4, above); y 2.5e-9
    # (press; y depends on neither k nor mu: both zero). Bound 3e-4
    names = ("k", "press", "mu")
    samples = _block_samples(3, seed=8)
    model = SimulationModel(
        block, outputs=BLOCK_OUTPUTS, t_end=0.02, dt=1e-5, record_interval=1e-3, integrator="rk4"
    )
    out = model(samples, wrt=names)
    assert not out["failed"].any()
    reference = _run_block(
        block, samples, np.arange(3), tolerance=Tolerance(1e-8), sensitivities=names
    ).gradients
    for output in BLOCK_OUTPUTS:
        for k, name in enumerate(names):
            peak = np.abs(reference[output][..., k]).max()
            error = np.abs(out["gradients"][output][..., k] - reference[output][..., k]).max()
            assert error <= 3e-4 * peak, (output, name)
