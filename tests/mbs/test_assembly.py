"""Building mechanisms: elements file themselves by role and engine (no kernels run here)."""

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs import planar, spatial


def test_elements_file_themselves_by_role():
    crank = planar.RigidBody("crank", mass=1.0, inertia=0.1)
    pin = planar.Revolute(planar.ground.point(), crank.point(), name="pin")
    load = planar.MarkerLoad(crank.point(0.5, 0.0), force=(0.0, -1.0))
    mechanism = planar.Mechanism(gravity=(0.0, -9.81)).add(load, pin, crank)
    assert mechanism.bodies == [crank] and mechanism.joints == [pin] and mechanism.forces == [load]
    assert mechanism.joint("pin") is pin and mechanism.body("crank") is crank
    # the kernels' marker order: joints' markers, then forces', then named ones
    tip = mechanism.mark("tip", crank.point(1.0, 0.0))
    assert mechanism.markers() == [pin.marker_i, pin.marker_j, load.marker_i, tip]


def test_an_element_of_the_other_engine_is_refused_by_name():
    rod = spatial.RigidBody("rod", mass=1.0, inertia=(1.0, 1.0, 1.0))
    with pytest.raises(InvalidParameterError, match="a planar Mechanism holds planar bodies"):
        planar.Mechanism().add(rod)
    with pytest.raises(InvalidParameterError, match="a spatial Mechanism holds spatial"):
        spatial.Mechanism().add(planar.RigidBody("bar", mass=1.0, inertia=0.1))
    with pytest.raises(InvalidParameterError, match="got 3"):
        spatial.Mechanism().add(3)


def test_joint_and_mechanism_inputs_are_checked():
    bar = planar.RigidBody("bar", mass=1.0, inertia=0.1)
    with pytest.raises(InvalidParameterError, match="Fixed cannot be driven"):
        planar.Fixed(planar.ground.point(), bar.point(), drive=planar.ConstantRate(1.0))
    with pytest.raises(InvalidParameterError, match="Revolute joins body 'bar' to itself"):
        planar.Revolute(bar.point(), bar.point(1.0, 0.0))
    with pytest.raises(InvalidParameterError, match="Prismatic needs two markers; its second"):
        planar.Prismatic(planar.ground.point(), bar)
    with pytest.raises(InvalidParameterError, match="gravity must be 3 finite numbers"):
        spatial.Mechanism(gravity=(0.0, np.nan, 1.0))
    with pytest.raises(InvalidParameterError, match="two bodies are named 'bar'"):
        planar.Mechanism().add(bar, planar.RigidBody("bar", mass=2.0, inertia=0.2))
    with pytest.raises(InvalidParameterError, match="no joint named 'hinge'"):
        planar.Mechanism().add(bar).joint("hinge")
