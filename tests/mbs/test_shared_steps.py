"""Samples on the modal sample's shared step sequence (:mod:`fuzzymbs.mbs.shared_steps`).

What must hold: the sequence replays the logged steps; a sample's outputs do not
depend on its batch mates; the modal sample's outputs become the reference's; and
the correction makes the band errors smooth, so that bands at a loose rtol on shared
steps match bands at a tight rtol far better than bands on each sample's own steps
(the brake's studies over 10 ms: docs/brake.md; here 0.4 ms, seconds of CPU).
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError, SimulationDivergedError
from fuzzymbs.fuzzy import Triangular, plan
from fuzzymbs.fuzzy.band_scale import width_relative
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.models.brake import DiscBrake
from fuzzymbs.tolerance import Tolerance

T_END = 4e-4
PARAMETERS = {
    "pad_spring_stiffness": Triangular.relative(200e3, 0.1),
    "caliper_spring_stiffness": Triangular.relative(1e3, 0.1),
    "nodal_force": Triangular.relative(16e3, 0.01),
}
OUTPUTS = ("y_lpad", "y_upad", "y_cali")


@pytest.fixture(scope="module")
def scheme():
    return plan(PARAMETERS, "reduced", 3)


def _columns(scheme, rows):
    return {name: scheme.samples[rows, i] for i, name in enumerate(PARAMETERS)}


@pytest.fixture(scope="module")
def shared(scheme):
    return DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3).share_steps(
        _columns(scheme, [scheme.nominal_index])
    )


def test_the_sequence_replays_the_logged_steps():
    # the modal sample replayed on its own logged sequence with the logged Jacobian
    # renewals repeats the logging run: the same accepted steps, none rejected, and the
    # records to the rounding of the step lengths (measured 4e-14 of the pads' peak,
    # 2e-10 of the caliper's); without the renewals its Jacobians have other ages where
    # the logging run rejected a step, and it only agrees to the tolerance (2e-5)
    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3).simulation
    logged = simulate(model.compiled, {}, outputs=model.outputs, log_steps=True, **model.settings)
    sequence, renewals = logged.step_times, logged.step_renewals
    assert sequence[-1] == pytest.approx(T_END, rel=1e-12) and np.all(np.diff(sequence) > 0)
    assert len(sequence) == len(renewals) == logged.step_counts[0, 0]
    assert logged.step_counts[0, 1] > 0 and renewals[0] and renewals.sum() < len(renewals)
    replay = simulate(
        model.compiled,
        {},
        outputs=model.outputs,
        step_sequence=sequence,
        jacobian_renewals=renewals,
        **model.settings,
    )
    own_ages = simulate(
        model.compiled, {}, outputs=model.outputs, step_sequence=sequence, **model.settings
    )
    assert replay.step_counts[0].tolist() == [len(sequence), 0]
    assert own_ages.step_counts[0, 0] >= len(sequence)
    for name in model.outputs:
        peak = np.abs(logged.outputs[name]).max()
        np.testing.assert_allclose(replay.outputs[name], logged.outputs[name], atol=1e-8 * peak)
        np.testing.assert_allclose(own_ages.outputs[name], logged.outputs[name], atol=1e-4 * peak)


def test_a_sample_on_shared_steps_does_not_depend_on_its_batch(scheme, shared):
    alone = shared(_columns(scheme, [5]))
    mixed = shared(_columns(scheme, [9, 3, 5, scheme.nominal_index, 12, 1]))
    for name in OUTPUTS:
        np.testing.assert_array_equal(alone[name][0], mixed[name][2])


def test_an_empty_modal_sample_is_the_models_defaults(scheme, shared):
    # the plan's nominal row is the brake's defaults (200 kN/m, 1 kN/m, 16 kN), so the
    # model shared on {} runs every sample on the fixture's sequence, bit for bit
    brake = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)
    defaults = brake.simulation.compiled.parameters.defaults()
    assert all(defaults[name] == PARAMETERS[name].modal for name in PARAMETERS)
    on_defaults = brake.share_steps({})(_columns(scheme, [5]))
    expected = shared(_columns(scheme, [5]))
    for name in OUTPUTS:
        np.testing.assert_array_equal(on_defaults[name], expected[name])


def test_the_modal_sample_becomes_the_reference(scheme, shared):
    # the modal sample takes the logging run, which the correction also comes from:
    # logging + (reference - logging), the reference to the rounding of one addition
    modal = shared(_columns(scheme, [scheme.nominal_index]))
    reference = shared.simulation.shared.reference
    for name in OUTPUTS:
        peak = np.abs(reference[name]).max()
        deviation = np.abs(modal[name][0] - reference[name]).max() / peak
        assert deviation < 1e-14


@pytest.mark.slow
def test_the_pilots_runs_are_kept_for_the_plan(scheme, monkeypatch):
    # runs through deviations (a study's pilot) are kept, and a later call takes them
    # instead of running them again: bit for bit what the call would have run (a
    # sample's outputs do not depend on its batch), and only the others are run
    import fuzzymbs.mbs.integrate as integrate

    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)
    modal = _columns(scheme, [scheme.nominal_index])
    plan_rows = [9, 3, 5, scheme.nominal_index, 12, 1]
    unkept = model.share_steps(modal)(_columns(scheme, plan_rows))
    shared = model.share_steps(modal)
    shared.deviations(_columns(scheme, [5, 12, 3]))
    ran = []
    simulate = integrate.simulate

    def counting(system, samples=None, **settings):
        ran.append(len(next(iter(samples.values()))))
        return simulate(system, samples, **settings)

    monkeypatch.setattr(integrate, "simulate", counting)
    kept = shared(_columns(scheme, plan_rows))
    assert ran == [2]  # rows 9 and 1: the modal sample takes the logging run
    for name in OUTPUTS:
        np.testing.assert_array_equal(kept[name], unkept[name])
    shared(_columns(scheme, [scheme.nominal_index]))
    assert ran == [2]  # the modal sample alone: nothing to run
    assert shared.tightened(10.0).simulation.shared.kept.keys() == {
        shared.simulation.compiled.parameters.values(modal)[0].tobytes()
    }  # a tighter model keeps only its own logging run
    shared.tightened(10.0).deviations(_columns(scheme, [5]))
    ran.clear()
    shared.tightened(10.0)(_columns(scheme, [5, 9]))
    assert ran == [1]  # one tighter model per factor: the pilot's runs serve the check


@pytest.mark.slow
def test_shared_steps_bring_loose_bands_to_the_tight_ones(scheme, shared):
    # second method: the same plan on each sample's own steps at rtol 1e-6 (converged:
    # 0.04 % of the cut width off the same at 1e-7, for half its CPU); at rtol 1e-3 the
    # shared steps' bands lie within 2 % of the cut width of those, the own steps' at the
    # same rtol ten times further off (measured 2026-12-02: 0.15 % against 14 %; 0.11 %
    # and 14 % against rtol 1e-7)
    samples = _columns(scheme, list(range(len(scheme))))
    tight = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-6)(samples)
    own = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)(samples)
    on_shared = shared(samples)

    def band_error(out):
        worst = 0.0
        for name in OUTPUTS:
            cut = scheme.retransform({name: out[name]}, check_monotonic=False)[name]
            ref = scheme.retransform({name: tight[name]}, check_monotonic=False)[name]
            deviation = np.maximum(np.abs(cut.lower - ref.lower), np.abs(cut.upper - ref.upper))
            worst = max(worst, float(np.nanmax(width_relative(deviation, ref.lower, ref.upper))))
        return worst

    assert band_error(on_shared) < 0.02
    assert band_error(own) > 10 * band_error(on_shared)


def test_tightened_keeps_the_reference_and_logs_its_own_sequence(shared):
    tight = shared.tightened(10.0)
    assert tight.simulation.shared.reference is shared.simulation.shared.reference
    assert len(tight.simulation.shared.sequence) > len(shared.simulation.shared.sequence)
    assert "on the modal sample's steps" in tight.time_integration
    assert shared.shares_steps and not DiscBrake(t_end=T_END).shares_steps


def test_logged_ahead_names_the_tightened_model_that_takes_the_sequence_logged_ahead(shared):
    # the reference block logs the modal sample at rtol / 10 / 10 (the test below: that
    # model takes the sequence without a logging run); a study's pilot asks before it
    # measures its tighter model's error there (integration_check.choose_tolerance)
    assert shared.tightened(10.0).logged_ahead(10.0)
    assert not shared.logged_ahead(10.0)  # rtol / 10: a sequence of its own
    assert not shared.tightened(10.0).logged_ahead(3.0)
    assert not DiscBrake(t_end=T_END).logged_ahead(10.0)  # no shared steps


@pytest.mark.slow
def test_the_check_sequence_logged_beside_the_reference_is_its_own_logging_run(
    scheme, shared, monkeypatch
):
    # the reference block's third lane logs the modal sample at rtol / 10 / 10: the
    # sequence a tightened-twice model takes from it, without a logging run of its own,
    # is bit for bit the one that model's own logging run gives (lanes are independent)
    import fuzzymbs.mbs.shared_steps as shared_steps

    plain = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3).simulation
    # a hundredth only: a thousandth would be tighter than the reference block's lanes
    assert [(t.rtol, t.atol) for t in shared.simulation.shared.ahead] == [
        ((1e-3 / 10.0) / 10.0, None)
    ]
    modal = {name: float(v[0]) for name, v in _columns(scheme, [scheme.nominal_index]).items()}
    own = shared_steps._logged_run(plain.tightened(10.0).tightened(10.0), modal)

    def no_logging_run(*args):
        raise AssertionError("the sequence logged ahead should have been taken")

    once = shared.tightened(10.0)  # its own logging run (another tolerance)
    monkeypatch.setattr(shared_steps, "_logged_run", no_logging_run)
    twice = once.tightened(10.0).simulation.shared
    np.testing.assert_array_equal(twice.sequence, own.step_times)
    np.testing.assert_array_equal(twice.renewals, own.step_renewals)
    for name in OUTPUTS:
        np.testing.assert_array_equal(twice.modal_outputs[name], own.outputs[name][0])
    assert twice.reference is shared.simulation.shared.reference


@pytest.mark.slow
def test_both_reference_lanes_log_the_sequences_a_study_and_its_check_take(scheme, monkeypatch):
    # at rtol 1e-2 (the brake's) the models tightened twice and three times have the
    # reference runs' tolerances, 1e-4 and 1e-5: both lanes log their steps, and each
    # model takes its lane's run, bit for bit its own logging run (lanes are independent)
    import fuzzymbs.mbs.shared_steps as shared_steps

    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-2)
    modal = {name: float(v[0]) for name, v in _columns(scheme, [scheme.nominal_index]).items()}
    shared = model.share_steps(modal)
    ahead = shared.simulation.shared.ahead
    assert [t.rtol for t in ahead] == [1e-2 / 10 / 10, 1e-2 / 10 / 10 / 10]
    assert ahead[1].rtol == shared_steps.REFERENCE_RTOL
    tenth = shared.tightened(10.0)  # its own logging run
    assert tenth.logged_ahead(10.0) and tenth.tightened(10.0).logged_ahead(10.0)
    assert not tenth.tightened(10.0).tightened(10.0).logged_ahead(10.0)  # 1e-6
    plain = model.simulation
    own = [
        shared_steps._logged_run(plain.tightened(10.0).tightened(10.0), modal),
        shared_steps._logged_run(plain.tightened(10.0).tightened(10.0).tightened(10.0), modal),
    ]

    def no_logging_run(*args):
        raise AssertionError("the sequence logged ahead should have been taken")

    monkeypatch.setattr(shared_steps, "_logged_run", no_logging_run)
    hundredth = tenth.tightened(10.0)
    for taken, alone in zip((hundredth, hundredth.tightened(10.0)), own, strict=True):
        steps = taken.simulation.shared
        np.testing.assert_array_equal(steps.sequence, alone.step_times)
        np.testing.assert_array_equal(steps.renewals, alone.step_renewals)
        for name in OUTPUTS:
            np.testing.assert_array_equal(steps.modal_outputs[name], alone.outputs[name][0])
        assert steps.reference is shared.simulation.shared.reference


def test_a_later_lane_whose_log_overflows_is_left_out_and_the_first_kept():
    # the first logged sample's overflow raises (as with one logged sample); a later
    # one's leaves its log out, and the reference block keeps the first lane's sequence
    import fuzzymbs.mbs.shared_steps as shared_steps

    model = DiscBrake(t_end=1e-4, record_interval=1e-5, rtol=1e-2).simulation
    samples = {"nodal_force": np.full(2, 16e3)}
    loose_tight = Tolerance(np.array([1e-2, 1e-5]))
    full = model.simulate(samples, tolerance=loose_tight, log_steps=True, log_samples=2)
    loose, tight = (len(times) for times, _ in full.step_logs)
    assert loose < tight  # 464 against 3,356 steps over 0.1 ms
    short = model.simulate(samples, tolerance=loose_tight, log_steps=loose, log_samples=2)
    assert short.step_logs[1] is None
    np.testing.assert_array_equal(short.step_times, full.step_times)
    with pytest.raises(InvalidParameterError, match="more than the log holds"):
        model.simulate(
            samples, tolerance=Tolerance(np.array([1e-5, 1e-2])), log_steps=loose, log_samples=2
        )
    ahead = shared_steps.ahead_tolerances(model.tolerance)
    lanes = Tolerance(np.array([t.rtol for t in ahead]))  # 1e-4 and 1e-5
    counts = model.simulate(samples, tolerance=lanes, log_steps=True, log_samples=2).step_logs
    real = model.simulate

    def small_log(samples, **settings):  # the reference block's log holds the 1e-4 lane only
        if settings.get("log_steps"):
            settings["log_steps"] = len(counts[0][0])
        return real(samples, **settings)

    model.simulate = small_log
    *_, logged = shared_steps._reference_runs(model, {"nodal_force": 16e3}, ahead)
    assert list(logged) == [(1e-4, None)]


def test_log_samples_is_checked():
    model = DiscBrake(t_end=1e-5, record_interval=1e-5, rtol=1e-2)
    samples = {"nodal_force": np.full(2, 16e3)}
    with pytest.raises(InvalidParameterError, match="log_samples must be 1 to 2"):
        model.simulation.simulate(samples, log_steps=True, log_samples=3)
    with pytest.raises(InvalidParameterError, match="log_samples must be a whole number"):
        model.simulation.simulate(samples, log_steps=True, log_samples=1.5)
    logs = model.simulation.simulate(samples, log_steps=True, log_samples=2).step_logs
    assert len(logs) == 2  # the same sample twice: the same steps
    np.testing.assert_array_equal(logs[0][0], logs[1][0])


@pytest.mark.parametrize(
    ("sequence", "message"),
    [
        (np.array([1e-4, 5e-5, 4e-4]), "increase"),
        (np.array([1e-4, 2e-4]), "end at t_end"),
        (np.array([np.nan, 4e-4]), "finite"),
        (np.array([0.0, 4e-4]), "increase"),
    ],
)
def test_bad_sequences_are_refused(sequence, message):
    model = DiscBrake(t_end=T_END, record_interval=1e-5).simulation
    with pytest.raises(InvalidParameterError, match=message):
        simulate(
            model.compiled, {}, outputs=model.outputs, step_sequence=sequence, **model.settings
        )
    rk4 = {**model.settings, "integrator": "rk4"}
    with pytest.raises(InvalidParameterError, match="ros34pw2"):
        simulate(model.compiled, {}, outputs=model.outputs, step_sequence=np.array([T_END]), **rk4)


def test_bad_renewals_are_refused():
    model = DiscBrake(t_end=T_END, record_interval=1e-5).simulation
    sequence = np.array([2e-4, 4e-4])
    for renewals, message in (
        (np.array([1.0, 0.0]), "bool"),
        (np.array([True]), "length 2"),
    ):
        with pytest.raises(InvalidParameterError, match=message):
            simulate(
                model.compiled,
                {},
                outputs=model.outputs,
                step_sequence=sequence,
                jacobian_renewals=renewals,
                **model.settings,
            )
    with pytest.raises(InvalidParameterError, match="needs a step_sequence"):
        simulate(
            model.compiled,
            {},
            outputs=model.outputs,
            jacobian_renewals=np.array([True]),
            **model.settings,
        )


def test_the_reference_error_predicted_from_two_logging_runs():
    # closed form: with a modal error exactly C r^q (q = REFERENCE_ORDER) at rtol 1e-2
    # and 1e-3, the prediction at the reference's rtol is C r_ref^q
    from fuzzymbs.background import Background
    from fuzzymbs.mbs.shared_steps import (
        REFERENCE_EQUIVALENT_RTOL,
        REFERENCE_ORDER,
        REFERENCE_RTOL,
        SharedSteps,
        predicted_reference_error,
    )

    t = np.linspace(0.0, 1.0, 11)
    error = 3.0 * np.sin(t)  # C(t)
    runs = {}
    for rtol in (1e-2, 1e-3):
        outputs = {"y": np.cos(t) + error * rtol**REFERENCE_ORDER}
        none = Background(dict)
        runs[rtol] = SharedSteps({}, t, t > 0, outputs, none, REFERENCE_RTOL)
    predicted = predicted_reference_error(runs[1e-2], 1e-2, runs[1e-3], 1e-3)
    np.testing.assert_allclose(
        predicted["y"],
        np.abs(error) * REFERENCE_EQUIVALENT_RTOL**REFERENCE_ORDER,
        rtol=1e-9,
        atol=1e-15,
    )


def test_the_reference_is_the_two_runs_extrapolated_with_the_error_law():
    # closed form: runs whose error is exactly C r^q (q = REFERENCE_ORDER) at rtol r and
    # 10 r extrapolate to the exact value, and the error is estimated as C (r / 10)^q,
    # the error of the run a decade tighter
    from types import SimpleNamespace

    from fuzzymbs.mbs.shared_steps import REFERENCE_ORDER, REFERENCE_RTOL, _extrapolated

    t = np.linspace(0.0, 1.0, 11)
    exact, error = np.cos(t), 3.0 * np.sin(t) - 1.0
    r, q = REFERENCE_RTOL, REFERENCE_ORDER
    rows = [exact + error * (10 * r) ** q, exact + error * r**q]  # loose first, tight second
    runs = SimpleNamespace(
        outputs={"y": np.array(rows)},
        failed=np.array([False, False]),
        failure_reason=np.array(["", "non-finite state"]),
        failure_time=np.array([np.nan, 0.5]),
    )
    model = SimpleNamespace(outputs={"y": None})
    reference, estimate = _extrapolated(model, {}, runs, (1, 0))
    np.testing.assert_allclose(reference["y"], exact, rtol=0, atol=1e-14)
    np.testing.assert_allclose(estimate["y"], np.abs(error) * (r / 10) ** q, rtol=1e-9)
    runs.failed[0] = True
    with pytest.raises(SimulationDivergedError, match="at rtol"):
        _extrapolated(model, {"k": 1.0}, runs, (1, 0))


@pytest.mark.slow
def test_runs_ahead_are_kept_and_waited_for(scheme, monkeypatch):
    # run_ahead runs its samples in the background and keeps them; the next call waits
    # for them and runs only the others, bit for bit as without them
    import pickle

    import fuzzymbs.mbs.integrate as integrate

    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)
    modal = _columns(scheme, [scheme.nominal_index])
    rows = [9, 3, 5, 12]
    plain = model.share_steps(modal)(_columns(scheme, rows))
    shared = model.share_steps(modal)
    ran, then = [], []
    simulate = integrate.simulate

    def counting(system, samples=None, **settings):
        ran.append(len(next(iter(samples.values()))))
        return simulate(system, samples, **settings)

    monkeypatch.setattr(integrate, "simulate", counting)
    shared.run_ahead(_columns(scheme, [5, 12]), then=lambda: then.append(True))
    ahead = shared(_columns(scheme, rows))
    assert ran == [2, 2] and then == [True]  # the two ahead, then rows 9 and 3
    for name in OUTPUTS:
        np.testing.assert_array_equal(ahead[name], plain[name])
    shared.run_ahead(_columns(scheme, [1]))
    copy = pickle.loads(pickle.dumps(shared))  # waits for the runs ahead, takes them along
    assert len(copy.simulation.shared.kept) == 4  # the modal sample, rows 5, 12 and 1
    with pytest.raises(InvalidParameterError, match="shared steps"):
        model.run_ahead(_columns(scheme, [1]))


def test_deviations_are_the_outputs_less_the_modal_sample(scheme, shared):
    # deviations need no reference run: shared(samples) = deviations + reference, to
    # rounding (the modal sample's outputs minus its own outputs plus the reference)
    samples = _columns(scheme, [2, 7, scheme.nominal_index])
    corrected = shared(samples)
    deviations = shared.deviations(samples)
    reference = shared.simulation.shared.reference
    for name in OUTPUTS:
        peak = np.abs(reference[name]).max()
        np.testing.assert_allclose(
            deviations[name] + reference[name], corrected[name], rtol=0, atol=1e-12 * peak
        )
        assert np.abs(deviations[name][2]).max() <= 1e-8 * peak  # the modal sample itself
    with pytest.raises(InvalidParameterError, match="shared steps"):
        DiscBrake(t_end=T_END).deviations(samples)


@pytest.mark.slow
def test_a_pickled_model_takes_its_pending_reference_along(scheme):
    # a model whose reference runs are still going pickles with their result (waiting
    # for it), so that worker processes get the same correction
    import pickle

    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)
    shared = model.share_steps(_columns(scheme, [scheme.nominal_index]))
    copy = pickle.loads(pickle.dumps(shared))
    samples = _columns(scheme, [4, 11])
    for name in OUTPUTS:
        np.testing.assert_array_equal(copy(samples)[name], shared(samples)[name])


@pytest.mark.slow
def test_a_prepared_tightened_model_is_the_tightened_model(scheme, shared):
    # the check's tighter model, built in the background: the same outputs as one built
    # on the spot; a copy (or a pickled model) builds its own
    import copy

    samples = _columns(scheme, [6])
    direct = shared.tightened(10.0)
    simulation = copy.copy(shared.simulation)
    simulation.prepare_tightened(10.0)
    prepared = simulation.tightened(10.0)
    assert simulation.tightened(10.0) is prepared  # built once
    other = simulation.tightened(5.0)
    assert other is not prepared  # another factor: another model, kept as well
    assert simulation.tightened(5.0) is other
    assert simulation.tightened(10.0) is prepared
    assert copy.copy(simulation)._prepared == {}
    for name in OUTPUTS:
        np.testing.assert_array_equal(prepared(samples)[name], direct.simulation(samples)[name])


@pytest.mark.slow
def test_a_sequence_too_coarse_for_the_tolerance_is_left():
    # the error control still guards the steps along a sequence (up to SHARED_ACCEPT):
    # on a sequence logged at rtol 1e-1 (itself 10 % of the pads' peak off a converged
    # run at rtol 1e-7, 37 % of the caliper's), a sample at rtol 1e-4 rejects many
    # points and takes its own smaller steps in between; its records then lie within
    # 1 % of the sequence's own error from the converged run (measured 0.4 %: 3.9e-4 of
    # the pads' peak, against 4e-5 on its own steps at rtol 1e-4)
    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-4).simulation
    coarse = model.simulate({}, tolerance=Tolerance(1e-1), log_steps=True)
    on_coarse = model.simulate(
        {}, step_sequence=coarse.step_times, jacobian_renewals=coarse.step_renewals
    )
    converged = model.simulate({}, tolerance=Tolerance(1e-7))
    assert on_coarse.step_counts[0, 1] > 0
    assert on_coarse.step_counts[0, 0] > 2 * len(coarse.step_times)
    for name in OUTPUTS:
        peak = np.abs(converged.outputs[name]).max()
        sequence_error = np.abs(coarse.outputs[name] - converged.outputs[name]).max() / peak
        error = np.abs(on_coarse.outputs[name] - converged.outputs[name]).max() / peak
        assert error < 0.01 * sequence_error and error < 1e-3


def test_background_results_errors_and_pickling():
    import pickle

    from fuzzymbs.background import Background
    from fuzzymbs.errors import SimulationDivergedError

    assert Background(lambda a, b: a + b, 2, 3).result() == 5
    copy = pickle.loads(pickle.dumps(Background(sorted, [3, 1, 2])))
    assert copy.result() == [1, 2, 3]

    def fails():
        raise SimulationDivergedError("the reference run failed")

    failing = Background(fails)
    for _ in range(2):  # every call re-raises
        with pytest.raises(SimulationDivergedError, match="reference run failed"):
            failing.result()


@pytest.mark.slow
def test_samples_of_one_batch_at_their_own_tolerances():
    # one rtol per sample: each lane keeps its own error control, so each sample's
    # outputs are bit for bit those of its run alone (the reference and its companion
    # share a block this way)
    model = DiscBrake(t_end=T_END, record_interval=1e-5).simulation
    twice = {"nodal_force": np.array([16e3, 16e3]), "pad_spring_stiffness": np.array([2e5, 2.2e5])}
    both = model.simulate(twice, tolerance=Tolerance(np.array([1e-6, 1e-4])))
    for row, rtol in enumerate((1e-6, 1e-4)):
        alone = model.simulate(
            {name: values[row : row + 1] for name, values in twice.items()},
            tolerance=Tolerance(rtol),
        )
        for name in OUTPUTS:
            np.testing.assert_array_equal(both.outputs[name][row], alone.outputs[name][0])
    assert both.step_counts[0, 0] > 3 * both.step_counts[1, 0]
    with pytest.raises(InvalidParameterError, match="one per sample"):
        model.simulate(twice, tolerance=Tolerance(np.array([1e-6, 1e-5, 1e-4])))
    with pytest.raises(InvalidParameterError, match="rtol must be in"):
        model.simulate(twice, tolerance=Tolerance(np.array([1e-6, 0.0])))


def test_own_steps_undo_the_shared_steps_bit_for_bit(scheme, shared):
    # the band check's independent model (fuzzymbs.study.band_check.independent_model):
    # the shared brake on each sample's own steps, tenfold tighter. Reference: a brake
    # built at that rtol that never shared steps; same kernel, same arithmetic, so the
    # outputs are bit for bit its own
    from fuzzymbs.study.band_check import independent_model

    rows = [1, 5, 12]
    own = independent_model(shared)
    assert shared.shares_steps and not own.shares_steps
    assert own.tolerance.rtol == pytest.approx(1e-4)
    fresh = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-4)
    found, expected = own(_columns(scheme, rows)), fresh(_columns(scheme, rows))
    for name in OUTPUTS:
        np.testing.assert_array_equal(found[name], expected[name])
    with_shared = shared(_columns(scheme, rows))  # the shared model keeps its own steps
    assert not np.array_equal(with_shared["y_lpad"], found["y_lpad"])
