"""Disc brake: shapes, input checks, statics against closed forms, divergence, stability.

Short runs (0.1-1 ms) keep this file fast; the 10 ms runs and the 33-run
studies are in test_brake_slow.py (marked slow).
"""

from __future__ import annotations

import pickle
from dataclasses import replace

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody
from fuzzymbs.mbs.forces import NodalForce
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.linearize import steady_state
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.system import NodeDisplacement, System
from fuzzymbs.models.brake import (
    DEFAULTS,
    BrakeDesign,
    DiscBrake,
    brake_system,
    build_bodies,
    growth_rate,
    stability_analysis,
)
from fuzzymbs.study.registry import get_model

F_TOTAL = 25 * DEFAULTS["nodal_force"]  # 400 kN per pad
C_P = DEFAULTS["penalty_stiffness"]


@pytest.fixture(scope="module")
def model() -> DiscBrake:
    return DiscBrake(t_end=1e-3, record_interval=1e-5)


@pytest.fixture(scope="module")
def bodies():
    return build_bodies(BrakeDesign())


def test_outputs_shaped_with_time_coordinate(model):
    out = model({"nodal_force": np.array([16e3, 15.8e3]), "disc_speed": np.array([1.0, 1.1])})
    t = model.coords["time"]
    assert t.shape == (101,)
    np.testing.assert_allclose(t[[0, -1]], [0.0, 1e-3], atol=1e-15)
    for name in ("y_lpad", "y_upad", "y_cali"):
        assert out[name].shape == (2, t.size)
        assert np.isfinite(out[name]).all()
    assert not out["failed"].any()
    # zero initial conditions; the pads are pressed onto the disc from both sides
    assert out["y_lpad"][0, 0] == 0.0
    assert out["y_lpad"][0, 50:].mean() > 0 > out["y_upad"][0, 50:].mean()


def test_invalid_parameters_rejected(model):
    with pytest.raises(InvalidParameterError, match="pad_spring_stiffness"):
        model({"pad_spring_stiffness": np.array([-1.0])})
    with pytest.raises(InvalidParameterError, match="penalty_stiffness"):
        model({"penalty_stiffness": np.array([0.0])})
    with pytest.raises(InvalidParameterError, match="unknown brake parameter"):
        model({"tooth_stiffness": np.array([1.0])})
    with pytest.raises(InvalidParameterError, match="finite"):
        model({"nodal_force": np.array([np.nan])})
    spec = get_model("brake")
    with pytest.raises(InvalidParameterError, match="unknown brake option"):
        spec.factory(time_step=1e-6)
    with pytest.raises(InvalidParameterError, match="design field"):
        spec.factory(design={"disc_radius": 0.2})
    with pytest.raises(InvalidParameterError, match="contact"):
        DiscBrake(contact="three-pass")
    with pytest.raises(InvalidParameterError, match="disc_clamp"):
        BrakeDesign(disc_clamp="bolted").validate()
    with pytest.raises(InvalidParameterError, match="disc_thickness"):
        BrakeDesign(disc_thickness=-0.01).validate()


def test_registered_parameters_match_the_model(model):
    spec = get_model("brake")
    assert set(spec.parameters) == set(DEFAULTS) == set(model.compiled.parameters.names)
    for name, info in spec.parameters.items():
        assert info.default == DEFAULTS[name]
    assert set(spec.outputs) == {"y_lpad", "y_upad", "y_cali"}


def test_model_pickles_small_and_identical(model):
    blob = pickle.dumps(model)
    assert len(blob) < 2_000_000  # plain arrays only (no meshes, no FE matrices)
    copy = pickle.loads(blob)
    s = {"nodal_force": np.array([16e3])}
    np.testing.assert_array_equal(copy(s)["y_upad"], model(s)["y_upad"])


def _node_y(compiled, state, body, nodes):
    """y displacements of ``nodes`` of ``body`` at a static state (coordinates only)."""
    x = np.concatenate([state, np.zeros_like(state)])
    return np.array(
        [compiled.output_functional(NodeDisplacement(body, int(n), "y")) @ x for n in nodes]
    )


