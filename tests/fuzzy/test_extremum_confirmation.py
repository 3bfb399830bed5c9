"""The adaptive method confirms its extrema on the model: resonance ridges against their truth."""

import warnings

import numpy as np
import pytest

from fuzzymbs.fuzzy import Triangular, plan
from fuzzymbs.fuzzy.band_scale import band_miss
from fuzzymbs.fuzzy.box_search import box_extremes
from fuzzymbs.fuzzy.chebyshev_grid import ChebyshevSparseGrid, node_values
from fuzzymbs.fuzzy.extremum_confirmation import confirmation_probes
from fuzzymbs.fuzzy.numbers import triangular_numbers
from fuzzymbs.models.closed_form.hard_cases import HardCase, dense_truth
from fuzzymbs.models.closed_form.resonance import (
    polished_truth,
    sdof_amplitude,
    sdof_resonance,
    sdof_truth,
    two_dof_amplitudes,
    two_dof_resonance,
)

LEVELS = np.linspace(0.0, 1.0, 6)
# the truths: sdof_truth is the closed form up to a 20,001-point mass axis (error below
# 1e-6 of the cut width); polished_truth is a dense grid polished by L-BFGS-B from the
# best points of a 21-point-per-axis grid (the optimiser's tolerance, far below 0.1 %).
# A miss is therefore within the 1 % tolerance up to 0.1 %: 0.011.
TOLERANCE = 0.011


def _adaptive(case: HardCase, **options):
    scheme = plan(triangular_numbers(case.triangles), method="adaptive", levels=LEVELS, **options)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cuts = scheme.retransform(scheme.evaluate(case.model))
        outcome = scheme.outcome()
    return scheme, cuts, outcome


def _miss(case: HardCase, cuts, truth) -> float:
    return max(band_miss(c.lower, c.upper, *truth[k]) for k, c in cuts.items())


def _truth(case: HardCase):
    if case.name.startswith("sdof"):
        return sdof_truth(case, LEVELS)
    return polished_truth(case, LEVELS, starts=3)


@pytest.mark.parametrize(
    "case",
    [
        # measured (benchmarks/ridge_confirmation.py): 112 runs, miss 0.02 % (3.69 % for 82
        # runs without the confirmation); 282 runs, 0.71 %; 158 runs, 0.03 %
        pytest.param(sdof_resonance(0.05), id="sdof-5%"),
        pytest.param(sdof_resonance(0.02), id="sdof-2%"),
        pytest.param(two_dof_resonance(0.05), id="2dof-5%"),
        pytest.param(two_dof_resonance(0.02), id="2dof-2%", marks=pytest.mark.slow),
    ],
)
def test_a_resonance_ridges_highest_point_is_found(case):
    _, cuts, outcome = _adaptive(case)
    miss = _miss(case, cuts, _truth(case))
    assert miss <= TOLERANCE or outcome.error >= 0.5 * miss, (miss, outcome.error)
    assert outcome.converged
    assert miss <= TOLERANCE


@pytest.mark.slow
@pytest.mark.parametrize(
    "case", [pytest.param(sdof_resonance(0.005), id="sdof-0.5%"), two_dof_resonance(0.005)]
)
def test_a_sharp_ridge_is_found_or_reported(case):
    # damping ratio 0.5 %: the ridge is 1 % of k wide; minutes of surrogate work
    _, cuts, outcome = _adaptive(case)
    miss = _miss(case, cuts, _truth(case))
    assert miss <= TOLERANCE or outcome.error >= 0.5 * miss, (miss, outcome.error)


@pytest.mark.slow
def test_a_sharp_crest_ending_in_a_corner_is_found():
    # the chain at 0.5 % damping: mass 1's amplitude at mu = 0.2 is highest where its crest
    # (k1 against m1) meets the corner of the largest k2, the smallest m1 and the smallest
    # damping, k1 inside. Before the near ties and the corners climbed again within their
    # faces the method said converged 1.02 % off it (1.43 % with the kernel distances
    # summed directly, 0.41 % reported); measured now 1,940 runs, 0.05 % off, 0.20 %
    # reported (benchmarks/gradient_adaptive.py; truth: dense grid polished by L-BFGS-B)
    case = two_dof_resonance(0.005)
    _, cuts, outcome = _adaptive(case)
    miss = _miss(case, cuts, _truth(case))
    assert outcome.converged
    assert miss <= TOLERANCE, (miss, outcome.error)


@pytest.mark.parametrize("budget", [60, 150])
def test_the_reported_error_stays_honest_on_a_sharp_ridge_at_a_small_budget(budget):
    # stopped by its budget the method reports at least half its true miss
    case = sdof_resonance(0.005)
    _, cuts, outcome = _adaptive(case, max_runs=budget)
    miss = _miss(case, cuts, _truth(case))
    assert not outcome.converged
    assert miss <= TOLERANCE or outcome.error >= 0.5 * miss, (miss, outcome.error)


