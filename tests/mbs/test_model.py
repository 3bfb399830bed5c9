"""The batched model interface, parameter binding, failure flags and input errors."""

import pickle

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.bodies import RotatingBody, TranslatingBody
from fuzzymbs.mbs.contact import CartesianChart, PenaltyContact
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import SimulationModel, simulate
from fuzzymbs.mbs.lumped import lumped_modal_body, rigid_body
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.profiles import TimeProfile
from fuzzymbs.mbs.system import Coordinate, NodeDisplacement, System

from .systems import ground_patch

MASS = 2.0
FORCE = Parameter("F", 10.0)
STIFFNESS = Parameter("k", 800.0)


def oscillator(force=FORCE, stiffness=STIFFNESS) -> System:
    system = System()
    system.add_body(TranslatingBody(rigid_body("mass", MASS), ["y"]))
    system.add(Spring("s", "mass", [0], stiffness=stiffness, direction="y"))
    system.add(NodalForce("f", "mass", [0], "y", force))
    return system


def test_model_outputs_coords_and_binding():
    model = SimulationModel(
        oscillator(), t_end=0.5, dt=1e-3, record_interval=1e-2, outputs={"y": Coordinate("mass")}
    )
    assert model.parameter_names == ("F", "k")
    k = np.array([800.0, 200.0, 450.0])
    f = np.array([10.0, -5.0, 2.0])
    out = model({"k": k, "F": f})
    t = model.coords["time"]
    assert out["y"].shape == (3, t.size) and t[0] == 0.0 and t[-1] == pytest.approx(0.5)
    assert out["failed"].tolist() == [False] * 3
    # closed form step response of an undamped oscillator: y = F/k (1 - cos(w t))
    ref = f[:, None] / k[:, None] * (1 - np.cos(np.sqrt(k / MASS)[:, None] * t))
    np.testing.assert_allclose(out["y"], ref, atol=1e-9 * np.abs(ref).max())
    # missing columns take defaults: one column given
    out = model({"k": np.array([800.0])})
    np.testing.assert_allclose(out["y"][0, -1], 10 / 800 * (1 - np.cos(20 * 0.5)), rtol=1e-8)
    # picklable (Dask / processes) and identical after the round trip
    clone = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(clone({"k": k, "F": f})["y"], model({"k": k, "F": f})["y"])


def test_shared_parameter_and_time_profile():
    # one name bound in two places; force ramped over 0.1 s
    system = System()
    system.add_body(TranslatingBody(rigid_body("mass", MASS), ["y"]))
    system.add(Spring("s1", "mass", [0], stiffness=Parameter("k", 100.0), direction="y"))
    system.add(Spring("s2", "mass", [0], stiffness=Parameter("k", 100.0), direction="y"))
    system.add(NodalForce("f", "mass", [0], "y", 50.0, profile=TimeProfile([0.0, 0.1], [0.0, 1.0])))
    damped = SimulationModel(system, t_end=0.1, dt=1e-4, outputs={"y": Coordinate("mass")})
    assert damped.parameter_names == ("k",)
    y = damped({"k": np.array([1e3])})["y"][0]
    # ramp response of m y'' + 2k y = F t / T:  y = F/(2k T) (t - sin(w t)/w), w^2 = 2k/m
    w = np.sqrt(2e3 / MASS)
    t = damped.coords["time"]
    np.testing.assert_allclose(y, 50 / (2e3 * 0.1) * (t - np.sin(w * t) / w), atol=1e-10)


def test_failed_samples_are_flagged_and_nan():
    # explicit RK4 is unstable for w dt > 2.83: k = 1e8 N/m, m = 2 kg, dt = 1e-3 -> w dt = 7
    model = SimulationModel(
        oscillator(), t_end=0.2, dt=1e-3, outputs={"y": Coordinate("mass")}, displacement_bound=0.1
    )
    out = model({"k": np.array([800.0, 1e8]), "F": np.array([10.0, 10.0])})
    assert out["failed"].tolist() == [False, True]
    assert out["failure_reason"][1] != "" and out["failure_reason"][0] == ""
    assert np.isnan(out["y"][1]).all() and np.isfinite(out["y"][0]).all()
    # a displacement beyond the bound (static 10/800 m = 12.5 mm, peak 25 mm > 20 mm)
    res = simulate(
        oscillator(),
        {"k": np.array([800.0])},
        t_end=0.2,
        dt=1e-3,
        outputs={"y": Coordinate("mass")},
        displacement_bound=0.02,
    )
    assert res.failed[0] and "bound" in res.failure_reason[0]
    assert 0 < res.failure_time[0] < 0.2


