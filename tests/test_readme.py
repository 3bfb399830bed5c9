"""The README's API tour runs as written and prints what its comments claim."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_tour_runs_and_matches_closed_form(capsys):
    text = README.read_text()
    block = re.search(r"## A tour of the API\s+```python\n(.*?)```", text, re.S).group(1)
    namespace: dict = {}
    exec(compile(block, str(README), "exec"), namespace)
    result = namespace["result"]
    # z = x1 * x2 with x1 = TFN(1, 2, 3), x2 = TFN(9, 10, 11): monotone in both inputs, so the
    # reduced method is exact: cut(mu) = [(1 + mu)(9 + mu), (3 - mu)(11 - mu)] (closed form).
    for mu in (0.0, 0.25, 0.5, 0.75, 1.0):
        lower, upper = result.alpha_cut(mu)
        np.testing.assert_allclose(
            [lower, upper], [(1 + mu) * (9 + mu), (3 - mu) * (11 - mu)], rtol=1e-14
        )
    rho = result.influence().relative
    np.testing.assert_allclose(rho.sum(), 1.0, rtol=1e-14)
    assert rho[0] > rho[1]  # x1 spreads +-50 %, x2 only +-10 %
    assert "17 (17, 2)" in capsys.readouterr().out  # 4 levels * 2^2 corners + 1 core point


def test_readme_names_the_shipped_demos():
    from importlib import resources

    text = README.read_text()
    demos = resources.files("fuzzymbs") / "demos"
    for name in re.findall(r"fuzzymbs demo ([\w-]+) --out", text):
        assert (demos / name).is_dir(), f"README names demo {name!r} that is not shipped"
