"""What one sample-step of the brake costs on this machine (a study's time estimate).

A study of the brake spends its time integrating: its cost is its sample-steps
(every run's accepted and rejected steps) times the cost of one. That cost is
measured here on one SIMD block of modal samples over the first
:data:`CALIBRATION_END` of sliding, the stretch where contact closes and the
integrator works hardest; ``fuzzymbs demo brake`` scales the demo's recorded
time by the ratio of this cost now to its cost when the demo was timed.
"""

from __future__ import annotations

import time

import numpy as np

from fuzzymbs.models.brake.model import DEFAULTS, DiscBrake

__all__ = ["CALIBRATION_END", "CALIBRATION_RTOL", "seconds_per_sample_step"]

#: Brake time integrated by the calibration [s] (about 0.3 s of one core).
CALIBRATION_END = 2e-4
#: The integrator tolerance of the calibration: the one the demo's studies choose.
CALIBRATION_RTOL = 1e-3
#: Samples in the calibration's batch: one SIMD block (the lanes kernel's width).
CALIBRATION_SAMPLES = 4


def seconds_per_sample_step(t_end: float = CALIBRATION_END, repeat: int = 3) -> float:
    """Wall time [s] of one sample-step of the brake here (ROS34PW2 at
    :data:`CALIBRATION_RTOL`, the modal sample in a block of
    :data:`CALIBRATION_SAMPLES`), the fastest of ``repeat`` runs after one run that
    compiles the kernels (or loads them from Numba's cache)."""
    model = DiscBrake(t_end=t_end, rtol=CALIBRATION_RTOL)
    samples = {name: np.full(CALIBRATION_SAMPLES, value) for name, value in DEFAULTS.items()}
    model.simulation.simulate(samples, t_end=t_end / 10)  # compile, or load the cache
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        result = model.simulation.simulate(samples)
        wall = time.perf_counter() - start
        steps = int(np.sum(result.step_counts))
        best = min(best, wall / steps)
    return float(best)
