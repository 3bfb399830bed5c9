"""Smoke test of the benchmark code: tiny sizes, structure, and baseline correctness.

Never asserts times. The per-sample baselines must compute the same model as
fuzzymbs, so each is checked against the compiled kernel:

* the NumPy brake RHS + Python RK4 loop (an independent re-implementation of the
  equations) against the batched RK4 kernel's trajectory;
* the interpreted MUBOCO-PR solver (the kernels' source without Numba) against
  the compiled batched STE;
* the flop counts (RK4, Rosenbrock, sensitivities) against hand counts.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"
sys.path.insert(0, str(BENCH))


@pytest.fixture(scope="module")
def brake():
    brake_bench = pytest.importorskip("brake_bench")
    return brake_bench, brake_bench.brake_model(40e-6, record_interval=5e-6)


def test_numpy_brake_loop_reproduces_the_kernel_trajectory(brake):
    from brake_numpy import NumpyRHS, rk4_numpy

    brake_bench, model = brake
    sample = {
        "pad_spring_stiffness": 210e3,
        "caliper_spring_stiffness": 0.95e3,
        "nodal_force": 16.1e3,
    }
    rhs = NumpyRHS(model.compiled.data, brake_bench.parameter_row(model, sample)[0])
    x0 = np.zeros(model.compiled.n_state)
    ours = rk4_numpy(rhs, x0, 1e-6, 40, 5, brake_bench.output_matrix(model))
    kernel = brake_bench.kernel_outputs(model, sample)
    assert ours.shape == kernel.shape == (3, 9)
    # same equations, same RK4 steps: only round-off (and the kernel's reassociating
    # fastmath) separates them; 1e-9 relative to the pads' motion (~1e-5 m here)
    scale = np.max(np.abs(kernel[:2]))
    assert scale > 1e-6  # the pads really moved
    np.testing.assert_allclose(ours, kernel, rtol=0, atol=1e-9 * scale)
    assert rhs.stats.active > 0  # contact was closed during the run


def test_numpy_rhs_matches_engine_rhs_at_a_random_state(brake):
    from brake_numpy import NumpyRHS

    brake_bench, model = brake
    params = brake_bench.parameter_row(model)
    rng = np.random.default_rng(3)
    state = 1e-6 * rng.standard_normal(model.compiled.n_state)
    engine = brake_bench.engine_rhs(model, params)(2.5e-3, state)
    ours = NumpyRHS(model.compiled.data, params[0])(2.5e-3, state)
    np.testing.assert_allclose(ours, engine, rtol=0, atol=1e-9 * np.max(np.abs(engine)))


def test_interpreted_gear_solver_equals_compiled():
    from gear_bench import interpreted_ste
    from interpreted import interpreted_gear_solver

    from fuzzymbs.models.gears import gear_pair_model

    model = gear_pair_model(positions=4)
    samples = {"tooth_stiffness": np.array([14000.0]), "contact_stiffness": np.array([9e8])}
    compiled = model(samples)["ste"]
    plain = interpreted_ste(model, samples, interpreted_gear_solver())
    # identical source and arithmetic order: equal to a few ulps of the STE (~1e-5 m)
    np.testing.assert_allclose(plain, compiled, rtol=1e-12, atol=1e-18)


def test_flop_count_terms(brake):
    from brake_flops import RK4_STAGES, step_flops

    _, model = brake
    data = model.compiled.data
    count = step_flops(data, active_fraction=0.5)
    bi = data[1]
    # kinematics: 2 products (U, Udot) x 2 flops x 3 components x nodes x modes per body
    modal = sum(4 * 3 * (row[5] - row[4]) * row[3] for row in bi)
    assert count["rhs_terms"]["kinematics"] >= modal
    assert count["flops_per_sample_step"] > RK4_STAGES * count["flops_per_rhs"]
    assert count["coordinates"] == data[0]
    more = step_flops(data, active_fraction=1.0)["flops_per_sample_step"]
    assert more > count["flops_per_sample_step"]  # contact work grows with touching nodes


def test_rosenbrock_flop_count_by_hand(brake):
    from brake_flops import (
        jacobian_flops,
        lu_flops,
        rhs_flops,
        rosenbrock_flops,
        sensitivity_flops,
        stage_solve_flops,
    )

    _, model = brake
    data = model.compiled.data
    n = int(data[0])
    # LU: dense 3 x 3 (steps k = 0, 1, 2: 1 + 2 + 8, 1 + 1 + 2, 1); two uncoupled 2 x 2
    # blocks (1 + 3 + 6, then 1 + 2 with nothing below coupled, 1 + 1 + 2, 1)
    assert lu_flops(n=3) == 16
    assert lu_flops(np.kron(np.eye(2), np.ones((2, 2))) != 0) == 18
    assert lu_flops(n=n) == n * (n - 1) / 2 + n + 2 * sum(m * m for m in range(n))
    # stage solve, n = 2: A_q r_q with gamma h and r_v (8 + 4), substitutions (2 + 2 + 2
    # divisions), u_q (4)
    assert stage_solve_flops(2) == 22
    # contact products: every pass couples the disc (16 modes) and a pad (1 + 8), 25
    # columns; 146 checked points, 3 rows each into two matrices, then each pass's sums
    full = jacobian_flops(data, active_fraction=1.0)
    assert full["contact_products"] == 12 * 25**2 * 146 + 4 * 2 * 25**2
    assert jacobian_flops(data, active_fraction=0.0)["contact_products"] == 0
    # one accepted step on a fresh LU: 3 stage right-hand sides, the stage matrix and its
    # LU, 4 stage solves, combinations sum_s (4 s + 2) 2n + (4 * 4 + 5) 2n = 106 n
    f_rhs = sum(rhs_flops(data, 1.0).values())
    one = {"accepted": 1, "rejected": 0, "rhs": 3, "jacobians": 0, "lus": 1}
    parts = rosenbrock_flops(data, one, 1.0)
    expected = 3 * f_rhs + 2 * n * n + n + lu_flops(n=n) + 4 * (4 * n * n + 3 * n) + 106 * n
    assert sum(parts.values()) == pytest.approx(expected, rel=1e-12)
    # linear in the counters; a Jacobian adds its own right-hand side and more
    double = rosenbrock_flops(data, {key: 2 * value for key, value in one.items()}, 1.0)
    assert sum(double.values()) == pytest.approx(2 * expected, rel=1e-12)
    more = rosenbrock_flops(data, {**one, "jacobians": 1}, 1.0)
    assert sum(more.values()) - expected > sum(full.values()) > f_rhs
    # sensitivities, one parameter and step: 3 differences (f + 4 per entry), 4 solves,
    # S_s and the stage sums (0 + 4 + 8 + 12) 2n, S_new 2 * 4 * 2n
    sens = sensitivity_flops(data, accepted=1, sens_rhs=3, parameters=1, active_fraction=1.0)
    by_hand = 3 * (f_rhs + 8 * n) + 4 * stage_solve_flops(n) + 64 * n
    assert sum(sens.values()) == pytest.approx(by_hand, rel=1e-12)


def test_targets_and_table_structure():
    import run

    figures = {key: 1.0 for key, _, _ in run.TARGETS}
    figures["brake_study_seconds"] = 10.0
    rows = run.targets(figures)
    assert set(rows) == {key for key, _, _ in run.TARGETS}
    assert rows["brake_study_seconds"]["met"] is False
    assert rows["brake_study_seconds"]["factor_missing"] == pytest.approx(2.0)
    assert rows["gear_study_seconds"]["met"] is True
    figures["targets"] = rows
    assert "brake_study_seconds" in run.table(figures)
    json.dumps(figures, allow_nan=False)


@pytest.mark.slow
def test_parameter_scaling_counts_runs():
    import scaling

    rows = scaling.parameter_scaling(max_parameters=3, levels=2)
    # general method: sum_{k=1}^{m+1} k^n points per parameter count n (THEORY section 1)
    assert [r["runs_without_reuse"] for r in rows] == [1 + 4 + 9, 1 + 8 + 27]
    assert all(0 < r["runs"] <= r["runs_without_reuse"] for r in rows)


def test_exudyn_reduced_pad_agrees_with_fuzzymbs():
    pytest.importorskip("exudyn")  # optional benchmark dependency
    import brake_exudyn

    ours, _ = brake_exudyn.run_fuzzymbs(steps=40, batch=2, record_every=5)
    theirs, _ = brake_exudyn.run_exudyn(steps=40, record_every=5)
    assert ours.shape == theirs.shape == (9,)
    # same bodies, forces and contact law in both codes; they differ only in the disc
    # surface velocity (exact in the Exudyn callback, interpolated from the patch nodes in
    # fuzzymbs), which moves the pad's y by well under 1e-4 of its motion (~1e-5 m here)
    scale = np.max(np.abs(ours))
    assert scale > 1e-6
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-4 * scale)


@pytest.mark.slow
def test_lane_sharing_counts_shared_and_split_cells(brake):
    # the counter behind the 99.97 % of docs/embs.md: identical lanes always share
    # their cells; lanes whose discs turn at 1 and 400 rad/s drift apart by more than
    # two polar cells in 0.3 ms, so some look-ups must be split
    from lane_sharing import _count_shared

    from fuzzymbs.mbs.kernels.layout import C_NSLAVE
    from fuzzymbs.mbs.kernels.simd import LANES as L

    compiled = brake[1].compiled
    data = compiled.data
    same = np.ascontiguousarray(np.repeat(compiled.parameters.values({}), L, axis=0))
    counts = np.zeros((data[11].shape[0], 2), dtype=np.int64)
    _count_shared(data, same, 300, 1e-6, 10, counts)
    assert counts[:, 1].sum() == 30 * data[11][:, C_NSLAVE].sum()  # 30 looks x all slaves
    assert (counts[:, 0] == counts[:, 1]).all()
    speeds = np.array([1.0, 400.0, 1.0, 400.0])
    apart = np.ascontiguousarray(compiled.parameters.values({"disc_speed": speeds}))
    counts[:] = 0
    _count_shared(data, apart, 300, 1e-6, 10, counts)
    assert counts[:, 0].sum() < counts[:, 1].sum()


@pytest.mark.slow
def test_ros_accuracy_table_runs():
    # the script behind the ROS34PW2 figures of docs/theory.md, on a
    # 50 us window: every integrator close to the fine RK4 reference there
    import ros_accuracy

    figures = ros_accuracy.table(5e-5, (1e-3, 1e-4))
    for sample in ("nominal", "corner"):
        assert figures[sample]["ros34pw2_rtol_0.0001"]["error"] < 1e-3
        assert figures[sample]["ros34pw2_rtol_0.001"]["steps_accepted_rejected"][0] > 0
        assert figures[sample]["rk4_1us"]["steps"] == 50


def test_box_search_times_the_correction_against_the_three_terms_it_replaced():
    # the script behind the correction's speed-up (CHANGELOG): both ways give the same
    # values, to round-off (the same sums in another order)
    import box_search

    figures = box_search.correction_values(repeats=1)
    assert figures["largest_difference_relative"] < 1e-12
    assert figures["three_terms_ms"] > 0 and figures["one_product_ms"] > 0


@pytest.mark.slow
def test_brake_sensitivities_cost_times_shared_steps_too():
    # the script behind the sensitivities' cost on shared steps (docs/brake.md), over
    # 20 us: the block on the nominal sample's logged sequence and Jacobians, without and
    # with study 1's three parameters, the ratio against the run without in the same call
    import brake_sensitivities

    report = brake_sensitivities.cost(2e-5, [1e-2], repeats=1)
    shared = report["ros34pw2 rtol 0.01 shared steps"]
    assert set(shared) == {"none", "study 1 (3)"}
    assert shared["none"]["cpu_ratio"] == 1.0
    assert shared["none"]["rhs_jac_lu_sens_rhs"][3] == 0  # no sensitivity right-hand sides
    assert shared["study 1 (3)"]["rhs_jac_lu_sens_rhs"][3] > 0
    assert shared["study 1 (3)"]["rhs_ratio"] > 1.0
    # as a study's runs: the lanes take the logging run's Jacobians, none of their own
    assert shared["none"]["rhs_jac_lu_sens_rhs"][1] == 0
    assert report["ros34pw2 rtol 0.01"]["none"]["rhs_jac_lu_sens_rhs"][1] >= 1


@pytest.mark.slow
def test_brake_sensitivities_rk4_part_reports_errors_steps_and_cost(tmp_path, monkeypatch):
    # the script behind the RK4 derivatives' figures (docs/brake.md), over 20 us: errors
    # against the reference, the change between two steps and the cost, the step restored
    import brake_sensitivities

    import fuzzymbs.mbs.central_differences as central_differences

    monkeypatch.setattr(brake_sensitivities, "CACHE", tmp_path)
    report = brake_sensitivities.rk4(2e-5, 2e-5, repeats=1)
    assert set(report["errors"]) == set(report["step_change_1e-4_to_1e-5"]) == {
        "y_lpad", "y_upad", "y_cali",
    }  # fmt: skip
    assert set(report["errors"]["y_lpad"]["relative"]) == {"k", "k_c", "F_n", "omega"}
    assert report["cost"]["cpu_ratio"] > 1.0
    assert central_differences.GRADIENT_STEP == 1e-4


@pytest.mark.slow
def test_jacobian_age_runs_each_age_and_restores_the_default(tmp_path):
    # the script behind the Jacobian age's figures (docs/benchmarks.md), over 0.1 ms:
    # its default-age coefficients are the kernel's, every age runs and is judged
    # against the rtol 1e-6 truth, and the kernel's coefficients are put back
    import jacobian_age

    import fuzzymbs.mbs.integrate as integrate
    from fuzzymbs.mbs.kernels import rosenbrock_methods as methods

    for ours, kernels in zip(
        jacobian_age.with_age(methods.JACOBIAN_AGE), methods.COEFFICIENTS, strict=True
    ):
        np.testing.assert_array_equal(ours, kernels)
    ages = jacobian_age.measure(1e-4, 1e-3, (5, 10), rounds=1, cache=tmp_path)
    assert set(ages) == {"5", "10"}
    for entry in ages.values():
        assert entry["steps"] > 0
        assert 0.0 < entry["band_error_percent"] < 50.0  # a 0.1 ms window at rtol 1e-3
    assert integrate.METHODS["ros34pw2"] is methods.COEFFICIENTS
    assert (tmp_path / "jacobian_age_truth_0.0001.npz").exists()


@pytest.mark.slow
def test_study_rerun_runs_a_study_three_times(tmp_path):
    # the script behind the rerun and resume figures of docs/benchmarks.md, on a 0.5 ms
    # brake study: run again finished it evaluates nothing, after losing a round only
    # that round's runs, and both results are the fresh run's bit for bit
    import study_rerun

    study = tmp_path / "short.toml"
    study.write_text(
        """
