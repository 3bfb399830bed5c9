"""The FE reference of the gear pair: loaded tooth contact analysis, batched.

``GearPairFE(pair, ...)`` meets the study-model interface like
:class:`~fuzzymbs.models.gears.model.MubocoPR` and returns the same ``ste`` over
``position`` (plus each tooth pair's load share): both whole gears are meshed in
2D from the package's generated profiles (:mod:`.fe_mesh`), their flank
compliances come from quadratic-triangle FE models (:mod:`.fe_compliance`,
cached on disk), and each mesh position is a contact problem with
non-penetration and no tension (:mod:`.fe_contact`, the reference; the batch runs
in its compiled twin :mod:`.fe_contact_kernel`).

Sample parameters: ``youngs_modulus`` (scales the cached tables by 1/E, no new
factorisation), ``poisson_ratio`` (a new table per distinct value, computed once
and cached), ``torque``, ``center_distance_deviation`` and ``tip_relief`` (the
initial gaps of :func:`~fuzzymbs.models.gears.flank_contact.pair_contact`, as in
``gear-pair``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.models.gears.fe_compliance import (
    ANALYSES,
    SUPPORTS,
    FlankCompliance,
    MeshOptions,
    flank_compliance,
)
from fuzzymbs.models.gears.fe_contact import ContactSettings, solve_position
from fuzzymbs.models.gears.fe_contact_kernel import solve_batch
from fuzzymbs.models.gears.flank_contact import (
    GEOMETRY_SIZE,
    GEOMETRY_TEXT,
    RB1,
    hpstc_radii,
    pack_geometry,
    sample_geometry,
)
from fuzzymbs.models.gears.geometry import GearPair
from fuzzymbs.models.gears.model import mesh_positions
from fuzzymbs.models.gears.muboco import pair_indices

__all__ = ["FE_SAMPLE_PARAMETERS", "GearPairFE", "gear_pair_fe_model"]

#: Sample parameters of the FE model (anything else is rejected).
FE_SAMPLE_PARAMETERS = (
    "youngs_modulus",
    "poisson_ratio",
    "torque",
    "center_distance_deviation",
    "tip_relief",
)
#: Columns whose registered default is NaN, "not set": all NaN means the model's value.
UNSET_BY_NAN = ("youngs_modulus", "poisson_ratio", "torque")
NOT_CONVERGED, NO_CONTACT = 1, 2
STATUS_TEXT = {
    NOT_CONVERGED: "contact iteration did not converge",
    NO_CONTACT: "no tooth pair in contact (cannot carry the torque)",
    **GEOMETRY_TEXT,
}


class GearPairFE:
    """Finite-element loaded tooth contact analysis of a spur-gear pair (batched).

    Parameters
    ----------
    pair : GearPair
        The gears (both of one material: the pinion's E and nu are the defaults).
    torque : float
        Pinion torque T1 [N m] when a sample carries none.
    positions : int or array
        Mesh positions over one mesh period (count or fractions in [0, 1)).
    analysis : {"plane-strain", "plane-stress"}
        Plane analysis of the gear bodies and the local flattening (default plane
        strain: docs/gears.md, "FE reference").
    support : {"clamped", "tangential"}
        Bore boundary condition (default clamped: a shaft bonded to the bore).
    mesh : MeshOptions or mapping, optional
        Discretisation (multiples of the module); default :class:`MeshOptions`.
    edge_radius : float, optional
        Rounding radius of the tip corners in corner contact [m] (default 0.05 m_n).
    pinion_relief_start_diameter, wheel_relief_start_diameter : float, optional
        Where the linear tip relief starts [m] (default HPSTC, as ``gear-pair``).
    cache : bool
        Use the disk cache of flank compliances.

    Notes
    -----
    ``model(samples)`` returns ``ste`` (B, P) [m] (pinion lead r_b1 phi, as
    ``gear-pair``), ``load_share`` (B, P, K) (force of tooth pair k / total, pairs
    ``coords["pair"]``; pair k starts contact at position -k), ``failed`` and
    ``failure_reason``.
    """

    def __init__(
        self,
        pair: GearPair,
        torque: float = 100.0,
        positions: int | Sequence[float] | np.ndarray = 60,
        analysis: str = "plane-strain",
        support: str = "clamped",
        mesh: MeshOptions | Mapping[str, Any] | None = None,
        edge_radius: float | None = None,
        pinion_relief_start_diameter: float | None = None,
        wheel_relief_start_diameter: float | None = None,
        cache: bool = True,
    ) -> None:
        if not isinstance(pair, GearPair):
            raise InvalidParameterError("pair must be a GearPair")
        torque = float(torque)
        if not math.isfinite(torque) or torque <= 0.0:
            raise InvalidParameterError(f"torque must be a positive pinion torque, got {torque!r}")
        if analysis not in ANALYSES:
            raise InvalidParameterError(f"analysis must be one of {ANALYSES}, got {analysis!r}")
        if support not in SUPPORTS:
            raise InvalidParameterError(f"support must be one of {SUPPORTS}, got {support!r}")
        if mesh is None:
            mesh = MeshOptions()
        elif isinstance(mesh, Mapping):
            allowed = [f.name for f in dataclasses.fields(MeshOptions)]
            unknown = sorted(set(mesh) - set(allowed))
            if unknown:
                raise InvalidParameterError(
                    f"unknown mesh option(s) {unknown}; options: {', '.join(allowed)}"
                )
            mesh = MeshOptions(**mesh)
        p, w = pair.pinion, pair.wheel
        if (p.youngs_modulus, p.poisson_ratio) != (w.youngs_modulus, w.poisson_ratio):
            raise InvalidParameterError("pinion and wheel must be of one material (E, nu)")
        edge = 0.05 * p.module if edge_radius is None else float(edge_radius)
        if not math.isfinite(edge) or edge <= 0.0:
            raise InvalidParameterError(f"edge_radius must be positive [m], got {edge_radius!r}")
        self.pair = pair
        self.torque = torque
        self.positions = mesh_positions(positions)
        self.analysis = analysis
        self.support = support
        self.mesh = mesh
        self.edge_radius = edge
        self.cache = bool(cache)
        given = (pinion_relief_start_diameter, wheel_relief_start_diameter)
        starts = tuple(
            default if d is None else 0.5 * float(d)
            for default, d in zip(hpstc_radii(pair), given, strict=True)
        )
        self.relief_start_diameters = (2.0 * starts[0], 2.0 * starts[1])
        self.geometry = pack_geometry(pair, starts)
        # every valid sample has a_w >= the zero-backlash distance: its contact ratio bounds K
        tight = dataclasses.replace(pair, center_distance=pair.zero_backlash_center_distance)
        self.pairs = pair_indices(pair, tight.contact_ratio)
        self.defaults = {
            "youngs_modulus": p.youngs_modulus,
            "poisson_ratio": p.poisson_ratio,
            "torque": torque,
            "center_distance_deviation": 0.0,
            "tip_relief": 0.0,
        }
        self.coords = {"position": self.positions, "pair": self.pairs.astype(float)}
        self.output_dims = {"ste": ("position",), "load_share": ("position", "pair")}
        self._tables: dict[float, tuple[FlankCompliance, FlankCompliance]] = {}

    # ---- compliance tables ---------------------------------------------------------------
    def tables(self, poisson_ratio: float | None = None) -> tuple[FlankCompliance, FlankCompliance]:
        """Flank compliances (E = 1 Pa) of pinion and wheel at Poisson's ratio ``nu``."""
        nu = self.defaults["poisson_ratio"] if poisson_ratio is None else float(poisson_ratio)
        if nu not in self._tables:
            gears = (
                dataclasses.replace(gear, poisson_ratio=nu)
                for gear in (self.pair.pinion, self.pair.wheel)
            )
            self._tables[nu] = tuple(
                flank_compliance(gear, self.mesh, self.analysis, self.support, cache=self.cache)
                for gear in gears
            )  # type: ignore[assignment]
        return self._tables[nu]

    def __getstate__(self) -> dict[str, Any]:
        # the tables travel as the disk cache: a model stays cheap to send to a worker
        state = dict(self.__dict__)
        state["_tables"] = {}
        return state

    def identity(self) -> str:
        """SHA-256 digest of every setting that changes the outputs (for result stores)."""
        settings = (
            repr(self.pair),
            self.torque,
            self.analysis,
            self.support,
            repr(self.mesh),
            self.edge_radius,
            self.relief_start_diameters,
        )
        digest = hashlib.sha256(repr(settings).encode())
        digest.update(np.ascontiguousarray(self.positions, dtype="<f8").tobytes())
        return digest.hexdigest()

    # ---- samples -------------------------------------------------------------------------
    def columns(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Per-sample parameter columns with the defaults filled in, checked."""
        unknown = set(samples) - set(FE_SAMPLE_PARAMETERS)
        if unknown:
            raise InvalidParameterError(
                f"unknown gear-pair-fe parameter(s) {sorted(unknown)}; "
                f"valid: {list(FE_SAMPLE_PARAMETERS)}"
            )
        sizes = {np.size(v) for v in samples.values() if np.ndim(v) == 1}
        if len(sizes) > 1:
            raise InvalidParameterError("all sample columns must have the same length")
        size = sizes.pop() if sizes else 1
        out = {}
        for name in FE_SAMPLE_PARAMETERS:
            value = samples.get(name)
            column = np.full(size, self.defaults[name]) if value is None else value
            column = np.broadcast_to(np.asarray(column, dtype=float), (size,)).copy()
            if name in UNSET_BY_NAN and np.isnan(column).all():
                column[:] = self.defaults[name]
            finite = np.isfinite(column)
            if name in ("youngs_modulus", "torque"):
                ok = finite & (column > 0.0)
                valid = "finite and positive"
            elif name == "poisson_ratio":
                ok = finite & (column > -0.5) & (column < 0.5)
                valid = "in (-0.5, 0.5)"
            elif name == "tip_relief":
                ok = finite & (column >= 0.0)
                valid = "finite and >= 0 [m]"
            else:
                ok = finite
                valid = "finite [m]"
            if not np.all(ok):
                raise InvalidParameterError(f"{name} must be {valid}, got {column[~ok][:3]!r}")
            out[name] = column
        return out

    def solve(self, samples: Mapping[str, Any], compiled: bool = True) -> dict[str, np.ndarray]:
        """STE, pair forces and contact kinds of a batch.

        Parameters
        ----------
        samples : mapping of str to (B,) array
            As for ``__call__``.
        compiled : bool
            Use the compiled batch kernel (:mod:`.fe_contact_kernel`, parallel over
            the samples); False runs the Python reference
            (:func:`.fe_contact.solve_position`) sample by sample.

        Returns
        -------
        dict
            ``ste`` (B, P) [m]; ``pair_force`` (B, P, K) [N]; ``pair_kind`` (B, P, K)
            (0 none, 1 conjugate, 2 pinion tip corner, 3 wheel tip corner);
            ``status`` (B,) (0 ok, else a key of ``STATUS_TEXT``).
        """
        cols = self.columns(samples)
        n_samples = cols["torque"].size
        n_pos, n_pairs = self.positions.size, self.pairs.size
        ste = np.full((n_samples, n_pos), np.nan)
        force = np.zeros((n_samples, n_pos, n_pairs))
        kind = np.zeros((n_samples, n_pos, n_pairs), dtype=np.int8)
        status = np.zeros(n_samples, dtype=np.int64)
        geometry = np.empty((n_samples, GEOMETRY_SIZE))
        for b in range(n_samples):
            status[b] = sample_geometry(
                self.geometry,
                cols["center_distance_deviation"][b],
                cols["tip_relief"][b],
                geometry[b],
            )
        # one set of tables per Poisson's ratio: the samples that share it form one batch
        for nu in np.unique(cols["poisson_ratio"]):
            group = np.flatnonzero((cols["poisson_ratio"] == nu) & (status == 0))
            if group.size == 0:
                continue
            pinion, wheel = self.tables(float(nu))
            if compiled:
                result = solve_batch(
                    geometry[group], status[group], self.positions, self.pairs,
                    cols["torque"][group], cols["youngs_modulus"][group], float(nu),
                    self.pair.pinion.face_width, self.edge_radius,
                    self.analysis == "plane-strain",
                    pinion.grid_roll, pinion.surface, pinion.reference, pinion.reference_depth,
                    wheel.grid_roll, wheel.surface, wheel.reference, wheel.reference_depth,
                )  # fmt: skip
                ste[group], force[group], kind[group], status[group] = result
                continue
            for b in group:
                settings = ContactSettings(
                    pinion=pinion,
                    wheel=wheel,
                    youngs_modulus=float(cols["youngs_modulus"][b]),
                    poisson_ratio=float(nu),
                    face_width=self.pair.pinion.face_width,
                    edge_radius=self.edge_radius,
                    analysis=self.analysis,
                )
                lag = 0.0
                for j, position in enumerate(self.positions):
                    lag, force[b, j], kind[b, j], flag = solve_position(
                        float(position), geometry[b], self.pairs, float(cols["torque"][b]),
                        settings, lag,
                    )  # fmt: skip
                    if flag != 0:
                        status[b] = flag
                        break
                    ste[b, j] = geometry[b, RB1] * lag
                if status[b] != 0:
                    ste[b] = np.nan
        return {"ste": ste, "pair_force": force, "pair_kind": kind, "status": status}

    def __call__(self, samples: Mapping[str, Any]) -> dict[str, np.ndarray]:
        """Evaluate a batch (the study-model interface).

        Parameters
        ----------
        samples : mapping of str to (B,) array
            Any of ``youngs_modulus`` [Pa], ``poisson_ratio``, ``torque`` [N m],
            ``center_distance_deviation`` [m], ``tip_relief`` [m].

        Returns
        -------
        dict
            ``ste`` (B, P) [m], ``load_share`` (B, P, K), ``failed`` (B,),
            ``failure_reason`` (B,).
        """
        result = self.solve(samples)
        total = result["pair_force"].sum(axis=2, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            share = np.where(total > 0.0, result["pair_force"] / total, np.nan)
        failed = result["status"] != 0
        share[failed] = np.nan
        reasons = np.array([STATUS_TEXT.get(int(s), "") for s in result["status"]], dtype=str)
        return {"ste": result["ste"], "load_share": share, "failed": failed,
                "failure_reason": reasons}  # fmt: skip


def gear_pair_fe_model(
    torque: float = 100.0,
    positions: int = 60,
    analysis: str = "plane-strain",
    support: str = "clamped",
    mesh: Mapping[str, Any] | None = None,
    edge_radius: float | None = None,
    pinion_relief_start_diameter: float | None = None,
    wheel_relief_start_diameter: float | None = None,
    **gear_options: Any,
) -> GearPairFE:
    """Factory of the registered ``"gear-pair-fe"`` model (gear data as for ``gear-pair``)."""
    from fuzzymbs.models.gears import DEFAULT_PAIR_OPTIONS, make_pair

    unknown = set(gear_options) - set(DEFAULT_PAIR_OPTIONS)
    if unknown:
        raise InvalidParameterError(
            f"unknown gear-pair-fe option(s) {sorted(unknown)}; gear data: "
            f"{sorted(DEFAULT_PAIR_OPTIONS)}; model: torque, positions, analysis, support, "
            "mesh, edge_radius, pinion_relief_start_diameter, wheel_relief_start_diameter"
        )
    pair = make_pair(**{**DEFAULT_PAIR_OPTIONS, **gear_options})
    model = GearPairFE(
        pair,
        torque=torque,
        positions=positions,
        analysis=analysis,
        support=support,
        mesh=mesh,
        edge_radius=edge_radius,
        pinion_relief_start_diameter=pinion_relief_start_diameter,
        wheel_relief_start_diameter=wheel_relief_start_diameter,
    )
    # fill the disk cache before a study sends the model to its workers, which read it
    model.tables()
    return model
