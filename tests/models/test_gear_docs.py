"""The Python code blocks of docs/gears.md run as written."""

import re
from pathlib import Path

import numpy as np
import pytest

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "gears.md"


def test_gears_guide_example_runs():
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) == 2
    namespace: dict = {}
    exec(compile(blocks[0], str(GUIDE), "exec"), namespace)
    out, model = namespace["out"], namespace["model"]
    assert out["ste"].shape == (2, 100)  # the shape the guide's comment states
    assert not out["failed"].any()
    assert model.reference["ste"].shape == (100,)
    # the stiffer second sample deflects less at every mesh position (STE ~ F / stiffness)
    assert np.all(out["ste"][1] < out["ste"][0])


@pytest.mark.slow
def test_gears_guide_fe_example_runs(tmp_path, monkeypatch):
    monkeypatch.setenv("FUZZYMBS_CACHE_DIR", str(tmp_path))
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    namespace: dict = {}
    exec(compile(blocks[1], str(GUIDE), "exec"), namespace)
    out = namespace["out"]
    assert out["ste"].shape == (2, 60) and out["load_share"].shape == (2, 60, 4)
    assert not out["failed"].any()
    # half the torque, no relief: the first sample's STE lies below the second's
    assert np.all(out["ste"][0] < out["ste"][1])