def _penetrations(compiled, bodies, state, design, side):
    """Penetrations of both contact passes of one pad, computed independently with NumPy.

    Pass 1: pad contact node y minus the disc face y interpolated bilinearly in the
    polar patch grid (r, theta); pass 2: disc patch node y minus the pad face y
    interpolated on the pad's 7 x 7 polar face grid. The faces are planes y = const
    (normals +-y) and the disc has not turned (t = 0), so the gaps are differences
    of y displacements; sign: positive = penetration.
    """
    pad = bodies.lower_pad if side == "lower" else bodies.upper_pad
    pad_name = f"{side}_pad"
    patch = bodies.disc.node_sets[f"patch_{side}"]
    radii, angles = design.patch_radii, design.patch_angles
    disc_y = _node_y(compiled, state, "disc", patch).reshape(radii.size, angles.size)
    dr, dth = design.pad_node_spacing
    face_r = design.pad_radii[0] + dr * np.arange(7)
    face_t = dth * (np.arange(7) - 3.0)
    face_y = _node_y(compiled, state, pad_name, pad.node_sets["face"]).reshape(7, 7)
    contact = pad.node_sets["contact"]
    contact_y = _node_y(compiled, state, pad_name, contact)

    def polar(p):
        return np.column_stack([np.hypot(p[:, 0], p[:, 2]), np.arctan2(-p[:, 2], p[:, 0])])

    disc_at_pad = RegularGridInterpolator((radii, angles), disc_y)(
        polar(pad.node_positions[contact])
    )
    pad_at_disc = RegularGridInterpolator((face_r, face_t), face_y)(
        polar(bodies.disc.node_positions[patch])
    )
    sign = 1.0 if side == "lower" else -1.0  # lower pad penetrates upwards (+y)
    return sign * (contact_y - disc_at_pad), sign * (
        pad_at_disc - _node_y(compiled, state, "disc", patch)
    )


@pytest.mark.parametrize("contact, n_points", [("two-pass", 73), ("single-pass", 25)])
def test_static_penetration_matches_load_over_contact_points(bodies, contact, n_points):
    # Closed form (THEORY section 4): F_total = 25 F_n = 400 kN is carried by n_points
    # penalty springs c_p -> mean penetration F_total / (n c_p) = 54.8 um (two-pass:
    # 25 pad nodes + 48 disc nodes) or 160 um (single-pass: 25 pad nodes).
    # mu = 0: with friction (280 kN of shear) the pads deform in-plane by tens of um,
    # which moves the points across the y-gradient of the faces; the independent
    # gap computation below uses the undeformed chart positions.
    design = BrakeDesign()
    compiled = brake_system(bodies, contact).compile()
    st = steady_state(compiled, {"friction_coefficient": np.array([0.0])})
    assert st.converged.all()
    state = st.x[0]
    for side in ("lower", "upper"):
        first, second = _penetrations(compiled, bodies, state, design, side)
        pens = first if contact == "single-pass" else np.concatenate([first, second])
        assert pens.size == n_points and (pens > 0).all()  # every point carries load
        # force balance of the pad: contact + springs to the caliper = applied load
        pad = bodies.lower_pad if side == "lower" else bodies.upper_pad
        back = _node_y(compiled, state, f"{side}_pad", pad.node_sets["back"])
        jaw = _node_y(compiled, state, "caliper", bodies.caliper.node_sets[f"{side}_jaw"])
        spring = DEFAULTS["pad_spring_stiffness"] * np.sum(back - jaw)
        sign = 1.0 if side == "lower" else -1.0
        # 1e-5: Newton tolerance and the small in-plane (Poisson) shift of the points
        assert C_P * pens.sum() - sign * (-spring) == pytest.approx(F_TOTAL, rel=1e-5)
        # the springs to the caliper take a small share: 25 k |y_pad| / F_total ~ 0.07 %
        # (two-pass) or 0.2 % (single-pass), hence 5e-3 for the closed form
        assert abs(spring) < 5e-3 * F_TOTAL
        np.testing.assert_allclose(pens.mean(), F_TOTAL / (n_points * C_P), rtol=5e-3)
        # the pad frame (its centre of mass) moves by the penetration plus the elastic
        # compression of pad and disc: within 5 % of the closed form (measured ~3 %)
        y_pad = state[compiled.body_dofs[f"{side}_pad"].start]
        assert sign * y_pad == pytest.approx(F_TOTAL / (n_points * C_P), rel=0.05)


