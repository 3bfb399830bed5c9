"""Convergence of the mechanism models' numerical defaults (tolerance, modes, elements).

For each registered mechanism model (flexible-pendulum, spin-up-beam,
slider-crank) at its default parameters, the largest deviation of each output
over the run from a finer setting:

* tolerance: rtol 1e-6 / atol 1e-8 (the engine's default) and rtol 1e-5 / atol 1e-7 (the
  slider-crank's), against rtol 1e-10 / atol 1e-12 (each model at its default pair: DOP853,
  the bodies being flexible);
* modes: the default mode count against twice as many (tight tolerance both; the
  pendulum's clamped modes on a pinned beam against 8, the most its mass matrix allows);
* elements: the default element count against twice as many (tight tolerance both);

each stated relative to the output's peak and to the width of the band a 5 %
spread of Young's modulus gives (the scale a fuzzy result is read on; the
spread's two runs at the fine setting). Run: ``python benchmarks/mechanisms_convergence.py``.
"""

from __future__ import annotations

import numpy as np

from fuzzymbs.models.mechanisms import pendulum, slider_crank, spin_up_beam

TIGHT = {"rtol": 1e-10, "atol": 1e-12}
CASES = {
    "flexible-pendulum": (pendulum.flexible_pendulum, pendulum.MODES, 8, pendulum.ELEMENTS),
    "spin-up-beam": (spin_up_beam.spin_up_beam, spin_up_beam.MODES, 12, spin_up_beam.ELEMENTS),
    "slider-crank": (slider_crank.slider_crank, slider_crank.MODES, 12, slider_crank.ELEMENTS),
}


def outputs(factory, **options) -> dict[str, np.ndarray]:
    model = factory(**options)
    raw = model({})
    assert not raw["failed"].any(), raw["failure_reason"]
    return {name: np.asarray(raw[name])[0] for name in model.outputs}


def band_width(factory, modes, elements) -> dict[str, float]:
    """Largest width over time of the band between E * 0.95 and E * 1.05."""
    model = factory(modes=modes, elements=elements, **TIGHT)
    modulus = model.defaults["youngs_modulus"]
    raw = model({"youngs_modulus": [0.95 * modulus, 1.05 * modulus]})
    return {name: float(np.max(np.abs(raw[name][1] - raw[name][0]))) for name in model.outputs}


def main() -> None:
    print("largest deviation over the run: of the peak | of the 5 %-E band width")
    for case, (factory, modes, more_modes, elements) in CASES.items():
        fine = outputs(factory, **TIGHT)
        width = band_width(factory, modes, elements)
        settings = {
            "tolerance (rtol 1e-6)": outputs(factory, rtol=1e-6, atol=1e-8),
            "tolerance (rtol 1e-5)": outputs(factory, rtol=1e-5, atol=1e-7),
            f"modes ({modes} vs {more_modes})": fine,
            f"elements ({elements} vs {2 * elements})": fine,
        }
        finer = {
            "tolerance (rtol 1e-6)": fine,
            "tolerance (rtol 1e-5)": fine,
            f"modes ({modes} vs {more_modes})": outputs(factory, modes=more_modes, **TIGHT),
            f"elements ({elements} vs {2 * elements})": outputs(
                factory, elements=2 * elements, **TIGHT
            ),
        }
        for setting, coarse in settings.items():
            for name in coarse:
                deviation = np.max(np.abs(coarse[name] - finer[setting][name]))
                peak = np.max(np.abs(finer[setting][name]))
                print(
                    f"{case:18s} {setting:24s} {name:20s} {deviation / peak:9.2e} | "
                    f"{deviation / width[name]:9.2e}"
                )


if __name__ == "__main__":
    main()
