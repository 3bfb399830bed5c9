"""Command line: end-to-end runs of shipped studies, plot, info and error reporting."""

import json
import os
import shutil
import subprocess
import sys
import tracemalloc
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from fuzzymbs.cli import app

runner = CliRunner()


def test_quickstart_demo_files_are_package_data():
    folder = resources.files("fuzzymbs") / "demos" / "quickstart"
    names = sorted(entry.name for entry in folder.iterdir() if entry.name.endswith(".toml"))
    assert names == ["01-product.toml", "02-oscillator.toml", "03-oscillator-sparse.toml"]


@pytest.fixture(scope="module")
def demo_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    result = runner.invoke(app, ["demo", "quickstart", "--out", str(out), "-q"])
    assert result.exit_code == 0, result.output
    return out


def test_demo_writes_results_plots_and_summary(demo_out):
    for study in ("product", "oscillator", "oscillator-sparse"):
        folder = demo_out / study
        assert (folder / "result.nc").stat().st_size > 0
        assert "Status: complete" in (folder / "summary.txt").read_text()
        pngs = list(folder.glob("*.png"))
        assert len(pngs) >= 3 and all(p.stat().st_size > 1000 for p in pngs)
        assert not list(folder.glob("*.pdf"))  # PDF only when asked (--format pdf)
    assert (demo_out / "oscillator" / "displacement_bands.png").exists()
    assert (demo_out / "oscillator" / "displacement_membership_time_0.5.png").exists()
    # the product demo is exact: cuts [(1+mu)(9+mu), (3-mu)(11-mu)] (THEORY.md oracle)
    with xr.open_dataset(demo_out / "product" / "result.nc") as ds:
        mu = ds["level"].values
        np.testing.assert_allclose(ds["z_lower"].values, (1 + mu) * (9 + mu), rtol=1e-14)
        np.testing.assert_allclose(ds["z_upper"].values, (3 - mu) * (11 - mu), rtol=1e-14)
        assert json.loads(ds.attrs["plots"]) == {"membership": []}
        # monotonic: the method check (24 validation runs for 17 runs: the default's
        # floor of 12 per parameter) finds round-off
        assert ds.attrs["validation_runs"] == 24 and ds.attrs["method_error"] < 1e-12
    summary = (demo_out / "product" / "summary.txt").read_text()
    assert "(from 24 sampled validation runs); no miss above the tolerance 1 %" in summary