[study]
name = "short-brake"
method = "adaptive"
levels = [0.0, 0.5, 1.0]
outputs = ["y_lpad"]
[model]
name = "brake"
[model.options]
t_end = 5e-4
record_interval = 1e-5
[parameters.pad_spring_stiffness]
type = "triangular"
modal = 200e3
spread = 0.1
[parameters.nodal_force]
type = "triangular"
modal = 16e3
spread = 0.01
""",
        encoding="utf-8",
    )
    figures = study_rerun.rerun(study, study_rerun.REPO / "src", lose=1)
    assert figures["fresh"]["evaluated"] > 0 and figures["rounds"] >= 2
    assert figures["finished"]["evaluated"] == 0 and figures["finished"]["same_as_fresh"]
    lost = figures["interrupted"]
    assert 0 < lost["evaluated"] < figures["fresh"]["evaluated"] and lost["same_as_fresh"]
    assert all(figures[k]["wall_s"] > 0 for k in ("fresh", "finished", "interrupted"))


@pytest.mark.slow
def test_compare_checkouts_runs_both_sides():
    # the script behind the before/after tables of docs/benchmarks.md, this checkout
    # against itself on a 0.1 ms study: both sides report two timed studies per round
    import compare_checkouts

    figures = compare_checkouts.compare(
        compare_checkouts.REPO, 1, False, t_end=1e-4, ros_t_end=5e-5
    )
    for side in ("this", "other"):
        assert len(figures[side]["study1"]) == 2
        assert figures[side]["study1_wall_min"] > 0
        wall, cpu = figures[side]["rk4_calls_min"]  # the model called alone
        assert wall > 0 and cpu > 0
        # ROS34PW2 without and with the sensitivities: [wall, CPU] each
        (ros,) = figures[side]["ros_calls"]
        assert len(ros) == 2 and all(wall > 0 and cpu > 0 for wall, cpu in ros)
    assert figures["study1_wall_this_over_other"] > 0
    assert figures["rk4_calls_wall_this_over_other"] > 0
    assert figures["ros_cpu_this_over_other"] > 0
    assert figures["ros_sensitivities_cpu_this_over_other"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("path", ["rk4", "ros"])
def test_kernel_profile_runs_its_workload_and_writes_a_perf_map(path, capsys):
    # the workloads behind docs/benchmarks.md's kernel profiles, run once without perf;
    # the perf map lists the functions compiled in this process (none when all were
    # loaded from Numba's cache), one "start size name" line each
    import os

    import kernel_profile

    kernel_profile.main(["--path", path, "--repeats", "1"])
    err = capsys.readouterr().err
    assert "T0 " in err and "cpu per run" in err
    with open(f"/tmp/perf-{os.getpid()}.map") as perf_map:
        for line in perf_map:
            start, size, name = line.split()
            assert int(start, 16) > 0 and int(size, 16) > 0 and name


@pytest.mark.slow
def test_ros_parts_runs():
    # the script behind the split of a ROS34PW2 step in docs/theory.md and benchmarks.md
    import ros_parts

    figures = ros_parts.parts(repeats=0.001)
    assert set(figures) == {"rhs_ms", "jacobian_ms", "lu_ms", "solve_ms"}
    assert all(value > 0 for value in figures.values())


@pytest.mark.slow
def test_work_precision_diagram_runs(tmp_path):
    import brake_work_precision

    figures = brake_work_precision.main(quick=True, figure=tmp_path / "wp.png", budget=120.0)
    rows = {(r["integrator"], r["setting"]): r for r in figures["rows"]}
    rk4 = [r for r in figures["rows"] if r["integrator"] == "RK4"]
    assert all(np.isfinite(r["error"]) for r in rk4)
    assert rk4[1]["error"] < rk4[0]["error"]  # the halved RK4 step is nearer the reference
    # SciPy's Radau with the analytic Jacobian (a second method) agrees with the 15.6 ns
    # RK4 reference to 1e-3 of the peak over 0.2 ms (measured 1e-4)
    assert rows[("SciPy Radau", "rtol 0.001")]["error"] < 1e-3
    assert (tmp_path / "wp.png").stat().st_size > 1000


@pytest.mark.slow
def test_brake_stiffness_explains_the_explicit_pairs_and_checks_the_jacobian():
    # benchmarks/brake_stiffness.py over the first 0.1 ms (14 s; docs/benchmarks.md
    # "Explicit pairs on the brake" holds the 1 ms run)
    import brake_stiffness

    report = brake_stiffness.main(["explicit", "eigen", "jvp", "jvp_cost"], 1e-4)
    rows = {(r["integrator"], r["rtol"], r.get("note", "")): r for r in report["explicit"]}
    rk45 = [rows[("SciPy RK45", rtol, "")]["rhs"] for rtol in brake_stiffness.RTOLS]
    # bound by stability, not accuracy: a hundredfold tighter rtol costs at most 30 % more
    # right-hand sides (measured 10 %; bound by accuracy, a fifth-order pair would take
    # 100^(1/5) = 2.5 times as many)
    assert max(rk45) < 1.3 * min(rk45)
    # the stiffness is the regularised friction's: without it RK45 takes a tenth of them
    # (measured 697 against 13,549)
    assert rows[("SciPy RK45", 1e-4, "friction_coefficient 0")]["rhs"] < 0.1 * rk45[1]
    # each integrator converges to the same answer: ROS34PW2 and RK45 at rtol 1e-5 within
    # 1e-4 of the outputs' peaks of ROS34PW2 at 1e-7 (measured 5.5e-7 and 2.8e-6)
    assert rows[("ROS34PW2", 1e-5, "")]["error"] < 1e-4
    assert rows[("SciPy RK45", 1e-5, "")]["error"] < 1e-4
    eigen = report["eigen"]
    frictionless = [r for r in eigen if r["note"]]
    # without friction the contact is conservative and the model undamped: a purely
    # imaginary spectrum (closed form of an undamped linear system; real parts measured
    # below 1e-10 against 2.3e5 rad/s)
    assert all(
        max(abs(r["most_negative_real"]), abs(r["largest_real"])) < 1e-6 * r["largest_imaginary"]
        for r in frictionless
    )
    # with it, real eigenvalues of mu f_N / eps order below -1e6 1/s at every time
    # (measured -7.5e6 to -1.2e8), which bound RK4 below the paper's 1 us
    friction = [r for r in eigen if not r["note"]]
    assert all(r["most_negative_real"] < -1e6 for r in friction)
    assert all(r["rk4_step_bound_s"] < 1e-6 for r in friction)
    # the analytic Jacobian times the sensitivity directions against the differences the
    # sensitivities take: within 2e-3 relative wherever the direction is resolved
    # (measured at most 2.1e-5 here, 6.6e-4 over 1 ms)
    resolved = [r for r in report["jvp"] if r["resolved"]]
    assert len(resolved) >= 12
    assert all(r["vs_forward_1e-4"] < 2e-3 for r in resolved)
    # the prototype product from the contact record against the difference of the
    # contact passes' forces (a second method): within 2e-3 (measured 7e-5 here, 9.6e-4
    # over 1 ms); its time is reported, not asserted
    cost = report["jvp_cost"]
    assert len(cost) == 5 and all(r["vs_difference"] < 2e-3 for r in cost)
    assert all(r["rhs_us"] > 0 and r["linear_contact_us"] > 0 for r in cost)


@pytest.mark.slow
def test_memory_scaling_quick_reports_both_cases():
    import memory_scaling

    row = memory_scaling.measure(2, False)  # 5^3 = 125 runs in a fresh interpreter
    assert row["runs"] == 125 and row["keep_raw"] is False
    assert not row["result_has_samples"]  # keep_raw=False: no raw outputs in the result
    assert row["peak_mb"] >= row["baseline_peak_mb"] > 0


@pytest.mark.slow
def test_dask_scaling_quick_runs():
    # 3^5 = 243 gear runs inline and on small local clusters: structure and bit-identity
    pytest.importorskip("distributed")
    import dask_scaling

    figures = dask_scaling.main(quick=True, diagnostics=False)
    assert figures["study"]["runs"] == 3**5
    assert all(r["identical_to_inline_1_thread"] for r in figures["variants"].values())


def test_external_models_quick_reproduces_the_cvode_table():
    # the convergence table behind the FMU default rtol 1e-6 (docs/studies.md, "FMU models"):
    # the model-exchange error falls with the tolerance, 3.9e-5 of the peak at the default
    import shutil

    if shutil.which("cc") is None:
        pytest.skip("no C compiler to build the example FMU")
    import external_models

    figures = external_models.main(["--quick"])
    errors = figures["cvode_error_by_rtol"]
    assert errors["1e-06"] == pytest.approx(3.9e-5, rel=0.5)
    assert errors["0.0001"] > errors["1e-06"] > errors["1e-08"]
    assert figures["fmi2_reuse_factor"] > 1.0 and figures["command_run_ms"] > 0.0


@pytest.mark.slow
def test_tolerance_study_quick_is_identical_on_dask():
    pytest.importorskip("distributed")
    import tolerance_study

    figures = tolerance_study.main(["--quick"])
    assert [row["runs"] for row in figures["rows"]] == [729, 729]
    assert figures["dask_identical_to_inline"]
    assert all(row["failed"] == 0 for row in figures["rows"])


@pytest.mark.slow
def test_reference_extrapolation_runs():
    # the extrapolated reference of shared steps against the modal sample at rtol 1e-7
    # over 0.2 ms (no stored bands: on the peak); the block's lane at 1e-5 is checked
    # bit for bit against the run alone inside the script
    import reference_extrapolation

    figures = reference_extrapolation.main(["--t-end", "2e-4"])
    study = figures["study1"]
    assert study["scale"] in ("peak", "cut width")
    for key in ("extrapolated", "run_1e-6", "run_1e-5", "estimate"):
        assert study[key] and all(np.isfinite(study[key]))
    assert figures["steps"]["1e-07"] > figures["steps"]["1e-05"] > figures["steps"]["0.0001"]


@pytest.mark.slow
def test_brake_bands_quick_runs():
    # 0.3 ms: a sample alone and beside others is bit-identical; the bands' error against
    # rtol 1e-6 falls with the tolerance (ROS34PW2's error ~ rtol^0.88, docs/brake.md)
    import brake_bands

    # only the parts asserted below (the shared-step variants and the SIMD timing would
    # double the run, which CI's time limit cannot spare)
    figures = brake_bands.main(
        ["--quick", "--rounds", "1", "--parts", "noise", "bands", "cost", "--shared-rtol"]
    )
    assert all(value == 0.0 for value in figures["noise"]["this"].values())
    study = figures["bands"]["study1"]
    coarse = max(max(v) for v in study["rtol 0.01"]["deviation"].values())
    fine = max(max(v) for v in study["rtol 0.001"]["deviation"].values())
    assert fine < coarse
    assert figures["cost"]["best"]["default"]["time_integration_error"] < 0.01


def test_brake_targets_variant_is_the_demo_with_rodas4(tmp_path):
    # benchmarks/brake_targets.py's RODAS4 variant: the demo's study file, its model's
    # integrator the only change
    import tomllib

    targets = pytest.importorskip("brake_targets")
    demo = targets.FILES[1]["default"]
    copy = targets.with_integrator(demo, "rodas4", tmp_path)
    original, changed = (tomllib.loads(path.read_text()) for path in (demo, copy))
    assert changed["model"].pop("options") == {"integrator": "rodas4"}
    assert changed == original
    assert targets.FILES[1]["paper"].exists() and targets.FILES[2]["paper"].exists()


def test_brake_targets_tolerance_variant_changes_only_the_tolerances(tmp_path):
    # benchmarks/brake_targets.py's --tolerances: the demo's study file, its method and
    # time-integration tolerances the only change; a file that sets them is refused
    import tomllib

    targets = pytest.importorskip("brake_targets")
    demo = targets.FILES[2]["default"]
    copy = targets.with_tolerance(demo, 0.05, tmp_path)
    original, changed = (tomllib.loads(path.read_text()) for path in (demo, copy))
    assert changed["study"].pop("method_tolerance") == 0.05
    assert changed["study"].pop("integration_tolerance") == 0.05
    assert changed == original
    with pytest.raises(ValueError, match="without tolerances"):
        targets.with_tolerance(copy, 0.02, tmp_path)


def test_study_timeline_finds_the_intervals_without_a_kernel_call():
    # calls overlapping on two threads merge; a gap shorter than 0.1 s is not listed;
    # the start before the first call and the end after the last are (hand-computed)
    study_timeline = pytest.importorskip("study_timeline")
    calls = [
        {"start_s": 1.5, "end_s": 30.0},
        {"start_s": 2.0, "end_s": 10.0},
        {"start_s": 10.05, "end_s": 29.0},
        {"start_s": 30.8, "end_s": 40.0},
        {"start_s": 44.0, "end_s": 50.0},
        {"start_s": 45.0, "end_s": 49.0},
    ]
    free = study_timeline.kernel_free(calls, 52.5)
    assert free == [[0.0, 1.5], [30.0, 30.8], [40.0, 44.0], [50.0, 52.5]]
    assert study_timeline.kernel_free(calls[:1], 30.05) == [[0.0, 1.5]]


def test_study_timeline_wrappers_take_what_the_wrapped_methods_take(monkeypatch):
    # the timeline's wrapper of SimulationModel.run_ahead must pass on every argument the
    # study gives it (a parameter added to run_ahead broke the whole benchmark once)
    import inspect

    from fuzzymbs.mbs import integrate

    study_timeline = pytest.importorskip("study_timeline")
    original = integrate.SimulationModel.run_ahead
    monkeypatch.setattr(integrate.SimulationModel, "run_ahead", original)  # restored after
    study_timeline.label_check_runs_ahead()
    wrapper = integrate.SimulationModel.run_ahead
    assert wrapper is not original
    assert list(inspect.signature(wrapper).parameters) == list(
        inspect.signature(original).parameters
    )


@pytest.mark.slow
def test_mechanism_gradients_reports_every_parameter():
    # the script behind the mechanisms' derivative figures (docs/mechanisms.md,
    # "Derivatives"), on two slider-crank samples and two steps: every parameter gets its
    # step change, its distance from own-step differences and from a tighter run, and
    # the cost ratio counts the replayed runs (two per parameter)
    import mechanism_gradients

    report = mechanism_gradients.measure("slider-crank", 2, [1e-3, 1e-4], repeats=1)
    assert set(report["parameters"]) == {
        "crank_speed", "spin_up_time", "youngs_modulus", "rod_width", "rod_height",
        "slider_mass",
    }  # fmt: skip
    for entry in report["parameters"].values():
        assert set(entry["step_change"]) == {"0.001->0.0001"}
        assert entry["size"] > 0 and entry["replayed_vs_tighter"] >= 0
    assert report["failed_samples"] == {"0.001": 0, "0.0001": 0}
    assert report["cost_ratio"] > 1.0


@pytest.mark.slow
def test_gear_dynamic_reports_cost_and_each_laws_smoothness():
    # the script behind docs/gears.md's cost and smoothness of the dynamic DTE, this
    # checkout against itself: the same DTE to the bit, every damping law measured
    import gear_dynamic
    from bench_common import REPO

    report = gear_dynamic.measure(REPO, rounds=1, quick=True)
    assert report["dte_difference_of_peak"] == 0.0
    assert report["cost_this"][0]["cpu_s"] > 0 and report["cpu_ratio_this_over_other"] > 0
    assert set(report["smoothness"]) == {"viscous (default)", "undamped", "Hunt-Crossley"}
    for speed in report["convergence"].values():
        assert speed["error_of_band"] > 0 and speed["half_step_difference_of_band"] > 0
    for law in report["smoothness"].values():
        assert law["jitter_in_steps"] >= 0 and set(law["difference_change"]) == {
            "0.0001", "0.0002", "0.0005", "0.001",
        }  # fmt: skip


def test_first_order_slopes_recover_a_linear_error_field():
    # benchmarks/first_order_correction.py's two slope estimates on a field linear in
    # p (plus a curvature the central differences cancel and the corners' main effects
    # leave out: an even term): both recover the slope to round-off, and the correction
    # with it leaves the even term alone (3 at every corner: sum of (+-1)^2)
    from first_order_correction import OUTPUTS, corrected, slopes_central, slopes_corners

    rng = np.random.default_rng(3)
    p0, h = np.array([2e5, 1e3, 1.6e4]), np.array([5e3, 25.0, 40.0])
    slope = {name: rng.normal(size=(7, 3)) for name in OUTPUTS}  # (T, n)

    def field(rows):  # coarse - fine at rows (k, n)
        d = (rows - p0) / h
        return {k: (rows - p0) @ slope[k].T + (d**2).sum(1)[:, None] for k in OUTPUTS}

    central = np.repeat(p0[None, :], 6, axis=0)
    for i in range(3):
        central[2 * i, i] += h[i]
        central[2 * i + 1, i] -= h[i]
    signs = np.array([[1 if (k >> i) & 1 else -1 for i in range(3)] for k in range(8)])
    corners = p0 + signs * h
    zero = {k: 0.0 for k in OUTPUTS}
    found_central = slopes_central(field(central), zero, h)
    found_corners = slopes_corners(field(corners), zero, signs, h)
    rest = corrected(field(corners), corners, p0, found_corners)  # the even term is left
    for k in OUTPUTS:
        np.testing.assert_allclose(found_central[k], slope[k], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(found_corners[k], slope[k], rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(rest[k], 3.0, rtol=1e-9)


@pytest.mark.slow
def test_first_order_correction_quick_removes_the_slope_it_measured():
    # 0.3 ms, study 1, rtol 1e-2: the central-difference correction leaves the model's
    # slope relative to its tenfold tighter model at round-off (its sign and scale)
    import first_order_correction

    report = first_order_correction.main(["--quick"])["study1"]["rtol 0.01"]
    assert report["central_slope_left"] < 1e-9
    for label in ("constant", "central", "corners"):
        assert all(np.isfinite(v).all() and min(v) >= 0 for v in report[label].values())


@pytest.mark.slow
def test_logged_jacobians_quick_compares_both_ways():
    # 0.3 ms, study 1: the log's samples evaluate almost no Jacobian of their own and stay
    # within a small fraction of the samples' spread of their own-Jacobian runs
    import logged_jacobians

    report = logged_jacobians.main(["--quick"])["study1"]
    assert report["logged"]["jacobians"] < 0.2 * report["own"]["jacobians"]
    assert report["difference_of_spread"] < 2e-3
    assert report["log_rows"] > 0 and report["cpu_ratio_logged_over_own"] > 0


@pytest.mark.slow
def test_round_padding_fills_each_refinement_round_to_the_multiple():
    # the experiment behind "Idle lanes of the plan's rounds" in docs/benchmarks.md, on the
    # gear demo's adaptive study (19 runs in 3 rounds): padding to 4 leaves the first round
    # and the extremum confirmation as they are and fills every round between to whole
    # blocks of 4 with points the method itself would certify
    import round_padding

    demo = round_padding.REPO / "src" / "fuzzymbs" / "demos" / "gear-ste" / "01-ste-adaptive.toml"
    plain, padded = round_padding.main(["--file", str(demo), "--multiples", "1", "4"])["runs"]
    assert sum(plain["round_sizes"]) == plain["runs"]
    assert sum(padded["round_sizes"]) == padded["runs"]
    assert padded["round_sizes"][0] == plain["round_sizes"][0]
    middle = padded["round_sizes"][1:-1]
    assert middle and all(size % 4 == 0 for size in middle)
    assert padded["runs"] > plain["runs"]
    assert padded["method_error"] <= 0.01 and plain["method_error"] <= 0.01


@pytest.mark.slow
def test_rk4_parts_reports_a_step_against_its_right_hand_sides():
    # the script behind RK4's step against its four right-hand sides in docs/benchmarks.md
    import rk4_parts

    figures = rk4_parts.main(["--steps", "40", "--repeats", "1"])
    assert figures["advance_ms"] > 0 and figures["four_rhs_ms"] > 0
    assert set(figures["rk4_ms"]) == {"1 blocks", "2 blocks", "4 blocks"}


@pytest.mark.slow
def test_compile_events_counts_what_a_test_compiles():
    # the script behind docs/contributing.md's compile figures, on one test that compiles
    # the box search's climb kernel (a few seconds) in an empty cache
    compile_events = pytest.importorskip("compile_events")
    node = "tests/fuzzy/test_box_search.py::test_box_extremes_against_a_dense_grid"
    result = compile_events.main([node, "--top", "5"])
    assert result["tests"] == [node]
    assert result["compilations"] >= result["fuzzymbs_compilations"] > 0
    assert result["seconds"] > 0.0
    names = [entry["function"] for entry in result["top"]]
    assert "fuzzymbs.fuzzy.climb_kernel.climb_starts" in names
    assert result["compiled_more_than_once"] == {}


def test_gradient_error_has_the_stated_scale():
    # benchmarks/gradient_adaptive.py --gradient-error E: each derivative's error is E w / h_i
    # times a standard normal draw; over 20,000 draws the sample standard deviation lies
    # within 3 % of it (its relative standard error is 1 / sqrt(2 x 20,000) = 0.5 %)
    from gradient_adaptive import with_error

    truth = {"y": (np.array([[1.0, -2.0]]), np.array([[3.0, 2.0]]))}  # widths 2 and 4
    half = np.array([0.5, 10.0])
    exact = {"y": np.zeros((20_000, 2, 2))}
    noisy = with_error(exact, truth, half, 0.01, np.random.default_rng(7))["y"]
    expected = 0.01 * np.array([2.0, 4.0])[:, None] / half  # (elements, n)
    np.testing.assert_allclose(noisy.std(axis=0), expected, rtol=0.03)
    # unbiased: the mean of the 80,000 standardised draws within 5 standard errors of 0
    assert abs((noisy / expected).mean()) < 5.0 / np.sqrt(noisy.size)


def test_other_w_methods_meet_their_order_conditions():
    # The tableaux of benchmarks/rodas_work_precision.py's --w-methods, as transcribed from
    # Rang (2015), Tables 2 and 3: the Rosenbrock order conditions of Hairer & Wanner
    # (Solving ODEs II, Table IV.7.1; beta = A + Gamma below the diagonal) to order 3 with
    # b and to order 2 with bhat, and ROS34PRw stiffly accurate (b the last row of A +
    # Gamma) with its stages 3 and 4 at one point; residuals below 1e-15 measured.
    import rodas_work_precision

    forms = {label: form for label, form, _ in rodas_work_precision.W_METHODS}
    for a, g, b, bhat in forms.values():
        gamma = g[0, 0]
        beta = np.tril(a + g, -1)
        beta1 = beta.sum(axis=1)
        alpha = a.sum(axis=1)
        for weights in (b, bhat):
            assert abs(weights.sum() - 1.0) < 1e-14
            assert abs(weights @ beta1 - (0.5 - gamma)) < 1e-14
        assert abs(b @ alpha**2 - 1.0 / 3.0) < 1e-14
        assert abs(b @ (beta @ beta1) - (1.0 / 6.0 - gamma + gamma**2)) < 1e-14
        assert abs(bhat @ alpha**2 - 1.0 / 3.0) > 1e-3  # the embedded solution: order 2
    a, g, b, _ = forms["ros34prw"]
    np.testing.assert_allclose(b, (a + g)[3], atol=1e-15)
    np.testing.assert_array_equal(a[2], a[3])


@pytest.mark.slow
def test_correction_blocks_runs_a_case_and_restores_the_block_sizes():
    # one closed-form case at the earlier block sizes: the same runs and certified error
    # as at the defaults (a block changes which BLAS kernel sums a row, not the sums)
    import correction_blocks

    import fuzzymbs.fuzzy.hermite_correction as hermite_correction
    import fuzzymbs.fuzzy.residual_correction as residual_correction
    from fuzzymbs.models.closed_form.resonance import resonance_cases

    default = residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES
    case = next(case for case in resonance_cases() if case.name == "sdof-5%")
    earlier = correction_blocks.run(case, True, correction_blocks.EARLIER)
    now = correction_blocks.run(case, True, default)
    assert (residual_correction._BLOCK_ENTRIES, hermite_correction._BLOCK_ENTRIES) == default
    assert earlier["runs"] == now["runs"] > 0
    assert abs(earlier["error"] - now["error"]) <= 1e-12
    # nearest_distances at its earlier block and its default: the same numbers (exact)
    rows = correction_blocks.nearest_distances_times(1)
    assert len(rows) == 3 and all(row["same_numbers"] for row in rows.values())


def test_random_honesty_models_carry_their_derivatives_and_the_script_runs(capsys):
    # benchmarks/random_honesty.py: each random model's analytic gradient against central
    # differences (step 1e-6 of the parameter; truncation and round-off below 1e-7 of the
    # largest derivative, measured 1e-10 to 3e-10), the scalar and the signal kind, and the
    # whole script on one small case (a 2-parameter scalar: converged, judged against its
    # polished truth)
    from random_honesty import main, random_case

    rng = np.random.default_rng(5)
    for dimension, elements in ((2, 1), (4, 21)):
        case = random_case(3, dimension, elements)
        names = list(case.triangles)
        point = {
            n: np.array([rng.uniform(case.triangles[n][0], case.triangles[n][2])]) for n in names
        }
        outputs, slopes = case.gradient(point)
        (key,) = outputs
        np.testing.assert_array_equal(outputs[key], case.model(point)[key])
        for i, name in enumerate(names):
            step = 1e-6 * point[name][0]
            up = case.model({**point, name: point[name] + step})[key]
            down = case.model({**point, name: point[name] - step})[key]
            central = (up - down) / (2.0 * step)
            scale = np.abs(slopes[key]).max()
            np.testing.assert_allclose(slopes[key][..., i], central, atol=1e-7 * scale)
        # seeded: the same model again
        np.testing.assert_array_equal(
            random_case(3, dimension, elements).model(point)[key], outputs[key]
        )
    main(["--seeds", "1", "--dimensions", "2", "--elements", "1", "--gradients", "false"])
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("random2s-1") and "converged" in lines[0]
    assert lines[-1].startswith("1 runs of the method: 1 converged")
