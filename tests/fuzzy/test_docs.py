"""The code blocks of docs/fuzzy.md run, in order, in one namespace."""

import re
import warnings
from pathlib import Path

import numpy as np

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "fuzzy.md"


def test_user_guide_examples_run(capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) >= 6
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for block in blocks:
            exec(compile(block, str(GUIDE), "exec"), namespace)
    capsys.readouterr()
    # the numbers the guide quotes in its comments
    assert len(namespace["p"]) == 33
    assert namespace["deflection"].nominal == 0.08
    # F/k is monotone: the reduced bounds are F_lo/k_hi and F_hi/k_lo at every level
    p = namespace["p"]
    force_low, force_high = p.cut_lower[:, 1], p.cut_upper[:, 1]
    stiffness_low, stiffness_high = p.cut_lower[:, 0], p.cut_upper[:, 0]
    np.testing.assert_allclose(namespace["deflection"].lower, force_low / stiffness_high)
    np.testing.assert_allclose(namespace["deflection"].upper, force_high / stiffness_low)
    np.testing.assert_array_equal(namespace["partial"].complete, [False, False, False, True, True])
    # validation runs: the first edge probe finds the valley floor, 1/12 of the mu = 0 cut
    # (reduced [0.25, 3.25] against the true [0, 3.25])
    assert namespace["miss"].max() == __import__("pytest").approx(0.25 / 3.0, rel=1e-12)
    assert namespace["check"].bound == "lower"  # sampled: a lower bound of the miss
    # symmetric triangles: (m+1)^n + m^n = 189 unique of sum_k k^n = 225 (docs/theory.md)
    assert len(namespace["general"]) == 189
    assert namespace["general"].points_without_reuse == 225
    np.testing.assert_allclose(namespace["influence"].relative.sum(), 1.0)
    # inverse fuzzy arithmetic: the synthetic measurement gives the truth back; the
    # residual tolerance 1e-3 of the output widths bounds the support error (~1e-3)
    identified = namespace["identified"]
    assert identified.converged and identified.max_residual <= 1e-3
    for name, number in namespace["truth"].items():
        np.testing.assert_allclose(
            identified.parameters[name].alpha_cut(0.0), number.alpha_cut(0.0), rtol=2e-3
        )
