"""Helpers of the tests that compare one study run in different ways (executors,
resumed after a kill): bit-identical datasets and an in-process Dask cluster."""

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import pytest


def assert_identical(a: Any, b: Any) -> None:
    """Bit for bit: equal values and equal NaN placement, every data variable."""
    assert set(a.data_vars) == set(b.data_vars)
    for name in a.data_vars:
        np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name, strict=True)


@contextmanager
def local_dask_client() -> Iterator[tuple[Any, Any]]:
    """(cluster, client) of one in-process worker with two threads (skips the test
    without the distributed package)."""
    distributed = pytest.importorskip("distributed")
    with (
        distributed.LocalCluster(
            n_workers=1,
            threads_per_worker=2,
            processes=False,
            protocol="tcp",
            dashboard_address=":0",  # a free port: 8787 may be taken by another cluster
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield cluster, client
