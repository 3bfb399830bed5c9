"""The same study gives bit-identical results inline, in a process pool and on Dask."""

import numpy as np
import pytest
from same_results import assert_identical, local_dask_client

from fuzzymbs import Triangular
from fuzzymbs.study.study import Study


def _oscillator_study():
    return Study(
        "damped-oscillator",
        {
            "mass": Triangular.relative(1.0, 0.05),
            "stiffness": Triangular.relative(1000.0, 0.1),
            "damping": Triangular.relative(3.0, 0.2),
        },
        method="reduced",
        levels=3,
        model_options={"time_steps": 101, "duration": 0.5},
    )


@pytest.fixture(scope="module")
def inline_result():
    return _oscillator_study().run(progress=False, chunk_size=5)


def test_process_pool_equals_inline(inline_result):
    result = _oscillator_study().run(executor="processes:2", chunk_size=5, progress=False)
    assert result.provenance["executor"] == "processes:2"
    assert_identical(result.dataset, inline_result.dataset)


def test_dask_local_cluster_equals_inline(inline_result):
    with local_dask_client() as (cluster, client):
        by_client = _oscillator_study().run(executor=client, chunk_size=5, progress=False)
        address = cluster.scheduler_address.replace("tcp://", "dask://")
        by_address = _oscillator_study().run(executor=address, chunk_size=7, progress=False)
    assert_identical(by_client.dataset, inline_result.dataset)
    assert_identical(by_address.dataset, inline_result.dataset)


def test_unknown_executor_is_rejected():
    from fuzzymbs.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="unknown executor 'threads'"):
        _oscillator_study().run(executor="threads", progress=False)


def test_dask_address_without_distributed_fails_before_any_run(monkeypatch, tmp_path):
    import sys

    from fuzzymbs.errors import InvalidParameterError
    from fuzzymbs.study.executors import check_executor_spec

    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    with pytest.raises(InvalidParameterError, match=r"needs Dask's distributed package"):
        check_executor_spec("dask://127.0.0.1:8786")
    check_executor_spec("inline")  # the others need nothing
    # a study file's own Dask executor is checked before the output folder is touched
    from importlib import resources

    from fuzzymbs.study.pipeline import run_study_file

    product = resources.files("fuzzymbs.demos") / "quickstart" / "01-product.toml"
    study_file = tmp_path / "product.toml"
    study_file.write_text(
        product.read_text().replace('executor = "inline"', 'executor = "dask://127.0.0.1:9"')
    )
    with pytest.raises(InvalidParameterError, match=r"needs Dask's distributed package"):
        run_study_file(study_file, tmp_path / "out", allow_code=True, progress=False)
    assert not (tmp_path / "out").exists()


def test_unpicklable_model_is_reported_before_starting_workers():
    from fuzzymbs.errors import InvalidParameterError

    study = Study(lambda s: {"z": s["x"]}, {"x": Triangular(0, 1, 2)}, levels=1)
    with pytest.raises(InvalidParameterError, match=r"cannot be pickled.*inline executor"):
        study.run(executor="processes:1", progress=False)


def test_workers_limit_the_kernel_threads_and_restore_them():
    # a worker's chunk runs with the Numba threads it was given (per thread), and the
    # thread's own setting comes back afterwards; without Numba the call is unchanged
    numba = pytest.importorskip("numba")
    from fuzzymbs.study.evaluation import evaluate_chunk

    seen = []

    def model(p):
        seen.append(numba.get_num_threads())
        return {"z": 2.0 * p["x"]}

    before = numba.get_num_threads()
    chunk = evaluate_chunk(model, {"x": np.arange(3.0)}, 0, threads=1)
    np.testing.assert_array_equal(chunk.outputs["z"], [0.0, 2.0, 4.0])
    assert seen == [1] and numba.get_num_threads() == before
    evaluate_chunk(model, {"x": np.arange(3.0)}, 0, threads=None)
    assert seen[-1] == before