def test_caliper_force_balance_with_ground_springs(bodies):
    # Make the pads' loads unequal (upper press halved) so that the caliper is pulled
    # off centre; at equilibrium the 50 pad springs and the 4 ground springs balance:
    # k sum(u_back - u_jaw) = k_c sum(u_ground) (translation equation of a free body).
    system = brake_system(bodies)
    system.elements = [
        replace(e, magnitude=0.5 * DEFAULTS["nodal_force"])
        if isinstance(e, NodalForce) and e.name == "upper_press"
        else e
        for e in system.elements
    ]
    compiled = system.compile()
    st = steady_state(compiled)
    assert st.converged.all()
    x = st.x[0]
    k, k_c = DEFAULTS["pad_spring_stiffness"], DEFAULTS["caliper_spring_stiffness"]
    pull = 0.0
    for side, pad in (("lower", bodies.lower_pad), ("upper", bodies.upper_pad)):
        back = _node_y(compiled, x, f"{side}_pad", pad.node_sets["back"])
        jaw = _node_y(compiled, x, "caliper", bodies.caliper.node_sets[f"{side}_jaw"])
        pull += k * np.sum(back - jaw)
    ground = k_c * np.sum(_node_y(compiled, x, "caliper", bodies.caliper.node_sets["ground"]))
    y_cali = x[compiled.body_dofs["caliper"].start]
    assert abs(y_cali) > 1e-6  # off centre by micrometres: the balance is not 0 = 0
    assert pull == pytest.approx(ground, rel=1e-6)
    # closed form for rigid bodies: y_c = k (sum y_back) / (50 k + 4 k_c); the caliper's
    # and pads' elastic deformation at the attachment nodes changes it by < 2 %
    y_l = x[compiled.body_dofs["lower_pad"].start]
    y_u = x[compiled.body_dofs["upper_pad"].start]
    assert y_cali == pytest.approx(25 * k * (y_l + y_u) / (50 * k + 4 * k_c), rel=0.02)


def test_diverging_configuration_flagged_failed():
    # c_p = 1e13 N/m: contact frequency ~6e7 rad/s, omega dt ~ 60 >> 2.8 (RK4 limit)
    brake = DiscBrake(t_end=1e-4, record_interval=1e-5, integrator="rk4")
    out = brake({"penalty_stiffness": np.array([1e8, 1e13])})
    assert list(out["failed"]) == [False, True]
    assert out["failure_reason"][1] != ""
    assert np.isnan(out["y_lpad"][1]).all() and np.isfinite(out["y_lpad"][0]).all()
    # an absurd time step diverges the nominal brake too
    coarse = DiscBrake(t_end=2e-3, dt=1e-4, record_interval=1e-4, integrator="rk4")
    assert coarse({"nodal_force": np.array([16e3])})["failed"].all()


def test_default_integrator_is_stable_where_rk4_diverges():
    # ROS34PW2 (L-stable, the default) integrates the stiff c_p = 1e13 N/m contact that
    # RK4 at 1 us cannot (above): the run ends finite and is not flagged
    out = DiscBrake(t_end=1e-4, record_interval=1e-5)({"penalty_stiffness": np.array([1e13])})
    assert not out["failed"].any() and np.isfinite(out["y_lpad"]).all()


def test_growth_rate_of_closed_form_signal():
    # y = exp(a t) sin(2 pi f t): windowed-std fit returns a (to 1 %, 20 periods/window)
    t = np.linspace(0.0, 1e-2, 20001)
    for a in (-300.0, 500.0):
        y = np.exp(a * t) * np.sin(2 * np.pi * 16e3 * t)
        assert growth_rate(y, t) == pytest.approx(a, rel=0.01)


def test_stability_flags_unstable_speed_consistent_with_integration(model):
    # Linearised about steady sliding, the brake is stable at 1 rad/s (friction acts
    # as transverse damping mu f_N / v, large at low sliding speed) and loses
    # stability by mode coupling at 10 rad/s. Check with the time integration: start
    # at the steady state plus a 1 nm push along the unstable mode (of 10 rad/s) and
    # subtract the unpushed run (which drifts slightly: the pad nodes slide over the
    # deformed, bilinearly interpolated disc patch). The difference must grow at the
    # eigenvalue's real part in the linear phase (0.4 ms, amplitude << 1 um), and decay
    # at 1 rad/s.
    compiled = model.compiled
    speeds = np.array([1.0, 10.0])
    result = stability_analysis(compiled, {"disc_speed": speeds}, n_modes=3)
    assert result.converged.all()
    assert result.max_real_part[0] <= 0 < result.max_real_part[1]
    assert result.unstable_count[0] == 0 and result.unstable_count[1] >= 1
    from fuzzymbs.mbs.linearize import eigenanalysis

    eig = eigenanalysis(compiled, {"disc_speed": speeds})
    n = compiled.n_dofs
    lam = eig.eigenvalues[1]
    k = int(np.argmax(np.where(lam.imag >= 0, lam.real, -np.inf)))
    assert lam[k].real == pytest.approx(result.max_real_part[1], rel=1e-12)
    shape = eig.mode_shapes[1, :, k]
    push = np.concatenate([1e-9 * shape.real, 1e-9 * (lam[k] * shape).real])
    x0 = np.zeros((4, 2 * n))
    x0[:, :n] = np.tile(eig.steady_state.x, (2, 1))
    x0[:2] += push
    run = simulate(
        compiled,
        {"disc_speed": np.tile(speeds, 2)},
        t_end=4e-4,
        dt=1e-6,
        record_interval=2e-6,
        initial_state=x0,
        outputs=model.simulation.outputs,
    )
    assert not run.failed.any()
    rates = growth_rate(run.outputs["y_lpad"][:2] - run.outputs["y_lpad"][2:], run.time)
    assert rates[0] < 0
    # 10 %: measured 3.6 % (window fit of a single growing mode plus the decaying rest)
    assert rates[1] == pytest.approx(result.max_real_part[1], rel=0.10)


