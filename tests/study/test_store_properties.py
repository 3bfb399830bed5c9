"""Property: however a run is chunked and wherever it is interrupted, the resumed
result equals an uninterrupted inline run bit for bit."""

import tempfile

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fuzzymbs import Triangular
from fuzzymbs.study.study import Study

PARAMETERS = {"x1": Triangular(1, 2, 3), "x2": Triangular(9, 10, 11), "x3": Triangular(-1, 0, 2)}


class StopAfter:
    """x1 * x2 + x3, raising KeyboardInterrupt on call number ``stop`` (None: never)."""

    coords: dict = {}  # noqa: RUF012

    def __init__(self, stop=None):
        self.stop = stop
        self.calls = 0

    def __call__(self, samples):
        self.calls += 1
        if self.calls == self.stop:
            raise KeyboardInterrupt
        return {"z": samples["x1"] * samples["x2"] + samples["x3"]}


REFERENCE = (
    Study(StopAfter(), PARAMETERS, levels=3, name="p", validation_runs=0)
    .run(progress=False)
    .dataset
)


@settings(max_examples=15, deadline=None)
@given(chunk_size=st.integers(1, 30), stop=st.integers(1, 10))
def test_resumed_equals_uninterrupted(chunk_size, stop):
    with tempfile.TemporaryDirectory() as store:
        try:
            Study(StopAfter(stop), PARAMETERS, levels=3, name="p", validation_runs=0).run(
                store=store, chunk_size=chunk_size, progress=False
            )
        except KeyboardInterrupt:
            pass
        model = StopAfter()
        result = Study(model, PARAMETERS, levels=3, name="p", validation_runs=0).run(
            store=store, chunk_size=chunk_size, progress=False
        )
        chunks = -(-len(result.dataset["sample"]) // chunk_size)
        assert model.calls == chunks - min(stop - 1, chunks)
    for name in REFERENCE.data_vars:
        np.testing.assert_array_equal(result.dataset[name], REFERENCE[name], strict=True)
