"""The Python code block of docs/studies.md runs as written."""

import re
from pathlib import Path

import numpy as np

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "studies.md"


def test_studies_guide_example_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) == 1
    monkeypatch.chdir(tmp_path)  # the example writes result.nc and plots/
    namespace: dict = {}
    exec(compile(blocks[0], str(GUIDE), "exec"), namespace)
    assert "z" in capsys.readouterr().out  # the printed summary names the output
    assert (tmp_path / "result.nc").stat().st_size > 0
    assert any((tmp_path / "plots").glob("*.png"))
    # THEORY.md oracle: z = x1 x2 is monotonic for positive inputs, so the cut at mu is
    # [lo1 lo2, hi1 hi2] with x1 = TFN(1, 2, 3) and x2 = TFN(9, 10, 11) (modal 10, spread 0.1)
    lower, upper = namespace["result"].alpha_cut("z", 0.5)
    np.testing.assert_allclose([lower, upper], [1.5 * 9.5, 2.5 * 10.5], rtol=1e-14)
