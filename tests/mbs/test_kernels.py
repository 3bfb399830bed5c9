"""Small kernel helpers against NumPy references."""

import numpy as np

from fuzzymbs.mbs import kernels as K


def test_fast_atan2_matches_numpy():
    # reference: numpy.arctan2 (libm); our polynomial is documented to 5e-15 rad
    rng = np.random.default_rng(7)
    y = np.concatenate([rng.normal(size=20000), [0.0, 1.0, -1.0, 0.0, 1e-300, 3.0, -2.0]])
    x = np.concatenate([rng.normal(size=20000), [1.0, 0.0, 0.0, -1.0, -1.0, 3.0, -2.0]])
    got = np.array([K.atan2(a, b) for a, b in zip(y, x, strict=True)])
    ref = np.arctan2(y, x)
    assert np.abs(got - ref).max() < 1e-14
    # also right at the octant and pi/8 seams
    t = np.tan(np.pi / 8)
    for a, b in ((t, 1.0), (1.0, 1.0), (1.0, t), (-t, -1.0)):
        assert abs(K.atan2(a, b) - np.arctan2(a, b)) < 1e-14


def test_uniform_grid_detection():
    assert K._is_uniform(np.linspace(0.0, 1.0, 5), 4)
    assert not K._is_uniform(np.array([0.0, 0.1, 0.3]), 2)