def test_resonance_models_match_their_closed_forms():
    # the single-degree-of-freedom amplitude at resonance is F / (c Omega); the two-mass
    # chain with a rigid second spring (k2 large) is one mass m1 + m2 on k1
    k, m, zeta = np.array([1020.0]), np.array([1.0]), np.array([0.02])
    damping = 2.0 * zeta * np.sqrt(k * m)
    np.testing.assert_allclose(sdof_amplitude(k, m, zeta), 1.0 / (damping * np.sqrt(1020.0)))
    stiff = two_dof_amplitudes(
        np.array([1000.0]), np.array([1e9]), np.array([1.0]), np.array([0.02]), omega_squared=300.0
    )
    single = sdof_amplitude(np.array([1000.0]), np.array([1.5]), np.array([0.02]), 300.0)
    np.testing.assert_allclose(stiff[0], [single[0], single[0]], rtol=1e-6)
    # the closed-form truth agrees with the dense grid (which lies inside it: a grid sees
    # less than the true range; the 2,001-point k axis resolves the 5 % ridge to 0.1 %)
    case = sdof_resonance(0.05)
    exact = sdof_truth(case, LEVELS)["amplitude"]
    grid = dense_truth(case, LEVELS)["amplitude"]
    assert band_miss(*grid, *exact) <= 1e-3
    assert np.all(grid[0] >= exact[0] - 1e-15) and np.all(grid[1] <= exact[1] + 1e-15)


def _valley_ridge_surrogate():
    # s(x) = -(x1 - x2)^2: its maximum is the whole diagonal, flat along (1, 1)
    grid = ChebyshevSparseGrid(2)
    for index in [(0, 0), (1, 0), (0, 1), (1, 1), (2, 0), (0, 2)]:
        new = grid.add_index(index)
        x = node_values(np.array(new))
        grid.set_values(new, (-((x[:, 0] - x[:, 1]) ** 2))[:, None])
    degrees, coefficients = grid.series()
    return degrees, coefficients, None


def _valley_ridge_probes(runs, limit, tie_limit=0, isolated_limit=0):
    """The valley ridge's maximum and the probes that confirm its extrema (unit square)."""
    degrees, coefficients, correction = _valley_ridge_surrogate()
    low, high = np.array([[-1.0, -1.0]]), np.array([[1.0, 1.0]])
    _, _, arg_low, arg_high = box_extremes(degrees, coefficients, low, high)
    probes = confirmation_probes(
        (degrees, coefficients, correction),
        arg_low,
        arg_high,
        low,
        high,
        np.ones((1, 1)),
        runs,
        np.array([True, True]),
        near=0.02,
        limit=limit,
        tie_limit=tie_limit,
        isolated_limit=isolated_limit,
    )
    return arg_high[0, 0], probes


def test_probes_go_to_the_ends_of_a_flat_crest():
    runs = np.zeros((1, 2))  # one run at the centre
    top, probes = _valley_ridge_probes(runs, limit=8)
    # the crest's two ends, the corners (1, 1) and (-1, -1), and local probes beside the
    # maximum found (across the crest, where the surrogate changes by 1 % of the width);
    # the minimum lies on the corners (1, -1) or (-1, 1), where no direction is free
    ends = {tuple(np.round(p, 6)) for p in probes}
    assert {(1.0, 1.0), (-1.0, -1.0)} <= ends
    beside = [p for p in probes if tuple(np.round(p, 6)) not in {(1.0, 1.0), (-1.0, -1.0)}]
    for point in beside:
        # h = sqrt(2 * 0.01 / 4) = 0.0707 across the crest (curvature 4 along (1, -1))
        assert abs(np.linalg.norm(point - top) - np.sqrt(0.005)) < 1e-6
    # a run at each end confirms them: nothing is left to probe
    _, confirmed = _valley_ridge_probes(np.concatenate((runs, probes)), limit=8)
    assert len(confirmed) == 0
    _, none = _valley_ridge_probes(runs, limit=0)
    assert len(none) == 0


def test_near_ties_are_probed_beyond_the_limit():
    # the flat crest of s = -(x1 - x2)^2 with runs 0.03 across it from both ends: on the
    # ends' scale (MIN_STEP) they look supported, so the local probes beside the maximum
    # (0.07 from every run on their scale of 0.07) fill a limit of 2; the ends, where the
    # surrogate is as high as its maximum (near ties), come on top of it
    runs = np.array([[0.0, 0.0], [0.97, 1.0], [-1.0, -0.97]])
    ends = {(1.0, 1.0), (-1.0, -1.0)}
    probed = {}
    for ties in (0, 2):
        _, probes = _valley_ridge_probes(runs, limit=2, tie_limit=ties)
        assert len(probes) == 2 + ties
        probed[ties] = {tuple(np.round(p, 6)) for p in probes}
    assert not ends & probed[0]
    assert ends <= probed[2]


