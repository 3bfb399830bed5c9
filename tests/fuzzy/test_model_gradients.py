"""The closed-form test models' analytic gradients against central finite differences."""

import numpy as np
import pytest

from fuzzymbs.models.closed_form.hard_cases import hard_cases
from fuzzymbs.models.closed_form.resonance import resonance_cases

CASES = [*hard_cases(), *resonance_cases()]


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_gradients_match_central_differences_and_outputs_are_the_models(case):
    names = list(case.triangles)
    low = np.array([case.triangles[n][0] for n in names])
    high = np.array([case.triangles[n][2] for n in names])
    points = low + np.random.default_rng(1).uniform(0.0, 1.0, (20, len(names))) * (high - low)
    outputs, gradients = case.gradient(dict(zip(names, points.T, strict=True)))
    plain = case.model(dict(zip(names, points.T, strict=True)))
    for key, value in plain.items():
        np.testing.assert_array_equal(outputs[key], value)  # the model's values, bit for bit
        assert gradients[key].shape == (*value.shape, len(names))
        largest = np.abs(gradients[key]).max()
        for i in range(len(names)):
            step = np.zeros(len(names))
            step[i] = 1e-6 * (high[i] - low[i])
            up = case.model(dict(zip(names, (points + step).T, strict=True)))[key]
            down = case.model(dict(zip(names, (points - step).T, strict=True)))[key]
            central = (up - down) / (2.0 * step[i])
            # central differences with a step of 1e-6 of the support: truncation O(h^2) and
            # round-off ~1e-16 / 1e-6 of the values; measured at most 7e-10 of the largest
            # slope of each case, so 1e-7 of it is the tolerance
            np.testing.assert_allclose(gradients[key][..., i], central, rtol=0, atol=1e-7 * largest)
