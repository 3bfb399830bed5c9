"""Runs on a shared step sequence take the logging run's Jacobians (ROS34PW2).

What must hold: the logging run keeps each Jacobian it evaluates and, per accepted
step, the one the step took; a run on its sequence reads them instead of evaluating
its own (ROS34PW2 is a W-method, so its order holds with any Jacobian: Rang and
Angermann 2005) and stays within a small fraction of the samples' spread of the same
run with its own Jacobians; the modal sample replayed on its log repeats the logging
run; and bad logs are refused with a clear error.
"""

from __future__ import annotations

import numpy as np
import pytest

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.fuzzy import Triangular, plan
from fuzzymbs.mbs.integrate import simulate
from fuzzymbs.mbs.kernels import jacobian_log
from fuzzymbs.models.brake import DiscBrake

from .test_jacobian import analytic

T_END = 4e-4
PARAMETERS = {
    "pad_spring_stiffness": Triangular.relative(200e3, 0.1),
    "caliper_spring_stiffness": Triangular.relative(1e3, 0.1),
    "nodal_force": Triangular.relative(16e3, 0.01),
}


@pytest.fixture(scope="module")
def brake():
    return DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3).simulation


@pytest.fixture(scope="module")
def logged(brake):
    return simulate(
        brake.compiled, {}, outputs=brake.outputs, log_steps=True, log_jacobians=True,
        **brake.settings,
    )  # fmt: skip


def test_the_logging_run_keeps_the_jacobian_each_step_took(brake, logged):
    rows, step_rows = logged.jacobian_log
    n = brake.compiled.n_dofs
    assert rows.shape == (rows.shape[0], 2 * n * n + 2 * n)
    assert step_rows.shape == logged.step_times.shape
    # a step that renewed takes a new row, the others the row before; rejected tries
    # may renew too, so rows can be skipped, never reused out of order
    assert step_rows[0] >= 0 and np.all(np.diff(step_rows) >= 0)
    renewed = logged.step_renewals[1:]
    assert np.all(np.diff(step_rows)[renewed] > 0) and np.all(np.diff(step_rows)[~renewed] == 0)
    assert rows.shape[0] == step_rows[-1] + 1 >= logged.step_renewals.sum()
    assert logged.work_counts[0, 1] == rows.shape[0]  # every Jacobian evaluated is kept


def test_the_first_row_is_the_jacobian_at_the_initial_state(brake, logged):
    # the row against the kernel's Jacobian evaluated directly at the initial state
    # (tests/mbs/test_jacobian's helper, checked there against a closed form and finite
    # differences): the log's layout and lane 0's values, bit for bit
    compiled = brake.compiled
    n = compiled.n_dofs
    params = compiled.parameters.values({})
    start = brake.initial_state
    x0 = compiled.initial_state(1) if start is None else np.atleast_2d(start)[:1].copy()
    full = analytic(compiled, params, x0, 0.0)[0]
    row = logged.jacobian_log[0][0]
    np.testing.assert_array_equal(row[: n * n].reshape(n, n), full[n:, :n])
    np.testing.assert_array_equal(row[n * n : 2 * n * n].reshape(n, n), full[n:, n:])


def _scheme():
    return plan(PARAMETERS, "reduced", 3)


def test_runs_on_the_log_stay_with_their_own_jacobians(brake, logged):
    # the reduced plan's samples on the logged sequence, with the log and with their
    # own Jacobians: the outputs differ by a small smooth amount (measured 1.2e-4 of the
    # samples' spread over 1 ms; the brake's bands over 10 ms are as far from rtol 1e-6
    # either way, docs/brake.md), and the log's samples evaluate far fewer Jacobians
    scheme = _scheme()
    samples = {name: scheme.samples[:, i] for i, name in enumerate(PARAMETERS)}
    common = dict(
        outputs=brake.outputs, step_sequence=logged.step_times,
        jacobian_renewals=logged.step_renewals, **brake.settings,
    )  # fmt: skip
    own = simulate(brake.compiled, samples, **common)
    taken = simulate(brake.compiled, samples, logged_jacobians=logged.jacobian_log, **common)
    assert not own.failed.any() and not taken.failed.any()
    for name in brake.outputs:
        spread = np.ptp(own.outputs[name], axis=0).max()
        assert np.abs(taken.outputs[name] - own.outputs[name]).max() < 2e-3 * spread
    assert taken.work_counts[:, 1].sum() < 0.2 * own.work_counts[:, 1].sum()