def test_method_check_reaches_the_cli_user(tmp_path, monkeypatch):
    # a model with a valley the reduced corners straddle (tests/study/test_method_check.py):
    # the validation runs find 0.25 of the true mu = 0 cut [0, 3.25] missed (7.69 % of its
    # width); the user sees the warning
    (tmp_path / "valley_model.py").write_text(
        "def make():\n"
        "    def model(s):\n"
        "        return {'z': (s['x1'] - 0.5 * s['x2']) ** 2 + 0.5 * s['x3']}\n"
        "    return model\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    study = tmp_path / "valley.toml"
    study.write_text(
        '[study]\nmethod = "reduced"\nlevels = 4\n[model]\nname = "valley_model:make"\n'
        "[parameters]\n"
        'x1 = { type = "triangular", lower = -1.0, modal = 0.0, upper = 1.0 }\n'
        'x2 = { type = "triangular", lower = -1.0, modal = 0.0, upper = 1.0 }\n'
        'x3 = { type = "triangular", lower = 0.0, modal = 1.0, upper = 2.0 }\n'
    )
    command = ["run", str(study), "--out", str(tmp_path / "o"), "-q", "--allow-code"]
    result = runner.invoke(app, command)
    assert result.exit_code == 0, result.output
    assert "validation run" in " ".join(result.output.split())
    summary = (tmp_path / "o" / "summary.txt").read_text()
    assert "method error at least 7.69 % of the cut width (from 36 sampled" in summary
    assert "validation runs), EXCEEDS the tolerance 1 %" in summary


def test_sparse_demo_matches_closed_form_and_a_dense_search(demo_out):
    from fuzzymbs.models.closed_form.oscillator import free_response

    with xr.open_dataset(demo_out / "oscillator-sparse" / "result.nc") as ds:
        mu = ds["level"].values
        time = ds["time"].values
        assert ds.sizes["sample"] == 69  # Smolyak level 3 in 3 dimensions (docs/fuzzy.md)
        # the natural frequency sqrt(k/m) / (2 pi) is monotonic: exact bounds from the cut ends
        spread = 1 - mu
        mass = (1 - 0.05 * spread, 1 + 0.05 * spread)
        stiffness = (1000 * (1 - 0.1 * spread), 1000 * (1 + 0.1 * spread))
        exact_lower = np.sqrt(stiffness[0] / mass[1]) / (2 * np.pi)
        exact_upper = np.sqrt(stiffness[1] / mass[0]) / (2 * np.pi)
        # 1e-7: the interpolant's error after the local search (measured 9e-10)
        np.testing.assert_allclose(ds["natural_frequency_lower"].values, exact_lower, rtol=1e-7)
        np.testing.assert_allclose(ds["natural_frequency_upper"].values, exact_upper, rtol=1e-7)
        # the displacement against the true response searched on a dense 21^3 grid of each
        # cut box (an independent reference): 2e-6 m of a 0.01 m amplitude (measured 1.5e-7)
        for j, s in enumerate(spread):
            axes = (
                np.linspace(1 - 0.05 * s, 1 + 0.05 * s, 21),
                np.linspace(1000 * (1 - 0.1 * s), 1000 * (1 + 0.1 * s), 21),
                np.linspace(3.1623 * (1 - 0.2 * s), 3.1623 * (1 + 0.2 * s), 21),
            )
            m, k, c = (a.ravel() for a in np.meshgrid(*axes, indexing="ij"))
            truth = free_response(time, m, k, c, 0.01)
            lower = ds["displacement_lower"].values[j]
            upper = ds["displacement_upper"].values[j]
            np.testing.assert_allclose(lower, truth.min(axis=0), rtol=0, atol=2e-6)
            np.testing.assert_allclose(upper, truth.max(axis=0), rtol=0, atol=2e-6)


def test_rerun_resumes_from_the_output_folder(demo_out, tmp_path):
    study = resources.files("fuzzymbs") / "demos" / "quickstart" / "01-product.toml"
    with resources.as_file(study) as path:
        result = runner.invoke(
            app, ["run", str(path), "--out", str(demo_out / "product"), "-q", "--no-plots"]
        )
    assert result.exit_code == 0, result.output
    with xr.open_dataset(demo_out / "product" / "result.nc") as ds:
        provenance = json.loads(ds.attrs["provenance"])
    assert provenance["evaluated"] == 0 and provenance["reused_from_store"] == 17
    with resources.as_file(study) as path:
        result = runner.invoke(
            app,
            ["run", str(path), "--out", str(demo_out / "product"), "-q", "--no-plots", "--fresh"],
        )
    assert result.exit_code == 0, result.output
    with xr.open_dataset(demo_out / "product" / "result.nc") as ds:
        provenance = json.loads(ds.attrs["provenance"])
    assert provenance["evaluated"] == 17 and provenance["reused_from_store"] == 0


def test_plot_command_redraws(demo_out, tmp_path):
    result = runner.invoke(
        app,
        [
            "plot",
            str(demo_out / "oscillator" / "result.nc"),
            "--out",
            str(tmp_path),
            "--format",
            "png",
        ],
    )
    assert result.exit_code == 0, result.output
    written = {Path(line).name for line in result.output.split()}
    assert {"displacement_bands.png", "displacement_membership_time_0.5.png"} <= written
    assert all((tmp_path / name).stat().st_size > 1000 for name in written)


def test_info_lists_models_with_units_and_methods():
    result = runner.invoke(app, ["info"])
    assert result.exit_code == 0, result.output
    assert "damped-oscillator" in result.output and "stiffness [N/m]" in result.output
    assert "Methods: general, reduced, extended, grid" in result.output
    # the adaptive method has no fixed run count: info names its tolerance and budget
    assert "adaptive: rounds until its certified error" in result.output
    assert "method_tolerance (default 0.01)" in result.output
    assert "max_runs (default 2,000): run budget" in result.output
    # every method's options come from its declaration
    assert "sparse_level (default 3)" in result.output
    assert "nonmonotonic (default none)" in result.output
    assert "quickstart" in result.output
    result = runner.invoke(app, ["info", "nope"])
    assert result.exit_code == 1 and "unknown model 'nope'" in result.output


def test_errors_are_reported_without_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        '[model]\nname = "product"\n[parameters.x3]\ntype = "triangular"\n'
        "modal = 1.0\nspread = 0.1\n"
    )
    result = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")])
    assert result.exit_code == 1
    assert "unknown parameter(s) ['x3']" in result.output and "x1 [1], x2 [1]" in result.output
    assert "Traceback" not in result.output
    result = runner.invoke(app, ["demo", "no-such-demo", "--out", str(tmp_path)])
    assert result.exit_code == 1 and "shipped demos: " in result.output

    assert "quickstart" in result.output
    occupied = tmp_path / "a-file"
    occupied.write_text("")
    study = resources.files("fuzzymbs") / "demos" / "quickstart" / "01-product.toml"
    with resources.as_file(study) as path:
        result = runner.invoke(app, ["run", str(path), "--out", str(occupied)])
    assert result.exit_code == 1 and "is not a directory" in result.output
    result = runner.invoke(app, ["plot", str(tmp_path / "missing.nc")])
    assert result.exit_code == 1 and "no such file" in result.output


