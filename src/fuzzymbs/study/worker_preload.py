"""A Dask worker preload: the modules a study's tasks need, imported when the worker starts.

Start a study's workers with it, so that a study pays no imports after its runs::

    dask worker tcp://SCHEDULER:8786 --nthreads 1 --preload fuzzymbs.study.worker_preload

or, in Python, ``LocalCluster(..., preload=["fuzzymbs.study.worker_preload"])``, or in the
workers' Dask configuration ``distributed.worker.preload: [fuzzymbs.study.worker_preload]``.

A study file's figures are drawn on the study's workers (:func:`fuzzymbs.plot.write_plots`),
each from a task that carries its part of the result as an xarray dataset. A fresh worker
first imports xarray, matplotlib and the plotting module for it: about 0.5 s of one core
(2-core machine), after the study's last run, where nothing else can be done meanwhile
(docs/benchmarks.md, "Dask: two workers against one core"). Imported at the worker's start,
they cost the same once per worker instead, before any study. The models' own modules load
with the first task that unpickles a model (their compiled kernels come from Numba's cache);
they are not imported here, since a cluster may serve any model.
"""

from __future__ import annotations

#: the modules imported, in this order (the figures are built without pyplot, so no
#: backend is chosen here: a worker's other tasks keep matplotlib's default)
MODULES = (
    "numpy",
    "xarray",
    "matplotlib.figure",
    "matplotlib.backends.backend_agg",
    "fuzzymbs.study.evaluation",
    "fuzzymbs.plot",
)


def import_modules() -> list[str]:
    """Import :data:`MODULES` and return their names."""
    import importlib

    for name in MODULES:
        importlib.import_module(name)
    return list(MODULES)


def dask_setup(worker: object) -> None:
    """Dask's preload hook, called once in each worker process as it starts."""
    import_modules()
