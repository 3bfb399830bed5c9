"""The code blocks of docs/fe.md run, in order, and print what the guide says."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "fe.md"


def test_fe_guide_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) == 3
    namespace: dict = {}
    for block in blocks:
        exec(compile(block, str(GUIDE), "exec"), namespace)
    capsys.readouterr()
    assert namespace["patch_nodes"].size == 28 and namespace["patch_faces"].shape == (2, 9)
    assert namespace["pad_contact"].size == 25
    assert (namespace["modal_disc"].n_modes, namespace["modal_disc"].n_nodes) == (20, 28)
    assert (namespace["modal_pad"].n_modes, namespace["modal_pad"].n_nodes) == (31, 50)
    np.testing.assert_allclose(
        namespace["disc"].natural_frequencies(3), [827.23, 842.00, 842.00], atol=0.01
    )