def test_stability_model_outputs_and_coords():
    model = get_model("brake-stability").factory(n_modes=3)
    out = model({"disc_speed": np.array([1.0, 10.0])})
    assert model.coords["mode_rank"].tolist() == [0, 1, 2]
    assert out["real_parts"].shape == out["frequencies"].shape == (2, 3)
    for name in (
        "max_real_part",
        "least_stable_frequency",
        "unstable_modes",
        "failed",
        "pad_max_real_part",
        "pad_mode_frequency",
    ):
        assert out[name].shape == (2,)
    assert not out["failed"].any()
    # ranked: the first column is the largest real part of each sample
    assert (np.diff(out["real_parts"], axis=1) <= 0).all()
    np.testing.assert_array_equal(out["max_real_part"], out["real_parts"][:, 0])
    assert out["unstable_modes"][0] == 0 and out["unstable_modes"][1] >= 1
    # the pads' least stable mode: damped at 1 rad/s (friction), and at 10 rad/s it is
    # the unstable mode-coupling pair itself (the pads take part in it)
    assert out["pad_max_real_part"][0] < out["max_real_part"][0] <= 0
    assert out["pad_max_real_part"][1] == out["max_real_part"][1]
    # the RK4 step limit: at 1 rad/s set by the friction-damped pad modes (about -8.9e6
    # 1/s, so 2.785 / 8.9e6 = 0.31 us, below the paper's 1 us); ten times larger at 10
    # rad/s, where the friction damping mu f_N / v_slide is ten times smaller
    assert out["rk4_max_step"].shape == (2,)
    assert 2.5e-7 < out["rk4_max_step"][0] < 3.5e-7 < 3.0e-6 < out["rk4_max_step"][1] < 3.4e-6


def test_demo_study_files_validate():
    from fuzzymbs.study.pipeline import demo_files
    from fuzzymbs.study.studyfile import load_study_file

    files = demo_files("brake")
    assert [f.name for f in files][:2] == ["01-study1.toml", "02-study2.toml"]
    for f in files:
        definition = load_study_file(str(f))
        plan = definition.study.plan
        if f.name in ("01-study1.toml", "02-study2.toml"):
            # studies 1 and 2 refine adaptively (the paper's reduced 33 runs: examples/)
            assert plan.method == "adaptive" and len(plan.names) == 3
        elif len(plan.names) == 3:
            # reduced method, 3 parameters on 5 levels: 1 + 4 x 8 = 33 runs
            assert len(plan) == 33


def test_brake_on_general_bodies_compiles_to_the_frame_motion_arrays(bodies):
    # The brake is built from spatial FlexibleBody objects on a driven Revolute (disc)
    # and Prismatic joints (pads, caliper); written with the minimal-coordinate frame
    # motions directly it must give the same kernel arrays bit for bit, so the brake's
    # results and per-step cost are those of the minimal-coordinate kernels.
    general = brake_system(bodies)
    assert {type(b).__name__ for b in general.bodies.values()} == {"FlexibleBody"}
    direct = System()
    speed = Parameter("disc_speed", DEFAULTS["disc_speed"])
    direct.add_body(RotatingBody(bodies.disc, "y", speed=speed))
    for modal in (bodies.lower_pad, bodies.upper_pad, bodies.caliper):
        direct.add_body(TranslatingBody(modal, ["y"]))
    direct.elements = list(general.elements)
    a, b = general.compile(), direct.compile()
    for x, y in zip(a.data, b.data, strict=True):
        np.testing.assert_array_equal(x, y)
    assert a.parameters.slots == b.parameters.slots
    assert a.body_dofs == b.body_dofs
