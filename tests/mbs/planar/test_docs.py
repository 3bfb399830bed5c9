"""The code blocks of docs/mechanisms.md run, in order, and give what the guide says."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from fuzzymbs.mbs.planar import simulate

GUIDE = Path(__file__).resolve().parents[3] / "docs" / "mechanisms.md"


@pytest.mark.slow  # its spatial example compiles the spatial kernels (about 25 s)
def test_mechanisms_guide_examples_run():
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) == 7
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    result = namespace["result"]
    assert not result.failed.any() and result.joint_residual[0] < 1e-10
    # the tip of the 1 m rod stays 1 m from the pivot (rigid body, revolute joint)
    tip = result.marker("tip")[0, :, :2]
    np.testing.assert_allclose(np.hypot(tip[:, 0], tip[:, 1]), 1.0, atol=1e-9)
    # the cubic spring holds the block about x = 1 m (its free length)
    slide = simulate(namespace["slide"], np.linspace(0.0, 1.0, 101))
    x = slide.coordinates("block")[0, :, 0]
    assert x[0] == pytest.approx(1.2) and x.min() == pytest.approx(0.8, abs=0.01)
    np.testing.assert_allclose(
        namespace["spatial"].position("bob")[0, :, 2], -np.cos(np.deg2rad(30)), atol=1e-9
    )
    # the flexible strip swings and bends, its joint held
    flexible = namespace["flexible"]
    assert not flexible.failed.any() and flexible.joint_residual[0] < 1e-10
    assert flexible.modal_coordinates("strip").shape == (1, 101, 4)
    assert np.abs(flexible.modal_coordinates("strip")).max() > 1e-5
    out = namespace["out"]
    assert out["tip_x"].shape == (2, 201) and not out["failed"].any()
    # the derivatives' example: at t = 0 the tip is at x = sin(angle) (a 1 m rod), and a
    # rigid pendulum's motion does not depend on its mass (the inertia scales with it)
    gradients = out["gradients"]["tip_x"]
    assert gradients.shape == (2, 201, 2)
    np.testing.assert_allclose(gradients[:, 0, 1], np.cos([0.5, 0.6]), rtol=1e-8)
    assert np.abs(gradients[..., 0]).max() < 1e-6