def test_failed_samples_write_a_summary(tmp_path):
    study = tmp_path / "bad-mass.toml"
    study.write_text(
        '[model]\nname = "damped-oscillator"\n[model.options]\ntime_steps = 11\n'
        '[parameters.mass]\ntype = "triangular"\nlower = -0.5\nmodal = 1.0\nupper = 1.5\n'
    )
    result = runner.invoke(app, ["run", str(study), "--out", str(tmp_path / "o"), "-q"])
    assert result.exit_code == 1 and "mass <= 0 kg" in result.output
    assert "FAILED" in (tmp_path / "o" / "summary.txt").read_text()
    result = runner.invoke(
        app, ["run", str(study), "--out", str(tmp_path / "o"), "-q", "--on-failure", "partial"]
    )
    assert result.exit_code == 0, result.output
    summary = (tmp_path / "o" / "summary.txt").read_text()
    assert "PARTIAL" in summary and "mass <= 0 kg" in summary


@pytest.mark.slow
def test_console_script_runs_a_shipped_study(tmp_path):
    # a real subprocess through the installed entry point (the demo itself runs via CliRunner)
    script = shutil.which("fuzzymbs", path=os.path.dirname(sys.executable))
    assert script is not None, "the fuzzymbs console script is not installed"
    study = resources.files("fuzzymbs") / "demos" / "quickstart" / "01-product.toml"
    with resources.as_file(study) as path:
        completed = subprocess.run(
            [script, "run", str(path), "--out", str(tmp_path / "out"), "--chunk-size", "5"],
            capture_output=True,
            text=True,
            timeout=300,
            check=False,
        )
    assert completed.returncode == 0, completed.stderr
    assert "17/17 samples" in completed.stderr  # the progress bar reached the end
    with xr.open_dataset(tmp_path / "out" / "result.nc") as ds:
        assert json.loads(ds.attrs["provenance"])["chunk_size"] == 5
        assert ds["z_upper"].values[0] == 33.0  # (3 - 0)(11 - 0)
    assert (tmp_path / "out" / "z_membership.png").stat().st_size > 1000
    assert "Status: complete" in (tmp_path / "out" / "summary.txt").read_text()


# ------------------------------------------------------ plans too large to run (max_runs)
WIDE_MODEL = """
def build():
    def total(samples):
        return {"y": sum(samples.values())}
    return total
"""


def _wide_study(folder: Path, method: str, levels: int) -> Path:
    """A study file of a 12-parameter model (a module of the test, hence --allow-code)."""
    (folder / "fuzzymbs_test_wide_model.py").write_text(WIDE_MODEL)
    parameters = "".join(
        f'x{i} = {{ type = "triangular", modal = {1.0 + i}, spread = 0.1 }}\n' for i in range(12)
    )
    path = folder / f"wide-{method}-{levels}.toml"
    path.write_text(
        f'[study]\nmethod = "{method}"\nlevels = {levels}\n\n'
        f'[model]\nname = "fuzzymbs_test_wide_model:build"\n\n[parameters]\n{parameters}'
    )
    return path


class _BoundedMemory:
    """Trace allocations, and cap the address space so that a regression fails, not the machine."""

    def __enter__(self):
        import resource

        self.resource = resource
        self.limits = resource.getrlimit(resource.RLIMIT_AS)
        size = 0
        status = Path("/proc/self/status")
        if status.exists():
            line = next(x for x in status.read_text().splitlines() if x.startswith("VmSize"))
            size = int(line.split()[1]) * 1024
        if size:  # Linux: 2 GiB above what the process maps now
            soft = size + 2 * 2**30
            hard = self.limits[1]
            if hard == resource.RLIM_INFINITY or soft < hard:
                resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        tracemalloc.start()
        return self

    def __exit__(self, *exc_info):
        _, self.peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        self.resource.setrlimit(self.resource.RLIMIT_AS, self.limits)
        return False