def test_the_modal_sample_on_its_log_repeats_the_logging_run(brake, logged):
    # as its replay with its own Jacobians does (test_shared_steps): the same steps and
    # records to the rounding of the step lengths
    replay = simulate(
        brake.compiled, {}, outputs=brake.outputs, step_sequence=logged.step_times,
        jacobian_renewals=logged.step_renewals, logged_jacobians=logged.jacobian_log,
        **brake.settings,
    )  # fmt: skip
    assert replay.step_counts[0].tolist() == [len(logged.step_times), 0]
    assert replay.work_counts[0, 1] == 0
    for name in brake.outputs:
        peak = np.abs(logged.outputs[name]).max()
        np.testing.assert_allclose(replay.outputs[name], logged.outputs[name], atol=1e-8 * peak)


def test_a_full_log_leaves_the_later_renewals_to_the_samples(brake, logged, monkeypatch):
    # a log's rows take at most LOG_BYTES: past them the logging run keeps no row (its
    # later steps name none, -1) and a run on the sequence evaluates its own Jacobians
    # there. The modal sample replayed on a five-row log then evaluates every other
    # Jacobian of the logging run itself, at the same states, and still repeats the run
    compiled = brake.compiled
    width = 2 * compiled.n_dofs**2 + compiled.n_state
    monkeypatch.setattr(jacobian_log, "LOG_BYTES", 5 * 8 * width)
    short = simulate(
        compiled, {}, outputs=brake.outputs, log_steps=True, log_jacobians=True,
        **brake.settings,
    )  # fmt: skip
    rows, step_rows = short.jacobian_log
    assert rows.shape[0] == 5 and logged.jacobian_log[0].shape[0] > 5
    np.testing.assert_array_equal(rows, logged.jacobian_log[0][:5])
    past = int(np.argmax(step_rows < 0))
    assert past > 0 and np.all(step_rows[past:] < 0) and step_rows[:past].max() == 4
    np.testing.assert_array_equal(short.step_times, logged.step_times)  # logging never steers
    replay = simulate(
        compiled, {}, outputs=brake.outputs, step_sequence=short.step_times,
        jacobian_renewals=short.step_renewals, logged_jacobians=short.jacobian_log,
        **brake.settings,
    )  # fmt: skip
    assert replay.step_counts[0].tolist() == [len(short.step_times), 0]
    assert replay.work_counts[0, 1] == logged.work_counts[0, 1] - 5
    for name in brake.outputs:
        peak = np.abs(logged.outputs[name]).max()
        np.testing.assert_allclose(replay.outputs[name], logged.outputs[name], atol=1e-8 * peak)


def test_a_shared_model_takes_its_logging_runs_jacobians():
    model = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3)
    shared = model.share_steps({}).simulation.shared
    assert shared.jacobians is not None and shared.jacobians[1].shape == shared.sequence.shape
    rodas = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-3, integrator="rodas4")
    assert rodas.share_steps({}).simulation.shared.jacobians is None  # not a W-method


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"log_jacobians": True}, "log_steps"),
        ({"log_jacobians": True, "log_steps": True, "integrator": "rodas4"}, "ros34pw2"),
        ({"logged_jacobians": "log"}, "step_sequence"),
        ({"logged_jacobians": "short", "step_sequence": "seq"}, "one per step"),
        ({"logged_jacobians": "past", "step_sequence": "seq"}, "past the log"),
    ],
)
def test_bad_jacobian_logs_are_refused(brake, logged, overrides, message):
    rows, step_rows = logged.jacobian_log
    choices = {
        "log": (rows, step_rows),
        "short": (rows, step_rows[:-1]),
        "past": (rows[:1], step_rows),
        "seq": logged.step_times,
    }
    overrides = {k: choices.get(v, v) if isinstance(v, str) else v for k, v in overrides.items()}
    settings = {**brake.settings, **overrides}
    with pytest.raises(InvalidParameterError, match=message):
        simulate(brake.compiled, {}, outputs=brake.outputs, **settings)


def test_the_sequence_logged_ahead_first_brings_its_jacobians():
    # the references' block logs the modal sample ahead at rtol / 10 / 10 and once more
    # a tenth of that (rtol 1e-2: its two lanes); its first lane keeps its Jacobians, so
    # the model that takes that sequence takes them too, and the model on the other
    # lane's evaluates its own
    shared = DiscBrake(t_end=T_END, record_interval=1e-5, rtol=1e-2).share_steps({})
    tenth = shared.tightened(10.0)
    assert tenth.logged_ahead(10.0) and tenth.tightened(10.0).logged_ahead(10.0)
    first = tenth.tightened(10.0).simulation.shared
    second = tenth.tightened(10.0).tightened(10.0).simulation.shared
    assert first.sequence.size < second.sequence.size  # each lane's own steps
    assert first.jacobians is not None and first.jacobians[1].shape == first.sequence.shape
    assert second.jacobians is None
