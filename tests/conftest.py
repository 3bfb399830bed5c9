"""Shared pytest configuration."""

import os
import subprocess
import sys

import pytest

# BLAS pinned to one thread: kernels parallelise over samples, not inside BLAS.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("MPLBACKEND", "Agg")
# No user trust file (fuzzymbs.study.trust): a study file's code runs only where a test allows it.
os.environ["FUZZYMBS_TRUST_FILE"] = os.path.join(os.path.dirname(__file__), "no-trust-file.toml")


# ---- what each test process runs first (pytest-xdist) ------------------------------------
# On a fresh clone most of the default suite's time is Numba compiling kernels, once in
# every test process that calls a kernel before another process has written it to the
# cache. With xdist's plain load scheduling both processes reach the same kernel family
# at about the same time and both compile it; both also build the module-scoped fixtures
# of a module whose tests they share. So each process starts with one group below: the
# tests that first call one family of kernels (each group about a minute of compilation,
# the two balanced) and the tests of an expensive module-scoped fixture (an entry without
# "::" is a whole module). Every later caller, on either process, loads the kernels from
# the cache. tests/test_kernels_first.py checks the entries; a missing one is skipped here.
KERNELS_FIRST = (
    (  # the gear pair's kernels: MUBOCO-PR static, its dynamics (the FE reference's contact
        # kernel is compiled in the slow suite only)
        "tests/models/test_gear_docs.py::test_gears_guide_example_runs",
        "tests/models/test_gear_dynamics.py::test_slow_running_dte_approaches_the_static_ste",
        "tests/models/test_gear_fe.py",  # its module fixture: once per process (module_fe_cache)
        # the quickstart demo (the module's demo_out fixture)
        "tests/test_cli.py::test_demo_writes_results_plots_and_summary",
        "tests/test_cli.py::test_sparse_demo_matches_closed_form_and_a_dense_search",
        "tests/test_cli.py::test_rerun_resumes_from_the_output_folder",
        "tests/test_cli.py::test_plot_command_redraws",
    ),
    (  # the elastic multibody engine's: right-hand side, Jacobian, RK4, ROS34PW2 / RODAS4
        "tests/mbs/test_contact.py::test_static_penetration_equals_load_over_penalty",
        "tests/mbs/test_jacobian.py::test_hoffmann_jacobian_is_the_closed_form[0.0]",
        "tests/mbs/test_model.py::test_node_displacement_output_of_elastic_translating_body",
        "tests/mbs/test_rosenbrock.py::test_order_on_a_stiff_linear_mode[ros34pw2-3]",
        "tests/mbs/test_reference.py::test_rk4_matches_dop853_on_rotating_elastic_contact[samples]",
    ),
)

# The slow suite's longest tests (seconds of one test process in a clean-clone `.ci/run`
# on the AVX2 host, 2026-12-01) in two groups of about equal time, so that no process is
# left running a long test alone at the end (the long ones first, as in longest processing
# time first scheduling). Each group leads one process's first send (in collection order),
# after its KERNELS_FIRST group (whose tests are not in the slow suite's collection, nor
# these in the default suite's). The tests that first call the planar kernels (the
# slider-crank, the mechanisms guide: 65 s of compiling `integrate_blocks` alone) share a
# group: in two groups both processes compiled them at once (88 and 190 s side by side).
LONG_FIRST = (
    (  # the planar and spatial kernels' first calls (119 and 87 s), 65 and 64 s
        "tests/mbs/planar/test_closed_loops.py::"
        "test_driven_rigid_slider_crank_matches_its_kinematics",
        "tests/mbs/planar/test_docs.py::test_mechanisms_guide_examples_run",
        "tests/models/test_brake_slow.py::test_study1_runs_and_nodal_force_dominates_the_pads",
        "tests/models/test_brake_slow.py::"
        "test_the_checks_re_runs_made_ahead_are_the_checks_bit_for_bit",
        # the two other users of its module fixture (the study it runs first): one run
        "tests/models/test_brake_slow.py::"
        "test_adaptive_study1_certifies_its_bands_and_holds_every_reduced_run",
        "tests/models/test_brake_slow.py::test_adaptive_study1_bands_hold_independent_points",
    ),
    (  # 50, 56 (with the rtol 1e-6 reference over 0.3 ms), 49, 46, 58 and under 19 s
        "tests/test_benchmarks_smoke.py::test_gear_dynamic_reports_cost_and_each_laws_smoothness",
        "tests/test_benchmarks_smoke.py::test_brake_bands_quick_runs",
        "tests/mbs/test_shared_steps.py::test_shared_steps_bring_loose_bands_to_the_tight_ones",
        "tests/fuzzy/test_extremum_confirmation.py::test_a_sharp_ridge_is_found_or_reported[case1]",
        "tests/fuzzy/test_first_order.py::"
        "test_with_gradients_ridges_and_hard_cases_are_honest[sdof-0.5%]",
        "tests/test_benchmarks_smoke.py::"
        "test_first_order_correction_quick_removes_the_slope_it_measured",
    ),
)


@pytest.fixture
def fresh_python():
    """``run(code, timeout=120) -> stdout``: ``code`` in a new interpreter (what a process
    imports, what it does at exit) within ``timeout`` seconds; a non-zero exit fails the
    test with the interpreter's stderr."""

    def run(code: str, timeout: float = 120) -> str:
        done = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=timeout
        )
        assert done.returncode == 0, done.stderr
        return done.stdout

    return run


@pytest.hookimpl(optionalhook=True)  # without pytest-xdist (-p no:xdist) it is never called
def pytest_xdist_make_scheduler(config, log):
    """xdist's load scheduling, each process first sent one group of KERNELS_FIRST and
    LONG_FIRST (what of it the run collected, in order)."""
    if config.getvalue("dist") != "load":
        return None
    from xdist.scheduler import LoadScheduling

    class KernelsFirstScheduling(LoadScheduling):
        def __init__(self, config, log=None):
            super().__init__(config, log)
            self.groups = [k + g for k, g in zip(KERNELS_FIRST, LONG_FIRST, strict=True)]

        def _send_tests(self, node, num):
            # the first send to each process (the initial distribution) leads with a group
            if self.groups and self.collection is not None:
                group = self.groups.pop(0)
                first = [
                    i
                    for i, nodeid in enumerate(self.collection)
                    if any(nodeid == e or nodeid.startswith(e + "::") for e in group)
                ]
                first = [i for i in first if i in self.pending]
                if first:
                    for i in first:
                        self.pending.remove(i)
                    self.node2pending[node].extend(first)
                    node.send_runtest_some(first)
            super()._send_tests(node, num)

    return KernelsFirstScheduling(config, log)
