"""The batched elastic disc-brake model (THEORY section 4).

Disc, lower and upper pad and caliper are finite-element bodies reduced
modally (:mod:`fuzzymbs.models.brake.geometry`), joined with the multibody
engine (:mod:`fuzzymbs.mbs`):

* disc: a :class:`~fuzzymbs.mbs.spatial.FlexibleBody` on a
  :class:`~fuzzymbs.mbs.spatial.Revolute` joint about y, driven at ``disc_speed``;
* pads and caliper: flexible bodies on :class:`~fuzzymbs.mbs.spatial.Prismatic`
  joints along y, each with its elastic modes (the System solves the four in
  minimal coordinates, :mod:`fuzzymbs.mbs.frame_motion`);
* 25 nodal forces ``nodal_force`` per pad on its back face, pressing it on the disc;
* 25 springs ``pad_spring_stiffness`` (y) per pad from its back face to the caliper jaw;
* 4 springs ``caliper_spring_stiffness`` (y) from the lower jaw to ground;
* penalty contact ``penalty_stiffness`` with regularised Coulomb friction
  ``friction_coefficient`` between each pad and the disc, either two-pass
  (default: the pad's 25 contact nodes against the disc's 48-node patch, and the
  48 patch nodes against the pad face) or single-pass (the 25 pad nodes only).

Outputs: the translations ``y_lpad``, ``y_upad``, ``y_cali`` [m] of the three
frames (for the free-free pads and caliper, the displacement of their centre
of mass, because the elastic modes carry no net translation), over
``model.coords["time"]``; with ``velocities=True`` also ``v_lpad``, ``v_upad``,
``v_cali`` [m/s] (phase diagrams).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.contact import PenaltyContact, PolarChart
from fuzzymbs.mbs.forces import NodalForce, Spring
from fuzzymbs.mbs.integrate import SimulationModel
from fuzzymbs.mbs.parameters import Parameter
from fuzzymbs.mbs.planar.profiles import ConstantRate
from fuzzymbs.mbs.spatial.bodies import FlexibleBody, frame_with_z, ground
from fuzzymbs.mbs.spatial.joints import Prismatic, Revolute
from fuzzymbs.mbs.step_stability import StepStability, rk4_step_stability
from fuzzymbs.mbs.system import CompiledSystem, Coordinate, System
from fuzzymbs.models.brake.geometry import BrakeBodies, BrakeDesign, build_bodies
from fuzzymbs.study.registry import ParameterInfo
from fuzzymbs.tolerance import DEFAULT_TOLERANCE, Tolerance

__all__ = ["CONTACT_TREATMENTS", "DEFAULTS", "OUTPUTS", "PARAMETERS", "DiscBrake", "brake_system"]

#: The paper's values (THEORY section 4), SI units.
DEFAULTS: dict[str, float] = {
    "pad_spring_stiffness": 200e3,  # k [N/m], each of 25 springs per pad
    "caliper_spring_stiffness": 1e3,  # k_c [N/m], each of 4 springs
    "nodal_force": 16e3,  # F_n [N], each of 25 nodes per pad (400 kN per pad)
    "disc_speed": 1.0,  # omega [rad/s]
    "penalty_stiffness": 1e8,  # c_p [N/m] per contact point
    "friction_coefficient": 0.7,  # mu [-]
}

#: Parameters that must be >= 0 (stiffnesses, force, friction) or > 0 (penalty).
_NON_NEGATIVE = (
    "pad_spring_stiffness",
    "caliper_spring_stiffness",
    "nodal_force",
    "friction_coefficient",
)
_POSITIVE = ("penalty_stiffness",)

CONTACT_TREATMENTS = ("two-pass", "single-pass")

PARAMETERS = {
    "pad_spring_stiffness": ParameterInfo(
        "N/m", "k: each of the 25 pad-caliper springs (y) per pad", DEFAULTS["pad_spring_stiffness"]
    ),
    "caliper_spring_stiffness": ParameterInfo(
        "N/m",
        "k_c: each of the 4 caliper-ground springs (y), lower-pad side",
        DEFAULTS["caliper_spring_stiffness"],
    ),
    "nodal_force": ParameterInfo(
        "N", "F_n: each of the 25 nodal forces pressing a pad on the disc", DEFAULTS["nodal_force"]
    ),
    "disc_speed": ParameterInfo(
        "rad/s", "omega: disc rotation speed about y", DEFAULTS["disc_speed"]
    ),
    "penalty_stiffness": ParameterInfo(
        "N/m", "c_p: contact penalty per contact point", DEFAULTS["penalty_stiffness"]
    ),
    "friction_coefficient": ParameterInfo(
        "-", "mu: Coulomb friction coefficient pad-disc", DEFAULTS["friction_coefficient"]
    ),
}

#: Outputs of :class:`DiscBrake` and their units (velocities only with ``velocities=True``).
OUTPUTS = {"y_lpad": "m", "y_upad": "m", "y_cali": "m"}
VELOCITY_OUTPUTS = {"v_lpad": "m/s", "v_upad": "m/s", "v_cali": "m/s"}

# per side: pad body, disc patch, normal of the disc patch (towards the pad), normal of
# the pad face (towards the disc) = direction of the press forces
_SIDES = {
    "lower": ("lower_pad", "patch_lower", "-y", "y"),
    "upper": ("upper_pad", "patch_upper", "y", "-y"),
}


def brake_system(
    bodies: BrakeBodies,
    contact: str = "two-pass",
    regularization_velocity: float = 1e-3,
    modal_damping_ratio: float = 0.0,
) -> System:
    """Assemble the brake from its reduced bodies (parameters bound to the sample columns).

    Parameters
    ----------
    bodies : BrakeBodies
        Reduced disc, pads and caliper.
    contact : {"two-pass", "single-pass"}
        Contact treatment (see the module docstring and docs/brake.md).
    regularization_velocity : float
        eps [m/s] of the regularised Coulomb law ``f_T = -mu f_N v_t / sqrt(|v_t|^2 + eps^2)``.
    modal_damping_ratio : float
        Damping ratio zeta of every elastic mode [-] (the paper: none).
    """
    if contact not in CONTACT_TREATMENTS:
        raise InvalidParameterError(f"contact must be one of {CONTACT_TREATMENTS}, got {contact!r}")
    p = {name: Parameter(name, value) for name, value in DEFAULTS.items()}
    system = System()
    y = frame_with_z((0.0, 1.0, 0.0))  # every joint acts along the disc's axis, global y
    disc = system.add_body(FlexibleBody("disc", bodies.disc, damping_ratio=modal_damping_ratio))
    drive = ConstantRate(p["disc_speed"])
    system.add_joint(Revolute(ground.point(axes=y), disc.point(axes=y), drive, "disc_bearing"))
    for modal in (bodies.lower_pad, bodies.upper_pad, bodies.caliper):
        body = system.add_body(FlexibleBody(modal.name, modal, damping_ratio=modal_damping_ratio))
        system.add_joint(
            Prismatic(ground.point(axes=y), body.point(axes=y), name=f"{modal.name}_guide")
        )
    chart = PolarChart("y", "x")  # the same polar chart about the disc axis on every body
    common = {
        "penalty": p["penalty_stiffness"],
        "friction": p["friction_coefficient"],
        "regularization_velocity": regularization_velocity,
    }
    for side, (pad, patch, patch_normal, face_normal) in _SIDES.items():
        # press the pad on the disc: +y for the lower pad, -y for the upper pad
        system.add(NodalForce(f"{side}_press", pad, "back", face_normal, p["nodal_force"]))
        system.add(
            Spring(
                f"{side}_pad_caliper",
                pad,
                "back",
                "caliper",
                f"{side}_jaw",
                stiffness=p["pad_spring_stiffness"],
                direction="y",
            )
        )
        system.add(
            PenaltyContact(
                f"{side}_pad->disc",
                pad,
                "contact",
                "disc",
                patch,
                chart,
                normal=patch_normal,
                **common,
            )
        )
        if contact == "two-pass":
            system.add(
                PenaltyContact(
                    f"disc->{side}_pad",
                    "disc",
                    patch,
                    pad,
                    "face",
                    chart,
                    normal=face_normal,
                    **common,
                )
            )
    system.add(
        Spring(
            "caliper_ground",
            "caliper",
            "ground",
            stiffness=p["caliper_spring_stiffness"],
            direction="y",
        )
    )
    return system


def check_samples(samples: Mapping[str, Any]) -> dict[str, NDArray[np.float64]]:
    """Validate brake parameter columns: known names, finite 1-D, physical ranges.

    Raises
    ------
    InvalidParameterError
        Naming the parameter and the valid range.
    """
    unknown = sorted(set(samples) - set(DEFAULTS))
    if unknown:
        raise InvalidParameterError(
            f"unknown brake parameter(s) {unknown}; valid: {sorted(DEFAULTS)}"
        )
    columns = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in samples.items()}
    for name, col in columns.items():
        if col.ndim != 1 or not np.isfinite(col).all():
            raise InvalidParameterError(f"brake parameter {name!r} must be finite 1-D, got {col}")
        if name in _NON_NEGATIVE and (col < 0).any():
            raise InvalidParameterError(
                f"brake parameter {name!r} must be >= 0, got {col[col < 0][0]!r}"
            )
        if name in _POSITIVE and (col <= 0).any():
            raise InvalidParameterError(
                f"brake parameter {name!r} must be > 0, got {col[col <= 0][0]!r}"
            )
    return columns


class DiscBrake:
    """Batched disc-brake model: ``model({param: (B,)}) -> {output: (B, T)}``.

    FE assembly and modal reduction run once at construction (cached on disk by
    :mod:`fuzzymbs.fe.cache`); the object then holds only plain arrays (the
    compiled system), so it pickles cheaply to worker processes.

    Parameters
    ----------
    design : BrakeDesign, optional
        Geometry, materials and mode counts (default: the documented brake).
    t_end : float
        End time [s] (paper: 10 ms).
    dt : float
        RK4's step [s] with ``integrator="rk4"`` (paper: 1e-6 s); ROS34PW2's first
        step.
    record_interval : float
        Output sampling interval [s] (a multiple of dt; 5 us resolves the
        32 kHz pad-on-disc ringing with about 6 points per period).
    contact : {"two-pass", "single-pass"}
        Contact treatment; two-pass by default (docs/brake.md explains why).
    regularization_velocity : float
        eps [m/s] of the regularised friction law.
    modal_damping_ratio : float
        Damping ratio of every elastic mode [-] (paper: 0).
    velocities : bool
        Also output the frame velocities ``v_lpad``, ``v_upad``, ``v_cali`` [m/s].
    displacement_bound : float
        A sample whose |y| output exceeds this [m] is stopped and flagged failed.
    chunk_size : int
        Samples per call of the RK4 kernel (its blocks run over Numba's threads).
    kernel : {"auto", "lanes", "samples"}
        How samples share the kernel's lanes (see :func:`fuzzymbs.mbs.integrate.simulate`):
        by default four samples per SIMD vector; "samples": a block per sample. Both
        give a sample bit-identical outputs whatever shares its block.
    integrator, rtol, atol
        ``"ros34pw2"`` (default): the linearly implicit ROS34PW2 with error control
        at rtol and atol (default: those of :data:`fuzzymbs.tolerance.DEFAULT_TOLERANCE`;
        atol None: a fraction of rtol); ``"rodas4"``: RODAS4 (order 4, a fresh Jacobian
        every step) in the same kernel, about half the CPU of ROS34PW2 for the same
        error from 5e-5 to 7e-6 of the peak (docs/brake.md); ``"rk4"``: the paper's
        fixed-step RK4 at dt, for reproducing the publication (see
        :func:`fuzzymbs.mbs.integrate.simulate`).
        Over 10 ms, ROS34PW2 at the default rtol is 0.27 % of the peak off a converged
        reference, RK4 at 1 us 13.1 %
        (docs/brake.md, "Accuracy of the time integration"). A fuzzy study reads the
        cut width, not the peak: a study tightens rtol for its cut widths itself
        (``scalable_tolerance``; docs/brake.md, "Bands above the numerical noise").
    """

    parameters = PARAMETERS

    def __init__(
        self,
        design: BrakeDesign | None = None,
        *,
        t_end: float = 0.01,
        dt: float = 1e-6,
        record_interval: float = 5e-6,
        contact: str = "two-pass",
        regularization_velocity: float = 1e-3,
        modal_damping_ratio: float = 0.0,
        velocities: bool = False,
        displacement_bound: float = 1e-3,
        chunk_size: int = 64,
        kernel: str = "auto",
        integrator: str = "ros34pw2",
        rtol: float = DEFAULT_TOLERANCE.rtol,
        atol: float | None = DEFAULT_TOLERANCE.atol,
    ) -> None:
        self.design = design or BrakeDesign()
        self.contact = contact
        bodies = build_bodies(self.design)
        system = brake_system(bodies, contact, regularization_velocity, modal_damping_ratio)
        outputs = {
            "y_lpad": Coordinate("lower_pad", 0),
            "y_upad": Coordinate("upper_pad", 0),
            "y_cali": Coordinate("caliper", 0),
        }
        if velocities:
            outputs.update(
                {
                    "v_lpad": Coordinate("lower_pad", 0, velocity=True),
                    "v_upad": Coordinate("upper_pad", 0, velocity=True),
                    "v_cali": Coordinate("caliper", 0, velocity=True),
                }
            )
        self.simulation = SimulationModel(
            system,
            t_end=t_end,
            dt=dt,
            outputs=outputs,
            record_interval=record_interval,
            displacement_bound=displacement_bound,
            chunk_size=chunk_size,
            kernel=kernel,
            integrator=integrator,
            tolerance=replace(DEFAULT_TOLERANCE, rtol=rtol, atol=atol),
        )
        self.coords = self.simulation.coords
        self.coord_units = {"time": "s"}
        self.outputs = {**OUTPUTS, **(VELOCITY_OUTPUTS if velocities else {})}
        self.output_dims = self.simulation.output_dims
        self.frequencies = {
            name: getattr(bodies, name).frequencies / (2 * np.pi)
            for name in ("disc", "lower_pad", "upper_pad", "caliper")
        }

    @property
    def compiled(self) -> CompiledSystem:
        """The compiled multibody system (kernel arrays)."""
        return self.simulation.compiled

    @property
    def time_integration(self) -> str:
        """The time integration in words (for study summaries)."""
        return self.simulation.time_integration

    @property
    def scalable_tolerance(self) -> bool:
        """True with ROS34PW2: a study may choose the tolerance for its cut widths."""
        return self.simulation.scalable_tolerance

    @property
    def tolerance(self) -> Tolerance:
        """The integrator's tolerance and its checks' tightening."""
        return self.simulation.tolerance

    def tightened(self, factor: float | None = None) -> DiscBrake:
        """The same brake with the tolerance divided by ``factor`` (default the tolerance's
        tightening; RK4: the step divided), for the study runner's choice and check of the
        time integration."""
        tight = copy.copy(self)
        tight.simulation = self.simulation.tightened(factor)
        return tight

    def prepare_tightened(self, factor: float | None = None) -> None:
        """Start building ``tightened(factor)`` in the background (on shared steps; see
        :meth:`fuzzymbs.mbs.integrate.SimulationModel.prepare_tightened`)."""
        self.simulation.prepare_tightened(factor)

    def logged_ahead(self, factor: float | None = None) -> bool:
        """On shared steps: True when ``tightened(factor)`` takes the sequence its reference
        block logs ahead (see :meth:`fuzzymbs.mbs.integrate.SimulationModel.logged_ahead`)."""
        return self.simulation.logged_ahead(factor)

    @property
    def differentiable(self) -> tuple[str, ...]:
        """The parameters ``brake(samples, wrt=names)`` gives the outputs' derivatives for:
        all six with a Rosenbrock integrator (each is a column of the kernel's parameter
        rows, the disc speed through the prescribed rotation), none with RK4."""
        return self.simulation.differentiable

    @property
    def gradient_cost(self) -> float:
        """CPU of a run per parameter differentiated, as a fraction of the run without
        (:attr:`fuzzymbs.mbs.integrate.SimulationModel.gradient_cost`): with three fuzzy
        parameters a run with gradients costs about 3.2 runs, more than the runs they save,
        so a study's ``gradients = "auto"`` runs the brake without them."""
        return self.simulation.gradient_cost

    def deviations(
        self, samples: Mapping[str, Any], wrt: Sequence[str] | None = None
    ) -> dict[str, NDArray]:
        """On shared steps: each sample's outputs minus the modal sample's on the same
        steps (no reference run needed; see
        :meth:`fuzzymbs.mbs.integrate.SimulationModel.deviations`)."""
        return self.simulation.deviations(check_samples(samples), wrt)

    def run_ahead(
        self,
        samples: Mapping[str, Any],
        then: Callable[[], Any] | None = None,
        wrt: Sequence[str] | None = None,
    ) -> None:
        """On shared steps: run ``samples`` in the background and keep them for a later
        call (see :meth:`fuzzymbs.mbs.integrate.SimulationModel.run_ahead`)."""
        self.simulation.run_ahead(check_samples(samples), then, wrt)

    @property
    def shares_steps(self) -> bool:
        """True after :meth:`share_steps`."""
        return self.simulation.shares_steps

    def predicted_reference_error(self, tighter: DiscBrake) -> dict[str, NDArray] | None:
        """On shared steps: the reference's error predicted before it has run (see
        :meth:`fuzzymbs.mbs.integrate.SimulationModel.predicted_reference_error`)."""
        return self.simulation.predicted_reference_error(tighter.simulation)

    @property
    def reference_error(self) -> dict[str, NDArray[np.float64]] | None:
        """With shared steps, the estimated error of the correcting reference per output."""
        return self.simulation.reference_error

    def share_steps(self, modal: Mapping[str, Any]) -> DiscBrake:
        """The same brake with every sample on the step sequence of the ``modal`` sample and
        that sample's integration error removed from every output (ROS34PW2;
        :mod:`fuzzymbs.mbs.shared_steps`): errors smooth across the parameters, so that
        bands as narrow as a +-1 % parameter's settle at a far looser rtol."""
        shared = copy.copy(self)
        columns = {name: np.atleast_1d(value)[:1] for name, value in modal.items()}
        single = {name: float(value[0]) for name, value in check_samples(columns).items()}
        shared.simulation = self.simulation.share_steps(single)
        return shared

    def own_steps(self) -> DiscBrake:
        """The same brake with each sample on its own step sequence again (undoes
        :meth:`share_steps`): a model whose errors are independent of the study's, for
        checking its bands (:func:`fuzzymbs.study.band_check.independent_model`)."""
        own = copy.copy(self)
        own.simulation = copy.copy(self.simulation)  # a copy drops runs kept or prepared
        own.simulation.shared = None
        return own

    def __call__(
        self, samples: Mapping[str, Any], wrt: Sequence[str] | None = None
    ) -> dict[str, NDArray]:
        """Integrate a batch of samples; failed samples are NaN rows flagged in ``failed``.

        With ``wrt`` (names of :attr:`differentiable`) the result also holds
        ``"gradients": {output: (B, T, len(wrt))}``, the outputs' derivatives with respect
        to those parameters in that order [m per the parameter's unit; m/s for the
        velocities], from forward sensitivities integrated with the run (docs/brake.md,
        "Derivatives of the outputs"); the outputs themselves are bit for bit the same.
        """
        return self.simulation(check_samples(samples), wrt)

    def step_stability(
        self, samples: Mapping[str, Any] | None = None, dt: float | None = None
    ) -> StepStability:
        """Is the RK4 step stable for the brake linearised at steady sliding?

        See :func:`fuzzymbs.mbs.step_stability.rk4_step_stability`. ``dt``
        defaults to the model's step. At the paper's 1 us it is not: the
        friction-damped pad modes (real eigenvalues near -8.9e6 1/s at 1 rad/s)
        need ``dt`` below about 0.31 us (docs/brake.md, "Accuracy of the time
        integration").
        """
        step = self.simulation.settings["dt"] if dt is None else dt
        return rk4_step_stability(self.compiled, check_samples(samples or {}), dt=step)
