"""Scaling: batch size (brake), parameter count (general, sparse method), Dask vs inline.

* Batch: the brake model integrated for a short end time with 1, 33, 343 and
  2401 samples in one compiled call; cost per sample-step and the fraction of
  the matmul flop bound reached (:mod:`brake_flops`).
* Parameters: general and sparse (default level) transformation methods with
  2 to 6 triangular parameters on m = 4 levels, closed-form model
  ``z = sum_i i x_i + prod_i x_i`` (vectorised); runs after de-duplication,
  the study's wall time (plan, evaluation, retransformation, dataset) and the
  sparse bounds' largest error against the general method's (exact here: the
  model is monotonic).
* Dask: the brake study (33 runs, short end time, 2 chunks of 17 and 16) on a
  ``distributed.LocalCluster`` of 2 worker processes with one thread (and one
  Numba thread) each, against the inline executor (one chunk after the other,
  2 Numba threads); cluster start-up and the first run (workers load the
  kernels) are timed apart.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np
from bench_common import best_time, log

BATCHES = (1, 33, 343, 2401)


def batch_scaling(steps: int, flops_per_sample_step: float, bound_gflops: float) -> list[dict]:
    """Cost per sample-step of the brake kernel for each batch size.

    Wall time (against the machine's bound) and CPU time of all threads (against
    one core's matmul rate: ``gflops_per_core``), the latter unaffected by other jobs.
    """
    from brake_bench import DT, brake_model

    rows = []
    rng = np.random.default_rng(7)
    for batch in BATCHES:
        model = brake_model(steps * DT, chunk_size=batch)  # one compiled call for the batch
        samples = {
            "pad_spring_stiffness": 200e3 * rng.uniform(0.9, 1.1, batch),
            "caliper_spring_stiffness": 1e3 * rng.uniform(0.9, 1.1, batch),
            "nodal_force": 16e3 * rng.uniform(0.99, 1.01, batch),
        }
        model(samples)  # warm-up (compile or load cache, thread pool)
        cpu_start = time.process_time()
        seconds = best_time(lambda m=model, s=samples: m(s), repeat=3)
        # CPU time of all threads per sample-step: the work, whatever else shares the cores
        cpu_per = (time.process_time() - cpu_start) / (3 * batch * steps)
        per = seconds / (batch * steps)
        gflops = flops_per_sample_step / per / 1e9
        rows.append(
            {
                "batch": batch,
                "steps": steps,
                "seconds": seconds,
                "seconds_per_sample_step": per,
                "gflops": gflops,
                "fraction_of_flop_bound": gflops / bound_gflops,
                "cpu_seconds_per_sample_step": cpu_per,
                "gflops_per_core": flops_per_sample_step / cpu_per / 1e9,
            }
        )
        log(f"scaling: batch {batch}: {per * 1e6:.2f} us/sample-step, {gflops:.2f} GFLOP/s")
    return rows


def _closed_form(samples: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    values = list(samples.values())
    total = sum((i + 1) * v for i, v in enumerate(values))
    return {"z": total + np.prod(values, axis=0)}


def parameter_scaling(max_parameters: int = 6, levels: int = 4) -> list[dict]:
    """Runs and wall time of general- and sparse-method studies with 2..max_parameters parameters.

    The model is monotonic, so the general method's bounds are exact (its samples
    include every cut box's corners); the sparse method's largest bound error
    against them, relative to the output range at mu = 0, is ``sparse_max_rel_error``.
    """
    from fuzzymbs.fuzzy.numbers import Triangular
    from fuzzymbs.study.study import Study

    rows = []
    for n in range(2, max_parameters + 1):
        parameters = {f"x{i + 1}": Triangular(0.9, 1.0, 1.1 + 0.1 * i) for i in range(n)}
        results = {}
        for method in ("general", "sparse"):

            def run(parameters: dict = parameters, method: str = method) -> Any:
                study = Study(_closed_form, parameters, method=method, levels=levels)
                return study, study.run(progress=False, keep_raw=False)

            study, result = run()
            results[method] = (len(study.plan), best_time(run, repeat=3), result.dataset)
        runs, seconds, general = results["general"]
        sparse_runs, sparse_seconds, sparse = results["sparse"]
        span = float(general["z_upper"][0] - general["z_lower"][0])
        error = max(
            float(np.abs(sparse[f"z_{side}"] - general[f"z_{side}"]).max())
            for side in ("lower", "upper")
        )
        naive = sum(k**n for k in range(1, levels + 2))
        rows.append({"parameters": n, "runs": runs, "runs_without_reuse": naive})
        rows[-1].update({"seconds": seconds, "sparse_runs": sparse_runs})
        rows[-1].update({"sparse_seconds": sparse_seconds, "sparse_max_rel_error": error / span})
        log(
            f"scaling: {n} parameters: general {runs} runs, {seconds:.3f} s; sparse "
            f"{sparse_runs} runs, {sparse_seconds:.3f} s, bound error {error / span:.1e}"
        )
    return rows


def dask_vs_inline(steps: int) -> dict[str, Any]:
    """Brake study (33 runs, ``steps`` steps) on a Dask LocalCluster and inline."""
    from brake_bench import DT, brake_study
    from distributed import Client, LocalCluster

    from fuzzymbs.fuzzy import NonMonotonicWarning

    study = brake_study(steps * DT, chunk_size=17)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonMonotonicWarning)
        study.run(progress=False)
        inline = best_time(lambda: study.run(progress=False), repeat=2)
        started = time.perf_counter()
        # one Numba thread per worker process: the two workers share the two cores
        cluster = LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            env={"NUMBA_NUM_THREADS": "1"},
        )
        client = Client(cluster)
        startup = time.perf_counter() - started
        try:
            first_start = time.perf_counter()
            first = study.run(executor=client, progress=False)
            first_run = time.perf_counter() - first_start
            seconds = best_time(lambda: study.run(executor=client, progress=False), repeat=2)
            again = study.run(executor=client, progress=False)
        finally:
            client.close()
            cluster.close()
    reference = study.run(progress=False)
    # the design promises bit-identical results on every executor
    keys = ("y_lpad_samples", "y_upad_samples", "y_cali_samples", "y_lpad_lower")
    same = all(
        np.array_equal(again.dataset[k].values, reference.dataset[k].values, equal_nan=True)
        for k in keys
    )
    largest = max(
        float(np.nanmax(np.abs(again.dataset[k].values - reference.dataset[k].values)))
        for k in keys
    )
    log(f"scaling: dask {seconds:.2f} s (start-up {startup:.1f} s), inline {inline:.2f} s")
    del first
    return {
        "steps": steps,
        "runs": len(study.plan),
        "chunks": 2,
        "inline_seconds": inline,
        "dask_seconds": seconds,
        "dask_first_run_seconds": first_run,
        "dask_cluster_startup_seconds": startup,
        "dask_over_inline": seconds / inline,
        "identical_results": bool(same),
        "max_abs_difference_m": largest,
    }