def test_isolated_extrema_are_run_beyond_the_ties():
    # s = -(x1 - x2)^2 has its minimum on the corners (1, -1) and (-1, 1), where no
    # direction is free: steps 1 to 6 leave it alone, step 7 runs it when no run lies
    # within ISOLATED (0.1) of it, after every other probe of the batch
    runs = np.array([[0.0, 0.0], [1.0, 1.0], [-1.0, -1.0]])
    _, plain = _valley_ridge_probes(runs, limit=8)
    _, more = _valley_ridge_probes(runs, limit=8, isolated_limit=2)
    np.testing.assert_array_equal(more[: len(plain)], plain)
    corner = more[len(plain) :]
    # one corner of the minimum (the one the box search returns), and the maximum's point
    # is supported by the probes across the crest: one isolated extremum
    assert corner.shape == (1, 2) and abs(corner[0, 0] - corner[0, 1]) == 2.0
    # a run 0.05 from that corner supports it; a run 0.15 away does not
    for offset, extra in ((0.05, 0), (0.15, 1)):
        near = corner - offset * np.sign(corner)
        _, probes = _valley_ridge_probes(np.concatenate((runs, near)), limit=8, isolated_limit=2)
        assert len(probes) == len(plain) + extra


@pytest.mark.slow  # a whole run of the method: 189 runs, 11 s of a test process
def test_a_random_signal_is_certified_within_the_tolerance():
    # random_case(1, 3, 21), a 21-point signal over 3 parameters the method was never
    # tuned on (benchmarks/random_honesty.py), with its gradients: without the isolated
    # extrema it said converged after 183 runs 1.36 % off (0.67 % reported): an edge
    # maximum of element 3 at mu = 0, 2.7 % of the cut width below the surrogate's corner
    # maximum and 0.27 from every run; with them 189 runs, 0.29 % (docs/fuzzy.md, "Models
    # it was never tuned on")
    from fuzzymbs.fuzzy.adaptive import AdaptiveTransformation
    from fuzzymbs.models.closed_form.random_models import random_case

    case = random_case(1, 3, 21)
    engine = AdaptiveTransformation(triangular_numbers(case.triangles), LEVELS, 0.01, 8000, 20_000)
    while not engine.done:
        points = engine.next_batch()
        if len(points) == 0:
            break
        engine.add(points, *case.gradient(dict(zip(engine.names, points.T, strict=True))))
    outcome = engine.outcome()
    truth = polished_truth(case, LEVELS)
    miss = band_miss(outcome.lower["y"], outcome.upper["y"], *truth["y"])
    assert outcome.converged and outcome.error <= 0.01
    assert miss <= TOLERANCE


def test_a_corner_point_climbs_again_within_its_faces():
    # s = -(x1 - 0.3 x2)^2, flat in x3: the maximum's crest x1 = 0.3 x2 moves with x2. From
    # x* = (0.24, 0.8, 0) the line along x3 reaches the x3 faces at (0.24, 0.8, +-1), which
    # the corner rule moves onto the x2 face (0.2 away): there the crest lies at x1 = 0.3,
    # where the corner point climbs to (the rule alone left it at 0.24, 0.0036 below)
    def surface(x):
        return -((x[:, 0] - 0.3 * x[:, 1]) ** 2)

    grid = ChebyshevSparseGrid(3)
    for index in [(0, 0, 0), (1, 0, 0), (0, 1, 0), (2, 0, 0), (0, 2, 0), (1, 1, 0)]:
        new = grid.add_index(index)
        grid.set_values(new, surface(node_values(np.array(new)))[:, None])
    degrees, coefficients = grid.series()
    top = np.array([[[0.24, 0.8, 0.0]]])
    probes = confirmation_probes(
        (degrees, coefficients, None),
        np.array([[[1.0, -1.0, 1.0]]]),  # the minimum, in a corner
        top,
        -np.ones((1, 3)),
        np.ones((1, 3)),
        np.ones((1, 1)),
        top[0],
        np.ones(3, dtype=bool),
        near=0.02,
        limit=100,
    )
    corners = probes[(probes[:, 1] == 1.0) & (np.abs(probes[:, 2]) == 1.0)]
    assert len(corners) == 2
    np.testing.assert_allclose(corners[:, 0], 0.3, atol=1e-6)
    np.testing.assert_allclose(surface(corners), 0.0, atol=1e-12)


def test_rounds_with_confirmation_are_the_same_in_any_chunking():
    # the model sees each round in chunks of 3 or all at once: the same points and bounds,
    # bit for bit (a round's points depend only on the outputs of the rounds before)
    case = sdof_resonance(0.05)
    numbers = triangular_numbers(case.triangles)
    results = []
    for chunk in (3, None):
        scheme = plan(numbers, method="adaptive", levels=LEVELS)
        outputs = scheme.evaluate(case.model, chunk_size=chunk)
        results.append((scheme.samples, scheme.retransform(outputs)["amplitude"]))
    np.testing.assert_array_equal(results[0][0], results[1][0])
    np.testing.assert_array_equal(results[0][1].upper, results[1][1].upper)


def test_a_monotonic_model_needs_no_confirmation():
    # z = x1 x2 on positive boxes: every extremum on a corner, no free direction, no probe:
    # the method's runs are those of the rounds before the confirmation existed (21)
    numbers = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11)}
    scheme = plan(numbers, method="adaptive", levels=4)
    scheme.evaluate(lambda s: {"z": s["x1"] * s["x2"]})
    assert len(scheme) == 21
