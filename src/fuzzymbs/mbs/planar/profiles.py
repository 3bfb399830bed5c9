"""Motion and load profiles of time: the prescribed angle of a drive, a force history.

Each profile gives f(t) and its first two derivatives (a driving constraint
needs the acceleration f''). The kernels evaluate them by code
(:func:`fuzzymbs.mbs.planar.kernels.profile`); the classes here hold the
numbers and say which code they are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fuzzymbs.errors import InvalidParameterError
from fuzzymbs.mbs.parameters import Parameter, Scalar

CONSTANT_RATE = 0
SPIN_UP = 1
HARMONIC = 2


def _finite(owner: str, **values: float) -> None:
    for name, value in values.items():
        if not np.isfinite(value):
            raise InvalidParameterError(f"{owner} {name} must be finite, got {value!r}")


def _numbers_only(what: str, value: Scalar) -> None:
    """The mechanism engines pack numbers: a Parameter is bound only by a System."""
    if isinstance(value, Parameter):
        raise InvalidParameterError(
            f"{what} is Parameter {value.name!r}, which only a System binds; a Mechanism "
            "takes numbers (build one per sample, as MechanismModel does)"
        )


@dataclass(frozen=True)
class ConstantRate:
    """f(t) = start + rate t (a crank at constant speed: rate in rad/s).

    In a :class:`~fuzzymbs.mbs.system.System` (minimal coordinates) ``rate`` may be a
    :class:`~fuzzymbs.mbs.parameters.Parameter`, bound to a sample column; the
    mechanism engines take numbers (``MechanismModel`` builds one mechanism per sample).
    """

    rate: Scalar
    start: float = 0.0
    code = CONSTANT_RATE

    def __post_init__(self) -> None:
        rate = self.rate.default if isinstance(self.rate, Parameter) else self.rate
        _finite("ConstantRate", rate=rate, start=self.start)

    def pack(self) -> list[float]:
        _numbers_only("ConstantRate rate", self.rate)
        return [self.start, self.rate, 0.0, 0.0]


@dataclass(frozen=True)
class SpinUp:
    """Smooth spin-up to ``speed`` in ``duration`` (Kane, Ryan & Banerjee 1987); in a
    :class:`~fuzzymbs.mbs.system.System` ``speed`` may be a Parameter.

    f(t) = (W/T) (t^2/2 + (T/(2 pi))^2 (cos(2 pi t/T) - 1)) for t < T, then
    W (t - T/2): the speed rises from 0 to W with zero acceleration at both ends.
    """

    speed: Scalar
    duration: float
    start: float = 0.0
    code = SPIN_UP

    def __post_init__(self) -> None:
        speed = self.speed.default if isinstance(self.speed, Parameter) else self.speed
        _finite("SpinUp", speed=speed, start=self.start)
        if not (np.isfinite(self.duration) and self.duration > 0):
            raise InvalidParameterError(f"SpinUp duration must be > 0 s, got {self.duration!r}")

    def pack(self) -> list[float]:
        _numbers_only("SpinUp speed", self.speed)
        return [self.start, self.speed, self.duration, 0.0]


@dataclass(frozen=True)
class Harmonic:
    """f(t) = start + amplitude sin(frequency t + phase) (frequency in rad/s)."""

    amplitude: float
    frequency: float
    phase: float = 0.0
    start: float = 0.0
    code = HARMONIC

    def __post_init__(self) -> None:
        _finite(
            "Harmonic",
            amplitude=self.amplitude,
            frequency=self.frequency,
            phase=self.phase,
            start=self.start,
        )

    def pack(self) -> list[float]:
        return [self.start, self.amplitude, self.frequency, self.phase]


Profile = ConstantRate | SpinUp | Harmonic

#: Floats a profile packs (every profile packs this many).
PROFILE_SIZE = 4


def evaluate(profile: Profile, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """f, f', f'' at times ``t`` (NumPy, for checks and plots)."""
    from fuzzymbs.mbs.planar.kernels import profile as kernel_profile

    params = np.asarray(profile.pack(), dtype=float)
    out = np.array([kernel_profile(profile.code, params, 0, float(s)) for s in np.atleast_1d(t)])
    return out[:, 0], out[:, 1], out[:, 2]


class ProfiledLoad:
    """A load times a profile of time: what a force element with a ``profile`` (a
    :data:`Profile`, or None: constant) gives the kernels."""

    @property
    def profile_code(self) -> int:
        """The profile's kernel code, -1 without one."""
        return -1 if self.profile is None else self.profile.code

    def profile_values(self) -> list[float]:
        """The profile's :data:`PROFILE_SIZE` numbers, zeros without one."""
        return self.profile.pack() if self.profile is not None else [0.0] * PROFILE_SIZE
