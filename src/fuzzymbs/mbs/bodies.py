"""Motion types of a reduced elastic body in the floating frame of reference.

A body couples a :class:`~fuzzymbs.mbs.modal_body.ModalBody` (what deforms) with
how its reference frame moves (what the frame does):

* :class:`FixedBody` -- frame fixed in space; elastic coordinates q only.
* :class:`TranslatingBody` -- frame free to translate along one or more axes
  (generalised coordinates s), no rotation; mass matrix
  ``[[m P^T P, P^T C_t], [C_t^T P, I]]``.
* :class:`RotatingBody` -- frame rotating about a fixed axis at a prescribed
  speed ``Omega(t) = speed * profile(t)``; gyroscopic, centrifugal and Euler
  terms act on q (see docs/embs.md for the derivation and signs).

A rigid body is the zero-mode case of each. Node positions in the inertial frame:
``x_k = origin + P s + xbar_k + Psi_k q`` (translating) and
``x_k = origin + A(theta) (xbar_k + Psi_k q)`` (rotating).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.modal_body import ModalBody, StressStiffening
from fuzzymbs.mbs.parameters import Scalar
from fuzzymbs.mbs.profiles import TimeProfile

_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def unit_vector(value: ArrayLike | str, what: str) -> NDArray[np.float64]:
    """A unit 3-vector from ``"x"``/``"-y"``/... or components (normalised)."""
    if isinstance(value, str):
        sign = -1.0 if value.startswith("-") else 1.0
        name = value.lstrip("+-")
        if name not in _AXES:
            raise InvalidParameterError(
                f"{what}: axis name must be 'x', 'y', 'z' (optionally signed, '-y'), got {value!r}"
            )
        return sign * np.array(_AXES[name])
    v = np.asarray(value, dtype=float).reshape(-1)
    if v.shape != (3,) or not np.isfinite(v).all() or np.linalg.norm(v) == 0:
        raise InvalidParameterError(f"{what}: need a non-zero finite 3-vector, got {value!r}")
    return v / np.linalg.norm(v)


def _damping_ratios(modal: ModalBody, ratio: float | ArrayLike) -> NDArray[np.float64]:
    z = np.broadcast_to(np.asarray(ratio, dtype=float), (modal.n_modes,)).copy()
    if not np.isfinite(z).all() or np.any(z < 0):
        raise InvalidParameterError(
            f"body {modal.name!r}: modal damping ratios must be finite and >= 0, got {ratio!r}"
        )
    return z


def _origin(value: ArrayLike, name: str) -> NDArray[np.float64]:
    o = np.asarray(value, dtype=float).reshape(-1)
    if o.shape != (3,) or not np.isfinite(o).all():
        raise InvalidParameterError(f"body {name!r}: origin must be a finite 3-vector, got {value}")
    return o


@dataclass(frozen=True, eq=False)
class _Body:
    modal: ModalBody
    name: str
    origin: NDArray[np.float64]
    damping_ratio: NDArray[np.float64] = field(repr=False)

    def __init__(
        self,
        modal: ModalBody,
        *,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        damping_ratio: float | ArrayLike = 0.0,
        name: str | None = None,
    ) -> None:
        """What every motion type holds: the reduced body, its name (default the modal
        body's), the frame's origin and the modal damping ratios, checked."""
        name = name or modal.name
        object.__setattr__(self, "modal", modal)
        object.__setattr__(self, "name", name)
        object.__setattr__(self, "origin", _origin(origin, name))
        object.__setattr__(self, "damping_ratio", _damping_ratios(modal, damping_ratio))

    @property
    def n_translations(self) -> int:
        return 0

    @property
    def n_dofs(self) -> int:
        """Number of generalised coordinates (translations, then modes)."""
        return self.n_translations + self.modal.n_modes


class FixedBody(_Body):
    """An elastic body whose frame is fixed in space.

    Parameters
    ----------
    modal : ModalBody
        Reduced body (may have zero modes: then it is rigid ground with attachment nodes).
    origin : array_like, shape (3,)
        Position of the body frame [m].
    damping_ratio : float or array_like, shape (r,)
        Modal damping ratio zeta per mode [-] (``D = diag(2 zeta omega)``).
    name : str, optional
        Defaults to ``modal.name``.
    """


class TranslatingBody(_Body):
    """An elastic body whose frame translates freely along ``axes`` (no rotation).

    Parameters
    ----------
    modal : ModalBody
        Reduced body; ``modal.translation_coupling`` (C_t) enters the mass matrix.
    axes : sequence of axis names or 3-vectors
        Directions of the translation coordinates s (e.g. ``["y"]``); orthogonal
        not required but independent.
    origin, damping_ratio, name
        As for :class:`FixedBody`.
    """

    axes: NDArray[np.float64]

    def __init__(
        self,
        modal: ModalBody,
        axes: list[ArrayLike | str] | tuple[ArrayLike | str, ...] = ("y",),
        *,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        damping_ratio: float | ArrayLike = 0.0,
        name: str | None = None,
    ) -> None:
        super().__init__(modal, origin=origin, damping_ratio=damping_ratio, name=name)
        nm = self.name
        if isinstance(axes, str):
            axes = [axes]
        p = np.array([unit_vector(a, f"body {nm!r} translation axis") for a in axes])
        if p.shape[0] == 0 or p.shape[0] > 3 or np.linalg.matrix_rank(p) < p.shape[0]:
            raise InvalidParameterError(
                f"body {nm!r}: need 1 to 3 independent translation axes, got {axes!r}"
            )
        object.__setattr__(self, "axes", p)  # (na, 3): row a is axis a

    @property
    def n_translations(self) -> int:
        return int(self.axes.shape[0])


class RotatingBody(_Body):
    """An elastic body rotating about a fixed axis at a prescribed speed.

    The rotation angle is ``theta(t) = speed * int_0^t profile``; the speed
    ``Omega(t) = speed * profile(t)`` [rad/s].

    Parameters
    ----------
    modal : ModalBody
        Reduced body; uses ``gyroscopic``, ``centrifugal``, ``centrifugal_load``
        and ``rotation_coupling`` (for the Euler term when the speed varies).
    axis : axis name or 3-vector
        Rotation axis e through ``origin`` (right-hand rule).
    speed : float or Parameter
        Speed scale [rad/s] (bindable to a sample column).
    profile : TimeProfile, optional
        Dimensionless speed history (default constant 1).
    origin, damping_ratio, name
        As for :class:`FixedBody`; the axis passes through ``origin``.
    stiffening : StressStiffening, optional
        The spin's stress stiffening (its ``spin`` part K_ij is used); default the
        modal body's own (``ModalBody.stress_stiffening``), if computed.
    """

    axis: NDArray[np.float64]
    speed: Scalar
    profile: TimeProfile
    stiffening: StressStiffening | None

    def __init__(
        self,
        modal: ModalBody,
        axis: ArrayLike | str = "y",
        speed: Scalar = 0.0,
        *,
        profile: TimeProfile | None = None,
        origin: ArrayLike = (0.0, 0.0, 0.0),
        damping_ratio: float | ArrayLike = 0.0,
        name: str | None = None,
        stiffening: StressStiffening | None = None,
    ) -> None:
        super().__init__(modal, origin=origin, damping_ratio=damping_ratio, name=name)
        nm = self.name
        object.__setattr__(self, "axis", unit_vector(axis, f"body {nm!r} rotation axis"))
        object.__setattr__(self, "speed", speed)
        object.__setattr__(self, "profile", profile or TimeProfile.constant())
        if stiffening is None:
            stiffening = modal.stress_stiffening
        object.__setattr__(self, "stiffening", stiffening)

    def rotated_matrices(self) -> dict[str, NDArray[np.float64]]:
        """G_e, C_e and the loads for the rotation axis e (from the SID integrals).

        ``G = sum_i e_i G_i``, ``C = sum_ij e_i e_j (C_ij + K_ij)`` (K_ij the body's
        ``stiffening``, if any: the centrifugal prestress),
        ``c = sum_ij e_i e_j c_ij`` (``Psi^T M E E xbar``) and
        ``g = C_r^T e`` (``Psi^T M E xbar``, the Euler load).
        """
        e = self.axis
        m = self.modal
        centrifugal = np.einsum("i,j,ijkl->kl", e, e, m.centrifugal)
        if self.stiffening is not None:  # the prestress of the same spin: Omega^2 K_e
            centrifugal = centrifugal + np.einsum("i,j,ijkl->kl", e, e, self.stiffening.spin)
        return {
            "gyroscopic": np.einsum("i,ijk->jk", e, m.gyroscopic),
            "centrifugal": centrifugal,
            "centrifugal_load": np.einsum("i,j,ijk->k", e, e, m.centrifugal_load),
            "euler_load": m.rotation_coupling.T @ e,
        }


def rotation_matrix(axis: NDArray[np.float64], angle: float) -> NDArray[np.float64]:
    """Rodrigues: rotation by ``angle`` [rad] about unit ``axis``."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


Body = FixedBody | TranslatingBody | RotatingBody


def node_row(body: Body, node: int, direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """d . u_node as a row over the body's coordinates: [d . P_a, d . Psi_k]."""
    parts = []
    if isinstance(body, TranslatingBody):
        parts.append(body.axes @ direction)
    parts.append(direction @ body.modal.mode_shapes[node])
    return np.concatenate(parts)
