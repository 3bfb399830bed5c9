"""Free vibration of a viscously damped single-degree-of-freedom oscillator (closed form).

Equation of motion ``mass * x'' + damping * x' + stiffness * x = 0`` with
``x(0) = initial_displacement`` and ``x'(0) = 0``. With the undamped natural
angular frequency ``omega = sqrt(stiffness / mass)`` [rad/s] and damping ratio
``zeta = damping / (2 sqrt(stiffness * mass))`` the solution is (any textbook on
vibrations, e.g. Rao, Mechanical Vibrations, sec. 2.6)::

    zeta < 1:  x = x0 exp(-zeta omega t) (cos(wd t) + zeta omega / wd sin(wd t)),
               wd = omega sqrt(1 - zeta^2)
    zeta = 1:  x = x0 exp(-omega t) (1 + omega t)
    zeta > 1:  x = x0 exp(-zeta omega t) (cosh(wh t) + zeta omega / wh sinh(wh t)),
               wh = omega sqrt(zeta^2 - 1)

The model is a demo of fuzzy *time signals*: its displacement has a time axis
(``coords = {"time": t}``, ``coord_units = {"time": "s"}``), its natural
frequency is a scalar output (``output_dims``), and ``reference`` holds an
independent numerical solution (SciPy ``solve_ivp``) at the default parameters
that the plots draw on top.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from fuzzymbs.errors import InvalidParameterError

#: Default parameters (SI): a 1 kg mass on a 1 kN/m spring, zeta = 0.05.
DEFAULT_MASS = 1.0
DEFAULT_STIFFNESS = 1000.0
DEFAULT_DAMPING = 2.0 * 0.05 * np.sqrt(DEFAULT_STIFFNESS * DEFAULT_MASS)


def free_response(
    time: np.ndarray,
    mass: np.ndarray,
    stiffness: np.ndarray,
    damping: np.ndarray,
    initial_displacement: float,
) -> np.ndarray:
    """Closed-form free response x(t) [m] for a batch of oscillators.

    Parameters
    ----------
    time : (T,) ndarray
        Time points [s].
    mass, stiffness, damping : (B,) ndarray
        Mass [kg], stiffness [N/m] and viscous damping coefficient [N s/m], all > 0
        (damping >= 0).
    initial_displacement : float
        x(0) [m]; the initial velocity is zero.

    Returns
    -------
    (B, T) ndarray
        Displacement [m].
    """
    omega = np.sqrt(stiffness / mass)[:, None]
    zeta = (damping / (2.0 * np.sqrt(stiffness * mass)))[:, None]
    t = np.asarray(time, dtype=float)[None, :]
    gap = 1.0 - zeta**2
    under = np.broadcast_to(gap > 1e-12, (omega.shape[0], t.shape[1]))
    over = np.broadcast_to(gap < -1e-12, under.shape)
    # Each regime is evaluated with a safe sqrt argument and selected by mask afterwards.
    wd = omega * np.sqrt(np.where(gap > 1e-12, gap, 1.0))
    under_shape = np.exp(-zeta * omega * t) * (np.cos(wd * t) + zeta * omega / wd * np.sin(wd * t))
    # Over-damped: written as two decaying exponentials so cosh/sinh cannot overflow.
    wh = omega * np.sqrt(np.where(gap < -1e-12, -gap, 1.0))
    ratio = zeta * omega / wh
    over_shape = 0.5 * (
        (1.0 + ratio) * np.exp((wh - zeta * omega) * t)
        + (1.0 - ratio) * np.exp(-(wh + zeta * omega) * t)
    )
    critical_shape = np.exp(-omega * t) * (1.0 + omega * t)
    shape = np.where(under, under_shape, np.where(over, over_shape, critical_shape))
    return initial_displacement * shape


class DampedOscillator:
    """Batched closed-form damped oscillator (see module docstring).

    Parameters
    ----------
    duration : float
        Simulated time span [s].
    time_steps : int
        Number of output time points (including t = 0).
    initial_displacement : float
        x(0) [m].

    Outputs
    -------
    displacement : (B, T) ndarray
        x(t) [m] on ``coords["time"]``.
    natural_frequency : (B,) ndarray
        Undamped natural frequency f = omega / (2 pi) [Hz].

    Samples with mass <= 0, stiffness <= 0 or damping < 0 are flagged in the
    ``failed`` output with a ``failure_reason`` (their rows are NaN).
    """

    def __init__(
        self, duration: float = 1.0, time_steps: int = 401, initial_displacement: float = 0.01
    ) -> None:
        if (
            isinstance(duration, bool)
            or not isinstance(duration, int | float)
            or not (0.0 < duration < np.inf)
        ):
            raise InvalidParameterError(
                f"duration must be a finite number > 0 [s], got {duration!r}"
            )
        if (
            isinstance(time_steps, bool)
            or not isinstance(time_steps, int | np.integer)
            or (time_steps < 2)
        ):
            raise InvalidParameterError(f"time_steps must be an integer >= 2, got {time_steps!r}")
        if (
            isinstance(initial_displacement, bool)
            or not isinstance(initial_displacement, int | float)
            or not np.isfinite(initial_displacement)
        ):
            raise InvalidParameterError(
                f"initial_displacement must be a finite number [m], got {initial_displacement!r}"
            )
        self.duration = float(duration)
        self.time_steps = int(time_steps)
        self.initial_displacement = float(initial_displacement)
        self.coords = {"time": np.linspace(0.0, self.duration, self.time_steps)}
        self.coord_units = {"time": "s"}
        self.output_dims = {"displacement": ("time",), "natural_frequency": ()}
        self.reference = {"displacement": self._numerical_reference()}
        self.reference_labels = {"displacement": "solve_ivp at the default parameters"}

    def identity(self) -> dict[str, float]:
        """The settings that change the outputs (part of a result store's identity)."""
        return {
            "duration": self.duration,
            "time_steps": self.time_steps,
            "initial_displacement": self.initial_displacement,
        }

    def _numerical_reference(self) -> np.ndarray:
        """x(t) at the default parameters by numerical integration (independent of the formula)."""
        from scipy.integrate import solve_ivp

        def rhs(_t: float, state: np.ndarray) -> list[float]:
            x, v = state
            return [v, -(DEFAULT_DAMPING * v + DEFAULT_STIFFNESS * x) / DEFAULT_MASS]

        t = self.coords["time"]
        solution = solve_ivp(
            rhs,
            (0.0, self.duration),
            [self.initial_displacement, 0.0],
            t_eval=t,
            rtol=1e-10,
            atol=1e-14 * max(abs(self.initial_displacement), 1.0),
            method="DOP853",
        )
        return solution.y[0]

    def __call__(self, samples: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Free response of a batch of oscillators.

        Parameters
        ----------
        samples : mapping
            ``mass`` [kg], ``stiffness`` [N/m], ``damping`` [N s/m], each (B,).

        Returns
        -------
        dict
            ``displacement`` (B, T) [m] over ``coords["time"]``, ``natural_frequency``
            (B,) [Hz], and ``failed`` / ``failure_reason`` (B,) for non-physical samples
            (mass or stiffness <= 0, damping < 0).
        """
        mass = np.asarray(samples["mass"], dtype=float)
        stiffness = np.asarray(samples["stiffness"], dtype=float)
        damping = np.asarray(samples["damping"], dtype=float)
        reasons = np.full(mass.shape, "", dtype=object)
        reasons[damping < 0] = "damping < 0 N s/m"
        reasons[stiffness <= 0] = "stiffness <= 0 N/m"
        reasons[mass <= 0] = "mass <= 0 kg"
        failed = reasons != ""
        ok = ~failed
        displacement = np.full((mass.size, self.time_steps), np.nan)
        frequency = np.full(mass.shape, np.nan)
        if ok.any():
            displacement[ok] = free_response(
                self.coords["time"],
                mass[ok],
                stiffness[ok],
                damping[ok],
                self.initial_displacement,
            )
            frequency[ok] = np.sqrt(stiffness[ok] / mass[ok]) / (2.0 * np.pi)
        return {
            "displacement": displacement,
            "natural_frequency": frequency,
            "failed": failed,
            "failure_reason": reasons.astype(str),
        }


def make_damped_oscillator(
    duration: float = 1.0, time_steps: int = 401, initial_displacement: float = 0.01
) -> DampedOscillator:
    """Factory registered as ``"damped-oscillator"``."""
    return DampedOscillator(duration, time_steps, initial_displacement)
