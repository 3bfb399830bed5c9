"""Flexible slider-crank, 64 samples of a fuzzy study: fuzzymbs's planar engine against Exudyn.

    python benchmarks/slider_crank_exudyn.py [--no-cold-compile]

What is compared
----------------
The registered ``slider-crank`` model (:mod:`fuzzymbs.models.mechanisms.slider_crank`)
and the same mechanism built in Exudyn, each run on the same 64 samples as a
fuzzy study runs them: a 4 x 4 x 4 grid of Young's modulus in 2.0e11 * [0.95, 1.05]
Pa, rod height in 0.006 * [0.98, 1.02] m and slider mass in 0.1 * [0.9, 1.1] kg;
crank speed 150 rad/s reached in a spin-up of 0.02 s, outputs every 0.2 ms from
0 to 0.1 s (501 points, the model's defaults). The mechanism: a steel crank of
0.15 m (20 mm x 10 mm) whose angle is prescribed by Kane's smooth spin-up
(:class:`fuzzymbs.mbs.planar.SpinUp`), a steel connecting rod of 0.3 m (width
0.01 m, the sampled height and modulus), a slider of the sampled mass on the x
axis, no gravity. Outputs compared: the rod midpoint's deflection across the
rod's chord (pin to pin) [m] and the slider position [m].

* fuzzymbs: ``slider_crank()`` at its defaults -- a floating frame on the chord,
  6 pinned-pinned modes of a 12-element Euler-Bernoulli beam (5 bending, the
  first axial), geometric stiffening through the nodes' foreshortening;
  DOP853 (the engine's pair for flexible bodies), rtol 1e-6, atol 1e-8, joints projected
  after every step;
  all 64 samples in one call (the kernels release the GIL, samples are shared
  by Numba's thread count of cores).
* Exudyn: one system per sample, built, assembled and solved in a Python loop
  (what an Exudyn user does): the rod is a chain of ``ObjectANCFCable2D``
  elements on ``NodePoint2DSlope1`` nodes (geometrically exact Euler-Bernoulli
  beam: axial strain |r'| - 1 and the exact curvature, no rotary inertia, as in
  fuzzymbs); the crank an ``ObjectRigidBody2D`` whose node is held at the origin
  by two ``ObjectConnectorCoordinate`` and whose angle follows the spin-up
  through a third one with ``offsetUserFunction`` (and ``offsetUserFunction_t``);
  the crank pin an ``ObjectJointRevolute2D`` to the rod's first node; the slider
  an ``ObjectMassPoint2D`` on the rod's last node, whose y a coordinate
  constraint holds at 0 (the slider's rotation is locked in fuzzymbs, so its
  inertia plays no part). Implicit generalized-alpha (Exudyn's default,
  spectral radius 0.9, index 3), fixed step, modified Newton.

Exudyn's explicit solvers are no option here: they eliminate coordinate
constraints but cannot solve the revolute joint, nor follow a constraint's
offset user function, and the ANCF rod's highest frequencies (1.3e6 rad/s with
8 elements, by Exudyn's eigenvalue solver) would hold RK4 to steps of about
2 us; generalized-alpha damps those and steps over them.

Exudyn's settings and the accuracy they buy
-------------------------------------------
8 elements and a 20 us step make Exudyn's midpoint deflection about as accurate
as fuzzymbs's at its defaults (a 25 or 40 us step gives 8e-5 or 2.6e-4 of the
peak against the reference below). Newton's tolerances are loosened from
Exudyn's defaults (relative 1e-8, absolute 1e-10) to 1e-6 and 1e-4, where they
change the result by 2e-6 of the peak and save about a third of the time; the
default absolute one lies below the residual's round-off (some 3e-8 here),
where Newton stalls in the first steps and Exudyn's adaptive step halves the
step (so the steps are fixed: ``adaptiveStep = False``).

The script measures the accuracy at the default parameters after the timings:
fuzzymbs's default against its own fine setting (12 modes, 24 elements, rtol
1e-10, atol 1e-12) -- about 5e-5 of the deflection's peak, the mode count
dominating -- and Exudyn's setting against a halved step, doubled elements,
Newton tolerances / 100 and a reference with 4 x the elements and 1/8 of the
step (3e-5 to 5e-5 of the peak). All deviations are also given relative to the
width of the band the 64 samples span (the largest over time of max - min across
samples), the scale a fuzzy result is read on.

The two codes' references differ by more than either code's discretisation
error, and that difference, not the settings, bounds their agreement:

* midpoint deflection, 8e-4 of the peak (0.3 % of the band) at 150 rad/s, 6e-5
  at 75 rad/s: it grows steeply with the load and stays the same from 6 to 36
  fuzzymbs modes and under Exudyn's refinement -- the models' nonlinear
  kinematics differ (ANCF keeps the exact axial strain and curvature; fuzzymbs
  linear modes in the chord frame with second-order foreshortening);
* slider position, 2e-6 m (5 % of its narrow band, 4e-5 m; the slider moves
  almost as the rigid crank drives it): the rod's axial compliance, which
  fuzzymbs's modes carry without a static correction -- 1 axial mode at the
  default, 2 at the fine setting; against Exudyn's reference the difference
  falls from 2.3e-6 m (6 modes) to 1.3e-6, 4.2e-7 and 2.5e-7 m with 12, 24 and
  36 modes (24 elements), so fuzzymbs's default-vs-fine figure understates this error by
  about half.

Figures
-------
The machine (:func:`bench_common.machine`); the Numba compile time (cold: a
fresh interpreter with an empty ``NUMBA_CACHE_DIR``; and this process's first
call, which compiles or loads Numba's cache); fuzzymbs's time for the 64
samples in one call after that warm-up call, with Numba's default threads and
with one, and with one on Dormand-Prince 5(4) (the pair it used before DOP853);
Exudyn's time for the 64 samples (building the systems included; the
``SolveDynamic`` share given too) and per sample; the ratios Exudyn / fuzzymbs
on the machine and per core (fuzzymbs on one thread; Exudyn runs a sample on
one core). Each time is the smaller of two repeats, as wall time and as this
process's CPU time (core-seconds, all threads): where other work shares the
machine, two threads need not halve the wall time, and the CPU time still
counts the work. Then the agreement on four samples, the largest over all 64,
and of the band's bounds. The last line is one JSON object with all figures.
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import json
import math
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numba
import numpy as np
from bench_common import load_average, log, machine, run_json_subprocess
from numpy.typing import NDArray

from fuzzymbs.models.mechanisms.slider_crank import (
    CRANK_LENGTH,
    CRANK_SECTION,
    ROD_LENGTH,
    STEEL_DENSITY,
    slider_crank,
)

#: The fuzzy study's parameters: name -> (nominal, relative lower, relative upper).
RANGES = {
    "youngs_modulus": (2.0e11, 0.95, 1.05),
    "rod_height": (0.006, 0.98, 1.02),
    "slider_mass": (0.1, 0.9, 1.1),
}
GRID = 4
OUTPUTS = ("midpoint_deflection", "slider_position")
#: Exudyn's settings (see the module docstring for the accuracy they give).
ELEMENTS = 8
STEP = 2e-5
SPECTRAL_RADIUS = 0.9
NEWTON_RTOL = 1e-6
NEWTON_ATOL = 1e-4
#: fuzzymbs's fine setting (the reference its default accuracy is measured against).
FUZZYMBS_FINE = {"modes": 12, "elements": 24, "rtol": 1e-10, "atol": 1e-12}
#: Samples whose agreement is listed one by one (grid corners and two inner points).
SHOWN = (0, 21, 42, 63)
REPEAT = 2

_COLD = """
import json, time
from fuzzymbs.models.mechanisms.slider_crank import slider_crank
model = slider_crank()
start = time.perf_counter()
model({})
first = time.perf_counter() - start
start = time.perf_counter()
model({})
print(json.dumps({"first": first, "second": time.perf_counter() - start}))
"""


def best_times(func: Callable[[], Any], repeat: int = REPEAT) -> tuple[float, float]:
    """Smallest wall time and smallest CPU time [s] of ``repeat`` calls of ``func``.

    The CPU time is this process's, summed over its threads: the core-seconds a
    call costs, which other work on the machine changes far less than the wall
    time (it takes cores away, not cycles).
    """
    wall = cpu = float("inf")
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        func()
        wall = min(wall, time.perf_counter() - start)
        cpu = min(cpu, time.process_time() - start_cpu)
    return wall, cpu


def study_samples() -> dict[str, NDArray[np.float64]]:
    """The 64 samples: a ``GRID``-point grid in each of :data:`RANGES`, flattened."""
    axes = [nominal * np.linspace(low, high, GRID) for nominal, low, high in RANGES.values()]
    mesh = np.meshgrid(*axes, indexing="ij")
    return {name: column.ravel() for name, column in zip(RANGES, mesh, strict=True)}


def spin_up(t: float, speed: float, duration: float) -> tuple[float, float]:
    """Crank angle [rad] and rate [rad/s] of Kane's spin-up (:class:`SpinUp`'s formula)."""
    if t >= duration:
        return speed * (t - 0.5 * duration), speed
    w = 2.0 * math.pi / duration
    angle = speed / duration * (0.5 * t * t + (math.cos(w * t) - 1.0) / (w * w))
    return angle, speed / duration * (t - math.sin(w * t) / w)


def exudyn_slider_crank(
    p: dict[str, float],
    times: NDArray[np.float64],
    elements: int = ELEMENTS,
    step: float = STEP,
    newton_rtol: float = NEWTON_RTOL,
    newton_atol: float = NEWTON_ATOL,
) -> tuple[dict[str, NDArray[np.float64]], float]:
    """One sample in Exudyn: the outputs at ``times`` and the wall time of ``SolveDynamic``.

    Parameters
    ----------
    p : dict
        The slider-crank's parameters (every key of ``PARAMETERS``).
    times : ndarray, shape (T,)
        Output times from 0 [s], evenly spaced by a multiple of ``step``.
    elements : int
        ANCF cable elements of the rod (even: a node at the midpoint).
    step : float
        Fixed generalized-alpha step [s].
    newton_rtol, newton_atol : float
        Newton's relative and absolute residual tolerances.

    Returns
    -------
    outputs : dict
        ``midpoint_deflection`` and ``slider_position``, each (T,) [m].
    seconds : float
        Wall time of ``SolveDynamic`` [s].
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        MarkerNodePosition,
        NodePoint2DSlope1,
        NodePointGround,
        NodeRigidBody2D,
        ObjectANCFCable2D,
        ObjectConnectorCoordinate,
        ObjectJointRevolute2D,
        ObjectMassPoint2D,
        ObjectRigidBody2D,
        SensorNode,
    )

    speed, duration = p["crank_speed"], p["spin_up_time"]
    area = p["rod_width"] * p["rod_height"]
    second_moment = p["rod_width"] * p["rod_height"] ** 3 / 12.0
    crank_mass = STEEL_DENSITY * CRANK_LENGTH * CRANK_SECTION[0] * CRANK_SECTION[1]

    system = exu.SystemContainer()
    mbs = system.AddSystem()
    fixed = mbs.AddMarker(
        MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround()), coordinate=0)
    )

    def hold(node: Any, coordinate: int, **offset: Any) -> None:
        """Constrain a nodal coordinate to 0 (or to an offset function of time)."""
        marker = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=coordinate))
        mbs.AddObject(ObjectConnectorCoordinate(markerNumbers=[fixed, marker], **offset))

    # crank: node at the pivot, centre of mass at mid-length, inertia about the pivot
    pivot = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    crank = mbs.AddObject(
        ObjectRigidBody2D(
            nodeNumber=pivot,
            mass=crank_mass,
            inertia=crank_mass * CRANK_LENGTH**2 / 3.0,
            centerOfMass=[CRANK_LENGTH / 2, 0.0],
        )
    )
    hold(pivot, 0)
    hold(pivot, 1)
    hold(
        pivot,
        2,
        offsetUserFunction=lambda mbs_, t, item, offset: spin_up(t, speed, duration)[0],
        offsetUserFunction_t=lambda mbs_, t, item, offset: spin_up(t, speed, duration)[1],
    )
    # rod: ANCF cable elements from the crank pin along x
    length = ROD_LENGTH / elements
    nodes = [
        mbs.AddNode(
            NodePoint2DSlope1(referenceCoordinates=[CRANK_LENGTH + k * length, 0.0, 1.0, 0.0])
        )
        for k in range(elements + 1)
    ]
    for first, second in itertools.pairwise(nodes):
        mbs.AddObject(
            ObjectANCFCable2D(
                nodeNumbers=[first, second],
                length=length,
                massPerLength=STEEL_DENSITY * area,
                bendingStiffness=p["youngs_modulus"] * second_moment,
                axialStiffness=p["youngs_modulus"] * area,
            )
        )
    pin = mbs.AddMarker(
        MarkerBodyPosition(bodyNumber=crank, localPosition=[CRANK_LENGTH, 0.0, 0.0])
    )
    root = mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[0]))
    mbs.AddObject(ObjectJointRevolute2D(markerNumbers=[pin, root]))
    # slider: a mass point on the rod's last node, held on the x axis
    mbs.AddObject(ObjectMassPoint2D(nodeNumber=nodes[-1], mass=p["slider_mass"]))
    hold(nodes[-1], 1)
    sensors = [
        mbs.AddSensor(
            SensorNode(
                nodeNumber=nodes[k],
                storeInternal=True,
                outputVariableType=exu.OutputVariableType.Position,
            )
        )
        for k in (0, elements // 2, elements)
    ]
    mbs.Assemble()

    settings = exu.SimulationSettings()
    ti = settings.timeIntegration
    ti.endTime = float(times[-1])
    ti.numberOfSteps = round(times[-1] / step)
    ti.adaptiveStep = False  # fixed steps (reductions would shift the sensor times)
    ti.generalizedAlpha.spectralRadius = SPECTRAL_RADIUS
    ti.newton.relativeTolerance = newton_rtol
    ti.newton.absoluteTolerance = newton_atol
    ti.verboseMode = 0
    if elements > 8:  # the dense solve's cost grows with the cube of the coordinates
        settings.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = float(times[1] - times[0])
    settings.show.computationTime = False
    settings.show.statistics = False
    start = time.perf_counter()
    mbs.SolveDynamic(settings)
    seconds = time.perf_counter() - start

    root_xy, middle_xy, tip_xy = (np.asarray(mbs.GetSensorStoredData(s)) for s in sensors)
    recorded = root_xy[:, 0]
    chord = tip_xy[:, 1:3] - root_xy[:, 1:3]
    chord /= np.linalg.norm(chord, axis=1)[:, None]
    arm = middle_xy[:, 1:3] - root_xy[:, 1:3]
    deflection = chord[:, 0] * arm[:, 1] - chord[:, 1] * arm[:, 0]
    outputs = {
        "midpoint_deflection": np.interp(times, recorded, deflection),
        "slider_position": np.interp(times, recorded, tip_xy[:, 1]),
    }
    return outputs, seconds


def exudyn_batch(
    parameters: list[dict[str, float]], times: NDArray[np.float64], **settings: Any
) -> tuple[dict[str, NDArray[np.float64]], float]:
    """Every sample in turn: outputs ``{name: (B, T)}`` and the summed ``SolveDynamic`` time."""
    rows: dict[str, list[NDArray[np.float64]]] = {name: [] for name in OUTPUTS}
    solving = 0.0
    for p in parameters:
        outputs, seconds = exudyn_slider_crank(p, times, **settings)
        solving += seconds
        for name in OUTPUTS:
            rows[name].append(outputs[name])
    return {name: np.array(rows[name]) for name in OUTPUTS}, solving


def band_width(outputs: dict[str, NDArray[np.float64]]) -> dict[str, float]:
    """Largest width over time of the band the samples span, per output."""
    return {name: float(np.max(np.ptp(outputs[name], axis=0))) for name in OUTPUTS}


def deviation(
    a: dict[str, NDArray[np.float64]],
    b: dict[str, NDArray[np.float64]],
    band: dict[str, float],
) -> dict[str, dict[str, float]]:
    """Largest |a - b| over the run per output [m], of ``b``'s peak and of the band width."""
    rows = {}
    for name in OUTPUTS:
        largest = float(np.max(np.abs(a[name] - b[name])))
        peak = float(np.max(np.abs(b[name])))
        rows[name] = {"abs": largest, "of_peak": largest / peak, "of_band": largest / band[name]}
    return rows


def cold_compile_seconds() -> float:
    """Numba's compile time of the model: first minus second call in a fresh interpreter
    with an empty cache directory."""
    with tempfile.TemporaryDirectory() as cache:
        times = run_json_subprocess(_COLD, env={"NUMBA_CACHE_DIR": cache}, timeout=1800.0)
    return times["first"] - times["second"]


def accuracy(band: dict[str, float]) -> dict[str, dict[str, dict[str, float]]]:
    """Discretisation errors of both codes and the models' difference, default parameters."""
    times = slider_crank().times
    default = {n: v[0] for n, v in slider_crank()({}).items() if n in OUTPUTS}
    fine = {n: v[0] for n, v in slider_crank(**FUZZYMBS_FINE)({}).items() if n in OUTPUTS}
    p = slider_crank().sample_parameters({})[0]
    chosen, _ = exudyn_slider_crank(p, times)
    reference, _ = exudyn_slider_crank(p, times, elements=4 * ELEMENTS, step=STEP / 8)
    variants = {
        f"halved step ({STEP / 2:g} s)": {"step": STEP / 2},
        f"doubled elements ({2 * ELEMENTS})": {"elements": 2 * ELEMENTS},
        "Newton tolerances / 100": {
            "newton_rtol": NEWTON_RTOL / 100,
            "newton_atol": NEWTON_ATOL / 100,
        },
    }
    fine_text = ", ".join(f"{k} {v:g}" for k, v in FUZZYMBS_FINE.items())
    rows = {f"fuzzymbs default vs fine ({fine_text})": deviation(default, fine, band)}
    for label, settings in variants.items():
        finer, _ = exudyn_slider_crank(p, times, **settings)
        rows[f"exudyn chosen vs {label}"] = deviation(chosen, finer, band)
    label = f"reference ({4 * ELEMENTS} elements, {STEP / 8:g} s)"
    rows[f"exudyn chosen vs {label}"] = deviation(chosen, reference, band)
    rows["models: fuzzymbs fine vs exudyn reference"] = deviation(fine, reference, band)
    return rows


def print_rows(title: str, rows: dict[str, dict[str, dict[str, float]]]) -> None:
    """A table of :func:`deviation` rows."""
    print(f"\n{title}")
    head = f"{'abs [m]':>9s} {'of peak':>8s} {'of band':>8s}"
    print(f"  {'':60s} {'deflection':^27s}   {'slider position':^27s}")
    print(f"  {'':60s} {head}   {head}")
    for label, row in rows.items():
        cells = "   ".join(
            f"{row[n]['abs']:9.2e} {row[n]['of_peak']:8.2e} {row[n]['of_band']:8.2e}"
            for n in OUTPUTS
        )
        print(f"  {label:60s} {cells}")


def print_time(label: str, seconds: float, note: str = "") -> None:
    """One line of the timing table."""
    print(f"  {label:52s} {seconds:8.2f} {note}".rstrip())


def agreement(
    fuzzy: dict[str, NDArray[np.float64]],
    exudyn: dict[str, NDArray[np.float64]],
    parameters: list[dict[str, float]],
    band: dict[str, float],
) -> dict[str, dict[str, dict[str, float]]]:
    """Exudyn against fuzzymbs: a few samples, the largest over all, the band's bounds."""
    rows = {}
    for i in SHOWN:
        values = ", ".join(f"{parameters[i][n]:.4g}" for n in RANGES)
        rows[f"sample {i:2d} ({values})"] = deviation(
            {n: exudyn[n][i] for n in OUTPUTS}, {n: fuzzy[n][i] for n in OUTPUTS}, band
        )
    rows[f"largest over all {len(parameters)} samples"] = deviation(exudyn, fuzzy, band)
    for bound, reduce in (("upper", np.max), ("lower", np.min)):
        rows[f"band's {bound} bound"] = deviation(
            {n: reduce(exudyn[n], axis=0) for n in OUTPUTS},
            {n: reduce(fuzzy[n], axis=0) for n in OUTPUTS},
            band,
        )
    return rows


def main(cold: bool = True) -> dict[str, Any]:
    """Run the comparison, print the figures; return them."""
    if importlib.util.find_spec("exudyn") is None:
        raise SystemExit("this benchmark needs Exudyn: pip install -e '.[bench]'")
    figures: dict[str, Any] = {"machine": machine()}
    info = figures["machine"]
    print(f"machine: {info['platform']} | {info['cpu'].get('Model name', '?')}")
    print(
        f"  {info['cpu_count']} CPUs, Numba threads {numba.get_num_threads()}, BLAS {info['blas']}"
    )
    print("  " + ", ".join(f"{k} {v}" for k, v in info["versions"].items() if v))
    print(f"  source {info['source']}, load average {info['load_average_at_start']}")

    samples = study_samples()
    model = slider_crank()
    parameters = model.sample_parameters(samples)
    count = len(parameters)
    ranges = ", ".join(f"{n} {v[0]:g} x [{v[1]}, {v[2]}]" for n, v in RANGES.items())
    print(f"\n{count} samples ({GRID}^3 grid: {ranges})")
    print(f"  outputs at {model.times.size} times over {model.times[-1]:g} s")
    print(
        f"  exudyn: {ELEMENTS} ANCF cable elements, generalized-alpha (spectral radius "
        f"{SPECTRAL_RADIUS:g}), fixed step {STEP:g} s, Newton rtol {NEWTON_RTOL:g} atol "
        f"{NEWTON_ATOL:g}"
    )

    if cold:
        log("cold compile (fresh interpreter, empty Numba cache) ...")
        figures["fuzzymbs_cold_compile_seconds"] = cold_compile_seconds()
    start = time.perf_counter()
    model({name: column[:2] for name, column in samples.items()})  # warm-up
    figures["fuzzymbs_first_call_seconds"] = time.perf_counter() - start

    threads = numba.get_num_threads()
    log(f"fuzzymbs, {count} samples, {threads} threads ...")
    fuzzy: dict[str, Any] = {}
    figures["fuzzymbs_seconds"], figures["fuzzymbs_cpu_seconds"] = best_times(
        lambda: fuzzy.update(model(samples))
    )
    if np.any(fuzzy["failed"]):
        raise RuntimeError(f"fuzzymbs samples failed: {set(fuzzy['failure_reason'])}")
    log(f"fuzzymbs, {count} samples, 1 thread ...")
    numba.set_num_threads(1)
    try:
        figures["fuzzymbs_seconds_1_thread"], figures["fuzzymbs_cpu_seconds_1_thread"] = best_times(
            lambda: model(samples)
        )
        log(f"fuzzymbs, {count} samples, 1 thread, Dormand-Prince 5(4) ...")
        previous = slider_crank(integrator="dopri5")
        previous({name: column[:2] for name, column in samples.items()})  # warm-up
        figures["fuzzymbs_dopri5_seconds_1_thread"], _ = best_times(lambda: previous(samples))
    finally:
        numba.set_num_threads(threads)

    log(f"exudyn, {count} samples, one system each ...")
    exudyn_slider_crank(parameters[0], model.times)  # warm-up (imports, first solve)
    runs: list[tuple[dict[str, NDArray[np.float64]], float]] = []
    figures["exudyn_seconds"], figures["exudyn_cpu_seconds"] = best_times(
        lambda: runs.append(exudyn_batch(parameters, model.times))
    )
    exudyn = runs[-1][0]
    figures["exudyn_solve_seconds"] = min(seconds for _, seconds in runs)

    band = band_width(fuzzy)
    figures["band_width"] = band
    figures["band_width_exudyn"] = band_width(exudyn)
    figures["agreement"] = agreement(fuzzy, exudyn, parameters, band)
    log("accuracy at the default parameters ...")
    figures["accuracy"] = accuracy(band)

    fz, fz1 = figures["fuzzymbs_seconds"], figures["fuzzymbs_seconds_1_thread"]
    ex = figures["exudyn_seconds"]
    cpu_fz, cpu_ex = figures["fuzzymbs_cpu_seconds"], figures["exudyn_cpu_seconds"]
    figures["ratio"] = ex / fz
    figures["ratio_per_core"] = ex / fz1
    figures["ratio_cpu"] = cpu_ex / cpu_fz
    print("\ntimes [s], each the smaller of two repeats: wall | CPU (core-seconds, all threads)")
    if cold:
        cold_seconds = figures["fuzzymbs_cold_compile_seconds"]
        print_time("Numba compile (fresh interpreter, empty cache)", cold_seconds)
    print_time(
        "fuzzymbs first call here (2 samples)",
        figures["fuzzymbs_first_call_seconds"],
        "(compiles, or loads Numba's cache when it is current)",
    )
    rows = (
        (f"fuzzymbs, {count} samples in one call, {threads} threads", fz, cpu_fz, ""),
        (
            f"fuzzymbs, {count} samples in one call, 1 thread",
            fz1,
            figures["fuzzymbs_cpu_seconds_1_thread"],
            "",
        ),
        (
            "fuzzymbs, the same with Dormand-Prince 5(4), 1 thread",
            figures["fuzzymbs_dopri5_seconds_1_thread"],
            float("nan"),
            " (the pair before DOP853)",
        ),
        (
            f"exudyn, {count} samples one by one",
            ex,
            cpu_ex,
            f", SolveDynamic {figures['exudyn_solve_seconds'] / count * 1e3:.1f} ms "
            f"({round(model.times[-1] / STEP)} steps)",
        ),
    )
    for label, wall, cpu, note in rows:
        print_time(label, wall, f"| {cpu:6.2f}   per sample {wall / count * 1e3:.1f} ms wall{note}")
    for label, key in (
        ("ratio exudyn / fuzzymbs, wall", "ratio"),
        ("ratio per core, wall: exudyn / fuzzymbs on 1 thread", "ratio_per_core"),
        ("ratio per core, CPU time: exudyn / fuzzymbs", "ratio_cpu"),
    ):
        print_time(label, figures[key])
    print(f"  load average at the end {load_average()}")

    print("\nwidth of the band the samples span (largest max - min over time) [m]")
    for name in OUTPUTS:
        exudyn_band = figures["band_width_exudyn"][name]
        print(f"  {name:20s} fuzzymbs {band[name]:.4e}, exudyn {exudyn_band:.4e}")
    print_rows("exudyn vs fuzzymbs: largest difference over the run", figures["agreement"])
    print_rows("accuracy, default parameters: largest difference over the run", figures["accuracy"])
    figures["exudyn_settings"] = {
        "elements": ELEMENTS,
        "step": STEP,
        "solver": "generalized-alpha",
        "spectral_radius": SPECTRAL_RADIUS,
        "newton_rtol": NEWTON_RTOL,
        "newton_atol": NEWTON_ATOL,
    }
    print(json.dumps(figures, default=float))
    return figures


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--no-cold-compile", action="store_true", help="skip the cold Numba compile (about 40 s)"
    )
    main(cold=not parser.parse_args().no_cold_compile)