def test_process_pool_shares_the_cores():
    import os

    from fuzzymbs.study.executors import resolve_executor

    resolved = resolve_executor("processes:2")
    try:
        assert resolved.task_threads == max(1, (os.cpu_count() or 1) // 2)
    finally:
        resolved.close()


STUDY_FILE = """[study]
name = "osc"
method = "reduced"
levels = 3
outputs = ["displacement"]
[model]
name = "damped-oscillator"
[model.options]
time_steps = 101
duration = 0.5
[parameters]
mass = { type = "triangular", modal = 1.0, spread = 0.05 }
stiffness = { type = "triangular", modal = 1000.0, spread = 0.1 }
"""


def test_a_study_file_on_dask_draws_its_figures_on_the_workers(tmp_path):
    # the reference: the same study file run inline draws the same figure files here
    distributed = pytest.importorskip("distributed")
    from fuzzymbs.study.pipeline import run_study_file

    path = tmp_path / "osc.toml"
    path.write_text(STUDY_FILE)
    inline = run_study_file(path, tmp_path / "inline", progress=False)
    with local_dask_client() as (cluster, client):
        address = cluster.scheduler_address.replace("tcp://", "dask://")
        with distributed.get_task_stream(client) as stream:
            on_dask = run_study_file(path, tmp_path / "dask", executor=address, progress=False)
    drawn = [task["key"] for task in stream.data if "render_figure" in str(task["key"])]
    assert len(drawn) == len(inline.plots) == 3
    assert_identical(on_dask.result.dataset, inline.result.dataset)
    assert [p.name for p in on_dask.plots] == [p.name for p in inline.plots]
    assert [p.read_bytes() for p in on_dask.plots] == [p.read_bytes() for p in inline.plots]


def test_the_worker_preload_imports_what_the_figure_tasks_need_at_the_workers_start(
    fresh_python,
):
    # a worker process started with the preload holds the plotting stack before any task;
    # the control: a process that imports distributed alone holds none of it
    distributed = pytest.importorskip("distributed")
    from fuzzymbs.study.worker_preload import MODULES

    def loaded() -> list[str]:
        import sys

        return [name for name in MODULES if name in sys.modules]

    control = fresh_python(
        f"import sys, distributed; print([m for m in {MODULES!r} "
        "if m in sys.modules and m != 'numpy'])"
    )
    assert control.strip() == "[]"
    with (
        distributed.LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            preload=["fuzzymbs.study.worker_preload"],
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        (modules,) = client.run(loaded).values()
    assert modules == list(MODULES)


def test_work_meanwhile_runs_once_in_a_thread_only_when_the_runs_go_elsewhere(caplog):
    import threading
    from concurrent.futures import ThreadPoolExecutor

    from fuzzymbs.study.execution import LazyExecutor

    calls = []

    def meanwhile():
        calls.append(threading.current_thread().name)

    inline = LazyExecutor(None, lambda resolved: None, None, meanwhile)
    inline.get()
    inline.waiting()
    assert calls == []  # inline: this thread runs the samples, nothing waits
    with ThreadPoolExecutor(1) as pool:
        elsewhere = LazyExecutor(pool, lambda resolved: None, None, meanwhile)
        elsewhere.waiting()  # before the executor started: nothing is out yet
        elsewhere.get()
        for _ in range(3):
            elsewhere.waiting()
        for thread in threading.enumerate():
            if thread.name == "fuzzymbs-meanwhile":
                thread.join(10)
    assert calls == ["fuzzymbs-meanwhile"]

    def failing():
        raise RuntimeError("no such module")

    with ThreadPoolExecutor(1) as pool, caplog.at_level("DEBUG", "fuzzymbs.study.execution"):
        broken = LazyExecutor(pool, lambda resolved: None, None, failing)
        broken.get()
        broken.waiting()  # logged in its thread, never raised here
        for thread in threading.enumerate():
            if thread.name == "fuzzymbs-meanwhile":
                thread.join(10)
    assert "work meanwhile failed: no such module" in caplog.text


def test_import_result_modules_loads_xarray_and_the_netcdf_engine(fresh_python):
    code = (
        "import sys\n"
        "from fuzzymbs.study import result\n"
        "assert 'xarray' not in sys.modules\n"
        "result.import_result_modules()\n"
        "engine = result.netcdf_engine()\n"
        "needed = {'h5netcdf': ['h5netcdf', 'h5py'], 'netcdf4': ['netCDF4']}.get(engine, [])\n"
        "print(all(m in sys.modules for m in ['xarray', *needed]))\n"
    )
    assert fresh_python(code).strip() == "True"
