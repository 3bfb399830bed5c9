"""How the kernels batch: blocks over threads, and many states through rhs_batch."""

from __future__ import annotations

import threading

import numba
import numpy as np
import pytest

from fuzzymbs.mbs.integrate import evaluate_rhs
from fuzzymbs.mbs.kernels.rhs import make_work, rhs_sample
from fuzzymbs.mbs.kernels.threads import for_each_range, held_threads, round_robin
from fuzzymbs.models.brake import DiscBrake


@pytest.mark.parametrize("tasks", [None, 1, 2, 3, 50])
@pytest.mark.parametrize("n_items", [1, 2, 7, 33])
def test_ranges_cover_every_item_once(n_items, tasks):
    seen = []
    lock = threading.Lock()

    def run(start, stop):
        assert 0 <= start < stop <= n_items
        with lock:
            seen.extend(range(start, stop))

    for_each_range(n_items, run, tasks=tasks)
    assert sorted(seen) == list(range(n_items))


def test_an_exception_in_a_range_reaches_the_caller():
    def run(start, stop):
        if start <= 5 < stop:
            raise ValueError("item 5")

    with pytest.raises(ValueError, match="item 5"):
        for_each_range(9, run)


def test_single_thread_runs_in_order():
    order = []
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        for_each_range(5, lambda a, b: order.extend(range(a, b)))
    finally:
        numba.set_num_threads(previous)
    assert order == [0, 1, 2, 3, 4]


def test_a_call_beside_a_running_one_takes_only_the_free_threads():
    # a call that starts while another holds the configured threads gets one thread (it
    # runs its blocks in order, in its own thread), not a pool beside the running one:
    # the reference run of a study then keeps its core while the pilot runs
    threads = numba.get_num_threads()
    if threads < 2:
        pytest.skip("needs two threads")
    inside, release = threading.Event(), threading.Event()
    seen = {}
    entered = []
    entered_lock = threading.Lock()

    def slow_start(block):
        return block

    def slow_advance(block, state, begin, end):
        # the first call holds every thread once each of its blocks is inside (its helper
        # joins a moment after the caller's block starts: waiting for one block races it)
        with entered_lock:
            entered.append(block)
            if len(entered) == threads:
                inside.set()
        release.wait(10.0)
        return False

    first = threading.Thread(target=round_robin, args=(threads, 1, 1, slow_start, slow_advance))
    first.start()
    try:
        assert inside.wait(10.0)
        seen["held"] = held_threads()
        callers = set()

        def advance(block, state, begin, end):
            callers.add(threading.get_ident())
            return False

        round_robin(4, 1, 1, lambda block: block, advance)
        seen["callers"] = callers
    finally:
        release.set()
        first.join()
    assert seen["held"] == threads
    assert seen["callers"] == {threading.get_ident()}  # one thread: this one
    assert held_threads() == 0  # all given back


def test_a_helper_joins_a_running_call_once_a_core_is_free():
    # the second call starts while the first holds every thread: it works alone, and its
    # helper joins it as soon as the first call ends, while its blocks still run
    threads = numba.get_num_threads()
    if threads < 2:
        pytest.skip("needs two threads")
    inside, release, joined = threading.Event(), threading.Event(), threading.Event()
    callers = {}

    def hold(block, state, begin, end):
        inside.set()
        release.wait(10.0)
        return False

    def second_call():
        def advance(block, state, begin, end):
            callers[block] = threading.get_ident()
            if block == 0:  # the caller's block: release the first call, then wait
                release.set()
                joined.wait(10.0)
            else:
                joined.set()
            return False

        callers["caller"] = threading.get_ident()
        round_robin(2, 1, 1, lambda block: block, advance)

    first = threading.Thread(target=round_robin, args=(threads, 1, 1, lambda b: b, hold))
    first.start()
    assert inside.wait(10.0)
    second = threading.Thread(target=second_call)
    second.start()
    second.join(20.0)
    first.join(20.0)
    assert joined.is_set()
    assert callers[0] == callers["caller"] and callers[1] != callers["caller"]
    assert held_threads() == 0


@pytest.fixture(scope="module")
def brake():
    return DiscBrake(t_end=1e-4).compiled


def test_rhs_batch_equals_one_state_at_a_time(brake):
    # reference: rhs_sample, one state per call with its lanes repeating it. Six states
    # of four parameter rows: the first block shares one time (four lanes of different
    # states), the second mixes times (each state in lanes of its own).
    rng = np.random.default_rng(11)
    params = brake.parameters.values(
        {"nodal_force": 16e3 * rng.uniform(0.9, 1.1, 4), "disc_speed": rng.uniform(1, 50, 4)}
    )
    n = brake.n_state
    states = np.zeros((6, n))
    states[:, : n // 2] = rng.normal(scale=2e-6, size=(6, n // 2))
    for name, offset in (("lower_pad", 55e-6), ("upper_pad", -55e-6)):
        states[:, brake.body_dofs[name].start] += offset  # pads pressed into the disc
    states[:, n // 2 :] = rng.normal(scale=1e-3, size=(6, n // 2))
    rows = np.array([0, 1, 2, 3, 1, 2])
    times = np.array([1e-4, 1e-4, 1e-4, 1e-4, 2e-4, 3e-4])
    got = evaluate_rhs(brake, params, rows, times, states)
    work = make_work(brake.data)
    expected = np.array(
        [rhs_sample(times[i], states[i], params[rows[i]], brake.data, work) for i in range(6)]
    )
    scale = np.abs(expected).max(axis=1, keepdims=True)
    assert (scale > 0).all()
    # a state alone in its block (times differ): the same operations, bit for bit
    np.testing.assert_array_equal(got[4:], expected[4:])
    # four different states in one block may take the per-lane contact path instead of
    # the shared one (same formulas, other FMA contraction): rounding, bound 1e-12 of each
    # state's largest derivative (measured: 0, bit for bit)
    assert (np.abs(got[:4] - expected[:4]) <= 1e-12 * scale[:4]).all()