def test_unknown_and_invalid_parameters_raise():
    model = SimulationModel(oscillator(), t_end=0.01, dt=1e-3, outputs={"y": Coordinate("mass")})
    with pytest.raises(InvalidParameterError, match="unknown parameter"):
        model({"stiffness": np.array([1.0])})
    with pytest.raises(InvalidParameterError, match="'k'"):
        model({"k": np.array([-1.0])})
    with pytest.raises(InvalidParameterError, match="'k'"):
        model({"k": np.array([np.nan])})
    with pytest.raises(InvalidParameterError, match="equal length"):
        model({"k": np.ones(2), "F": np.ones(3)})


def test_invalid_system_definitions_raise():
    with pytest.raises(InvalidParameterError, match="stiffness"):
        oscillator(stiffness=-5.0).compile()
    with pytest.raises(InvalidParameterError, match="unknown body"):
        s = oscillator()
        s.add(Spring("bad", "nobody", [0], stiffness=1.0))
        s.compile()
    with pytest.raises(InvalidParameterError, match="node"):
        s = oscillator()
        s.add(NodalForce("bad", "mass", [3], "y", 1.0))
        s.compile()
    with pytest.raises(InvalidParameterError, match="whole number"):
        simulate(oscillator(), t_end=0.0105, dt=1e-3, outputs={"y": Coordinate("mass")})
    with pytest.raises(InvalidParameterError, match="output"):
        simulate(oscillator(), t_end=0.01, dt=1e-3, outputs={"y": Coordinate("mass", 4)})
    # springs on a rotating body are refused (time-varying geometry)
    s = System()
    s.add_body(RotatingBody(rigid_body("rot", 1.0), "y", speed=1.0))
    s.add(Spring("bad", "rot", [0], stiffness=1.0))
    with pytest.raises(InvalidParameterError, match="rotating"):
        s.compile()
    # a master patch that is not a tensor grid
    s = System()
    s.add_body(ground_patch())
    s.add_body(TranslatingBody(rigid_body("block", 1.0), ["y"]))
    s.add(
        PenaltyContact(
            "c",
            "block",
            [0],
            "ground",
            [0, 1, 2, 3, 4],
            CartesianChart("x", "z"),
            penalty=1.0,
            normal="y",
        )
    )
    with pytest.raises(InvalidParameterError, match="grid"):
        s.compile()
    with pytest.raises(InvalidParameterError, match="positive"):
        lumped_modal_body("b", [(0, 0, 0)], [-1.0])


def test_node_displacement_output_of_elastic_translating_body():
    # a two-mass chain on a translating frame: node output = frame translation + Psi q
    stiff = np.zeros((6, 6))
    stiff[1, 1] = stiff[4, 4] = 1e4
    stiff[1, 4] = stiff[4, 1] = -1e4
    body = lumped_modal_body("chain", [(0, 0, 0), (0, 0.1, 0)], [1.0, 1.0], stiff, free_dofs=[1, 4])
    system = System()
    system.add_body(TranslatingBody(body, ["y"]))
    system.add(NodalForce("pull", "chain", [1], "y", 2.0))
    res = simulate(
        system,
        t_end=0.05,
        dt=1e-4,
        outputs={"top": NodeDisplacement("chain", 1, "y"), "s": Coordinate("chain")},
    )
    # free-free chain pulled at the top: centre of mass moves F t^2 / (2 m_total),
    # relative motion is the elastic mode (w^2 = 2k/m): top = com + F/(2k)/2 (1 - cos w t)
    t = res.time
    com = 2.0 * t**2 / (2 * 2.0)
    w = np.sqrt(2e4 / 1.0)
    ref = com + 2.0 / (4 * 1e4) * (1 - np.cos(w * t))
    np.testing.assert_allclose(res.outputs["top"][0], ref, atol=1e-9)


def test_eigenanalysis_of_unconverged_state_is_nan_and_flagged():
    from fuzzymbs.mbs.linearize import eigenanalysis, steady_state

    from .systems import hoffmann_system

    system = hoffmann_system(0.1).compile()
    rough = steady_state(system, max_iter=1)  # one Newton step from x = 0: not converged
    assert not rough.converged.any()
    result = eigenanalysis(system, state=rough)
    assert result.failed.all() and np.isnan(result.eigenvalues).all()
    assert not result.stable.any()


def test_shared_name_with_two_defaults_is_refused():
    system = System()
    system.add_body(TranslatingBody(rigid_body("mass", MASS), ["y"]))
    system.add(Spring("s1", "mass", [0], stiffness=Parameter("k", 100.0), direction="y"))
    system.add(Spring("s2", "mass", [0], stiffness=Parameter("k", 200.0), direction="y"))
    with pytest.raises(InvalidParameterError, match="one default"):
        system.compile()