def test_plans_too_large_to_run_are_one_line_errors_before_any_allocation(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    general = _wide_study(tmp_path, "general", 4)  # ~2.6e8 runs: 24 GB, then killed by the OS
    absurd = _wide_study(tmp_path, "reduced", 1_000_000)  # "Unable to allocate 1.82 TiB"
    product = tmp_path / "product-levels.toml"  # a registered model, no --allow-code
    product.write_text(
        '[study]\nlevels = 1000000\n[model]\nname = "product"\n[parameters]\n'
        'x1 = { type = "triangular", modal = 2.0, spread = 0.1 }\n'
        'x2 = { type = "triangular", modal = 10.0, spread = 0.1 }\n'
    )
    arguments = ["run", "--allow-code", "-q", "--out"]
    # warm-up: the imports of the run command are not what is measured
    runner.invoke(app, [*arguments, str(tmp_path / "w"), str(product)])
    for path, fragments in (
        (general, ["needs 260,917,841 model runs (2.6e+08)", "'reduced' 16,385"]),
        (absurd, ["4,096,000,001 model runs", "with levels = 10: 'reduced' 40,961"]),
        (product, ["4,000,001 model runs", "with levels = 10: 'reduced' 41"]),
    ):
        with _BoundedMemory() as memory:
            result = runner.invoke(app, [*arguments, str(tmp_path / path.stem), str(path)])
        assert result.exit_code == 1, result.output
        assert isinstance(result.exception, SystemExit)  # _fail, not an escaped error
        assert "Traceback" not in result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(f"error: {path}: [study]: The ")
        for fragment in (*fragments, "more than max_runs = 1,000,000", "'sparse'"):
            assert fragment in lines[0], fragment
        assert memory.peak < 16 * 2**20, memory.peak  # no sample table: a few MB of Python
        assert not (tmp_path / path.stem).exists()  # refused before the output folder


def test_max_runs_option_overrides_the_study_file(tmp_path):
    study = tmp_path / "limited.toml"
    study.write_text(
        '[study]\nlevels = 4\nmax_runs = 10\n[model]\nname = "product"\n[parameters]\n'
        'x1 = { type = "triangular", modal = 2.0, spread = 0.1 }\n'
        'x2 = { type = "triangular", modal = 10.0, spread = 0.1 }\n'
    )
    result = runner.invoke(app, ["run", str(study), "--out", str(tmp_path / "a"), "-q"])
    assert result.exit_code == 1 and "17 model runs" in result.output
    assert "more than max_runs = 10." in result.output
    result = runner.invoke(
        app, ["run", str(study), "--out", str(tmp_path / "b"), "-q", "--max-runs", "17"]
    )
    assert result.exit_code == 0, result.output
    assert "Status: complete" in (tmp_path / "b" / "summary.txt").read_text()
    result = runner.invoke(
        app, ["run", str(study), "--out", str(tmp_path / "c"), "-q", "--max-runs", "0"]
    )
    assert result.exit_code == 2 and "--max-runs" in result.output


def test_cli_needs_no_click(fresh_python):
    # typer >= 0.2x ships without click: the README's install (no test extras, which
    # pull click in through dask) must still start the CLI
    code = "import sys; sys.modules['click'] = None; import fuzzymbs.cli; print('ok')"
    assert fresh_python(code).strip() == "ok"


def test_thousands_of_unknown_parameters_are_named_in_one_readable_line(tmp_path):
    bad = tmp_path / "many.toml"
    lines = [f'p{i} = {{ type = "triangular", modal = 1.0, spread = 0.1 }}' for i in range(5000)]
    bad.write_text('[model]\nname = "product"\n[parameters]\n' + "\n".join(lines) + "\n")
    result = runner.invoke(app, ["run", str(bad), "--out", str(tmp_path / "o")])
    assert result.exit_code == 1
    assert "['p0', 'p1', 'p2', 'p3', 'p4', 'p5', 'p6', 'p7', 'p8', 'p9', ... and 4,990 more]" in (
        result.output.replace("\n", "")
    )
    assert "p4999" not in result.output


def test_console_entry_freezes_the_heap_at_exit(fresh_python):
    # main() registers gc.freeze before the command runs, so it runs after the command's
    # own exit handlers (atexit is last in, first out): a handler registered before
    # main() runs after it and sees the heap frozen, and the command's output is complete
    code = (
        "import atexit, gc, sys\n"
        "atexit.register(lambda: print('frozen at exit:', gc.get_freeze_count() > 0))\n"
        "from fuzzymbs import cli\n"
        "sys.argv = ['fuzzymbs', 'info']\n"
        "try:\n"
        "    cli.main()\n"
        "except SystemExit as end:\n"
        "    assert end.code in (0, None), end.code\n"
        "print('frozen before exit:', gc.get_freeze_count() > 0)\n"
    )
    lines = fresh_python(code).strip().splitlines()
    assert any(line.startswith("Executors: inline") for line in lines)  # info's output
    assert lines[-2:] == ["frozen before exit: False", "frozen at exit: True"]
