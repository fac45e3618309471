r"""Manoeuvres: speed profiles and steering patterns, sampled on a time grid.

A :class:`Maneuver` combines a speed pattern (reference speed ``v_ref`` [m/s] and
its derivative ``a_ref`` [m/s²]) with a steering pattern. Every steering
pattern is expressed as a yaw-rate reference ``r_ref`` [rad/s]: patterns given
as a lateral acceleration use ``r_ref = ay_ref / v``, patterns given as a
road-wheel angle use the linear steady-state yaw rate
``r_ref = v delta / (l + K v²)`` (``K`` the understeer gradient). The driver then
steers ``delta = (l + K v²) r_ref / v + k_r (r_ref - r) + k_b vy / vx``: the
linear feed-forward, a yaw-rate feedback (gain :attr:`Maneuver.yaw_gain`) and,
in the lateral model, a counter-steer on the body sideslip
(:attr:`Maneuver.sideslip_gain`), which keep the car controllable when a tire
saturates.

Random patterns draw from the ``numpy.random.Generator`` passed to
:meth:`Maneuver.sample`, so one seed gives one drive.

Path following on closed tracks lives in :mod:`roadgrip.sim.track`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import NDArray

from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "ConstantSpeed",
    "DoubleLaneChange",
    "Maneuver",
    "ManeuverSignals",
    "RandomSpeed",
    "RandomSteer",
    "Schedule",
    "SineSweep",
    "Slalom",
    "SpeedPattern",
    "SpeedPhases",
    "SteeringPattern",
    "StepSteer",
    "Straight",
    "smooth_noise",
]


def smooth_noise(t: NDArray[np.float64], corr_time: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """Unit-variance smooth random signal on a uniform grid ``t`` [s].

    White noise on a coarse grid (spacing ``corr_time / 4``) filtered by a
    Gaussian kernel of standard deviation ``corr_time / 2`` and interpolated
    with cubic-like smoothness (linear interpolation of a smooth signal).
    """
    if corr_time <= 0:
        raise ValueError(f"corr_time must be positive, got {corr_time}")
    t = np.asarray(t, float)
    span = float(t[-1] - t[0]) if t.size > 1 else 0.0
    step = corr_time / 4.0
    n = int(np.ceil(span / step)) + 1
    pad = 12
    w = rng.standard_normal(n + 2 * pad)
    k = np.arange(-pad, pad + 1) * step
    kern = np.exp(-0.5 * (k / (corr_time / 2.0)) ** 2)
    kern /= np.sqrt(np.sum(kern**2))
    coarse = np.convolve(w, kern, mode="same")[pad : pad + n]
    tc = t[0] + np.arange(n) * step
    return np.interp(t, tc, coarse)


class ManeuverSignals(NamedTuple):
    """Driver references on a time grid, each shape (n,)."""

    v_ref: NDArray[np.float64]
    a_ref: NDArray[np.float64]
    r_ref: NDArray[np.float64]
    steer_ff: NDArray[np.float64]


class SpeedPattern(Protocol):
    def speed(self, t: NDArray[np.float64], rng: np.random.Generator) -> tuple[NDArray, NDArray]:
        """``(v_ref, a_ref)`` on the grid ``t``."""


class SteeringPattern(Protocol):
    def yaw_rate_ref(
        self, t: NDArray[np.float64], v: NDArray[np.float64], vehicle: VehicleParams, rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """``r_ref`` [rad/s] on the grid ``t`` for the speed ``v``."""


def _ss_gain(v: NDArray, vehicle: VehicleParams) -> NDArray:
    """Linear steady-state yaw-rate gain ``v / (l + K v²)`` [1/s]."""
    return v / (vehicle.wheelbase + vehicle.understeer_gradient * v**2)


# --- speed patterns ------------------------------------------------------------------
@dataclass(frozen=True)
class ConstantSpeed:
    """Constant speed ``v`` [m/s]."""

    v: float

    def speed(self, t, rng):
        return np.full_like(t, self.v), np.zeros_like(t)


@dataclass(frozen=True)
class SpeedPhases:
    """Piecewise-constant acceleration phases from an initial speed.

    Parameters
    ----------
    v0 : float
        Initial speed [m/s].
    phases : tuple of (duration [s], acceleration [m/s²])
        Applied in order; after the last phase the speed is held.
    ramp : float
        Acceleration changes are ramped linearly over this time [s] (finite jerk).
    """

    v0: float
    phases: tuple[tuple[float, float], ...]
    ramp: float = 0.5

    def speed(self, t, rng):
        t = np.asarray(t, float)
        a = np.zeros_like(t)
        t0 = 0.0
        for dur, acc in self.phases:
            # trapezoidal acceleration pulse with linear ramps of length `ramp`
            r = min(self.ramp, dur / 2.0)
            up = np.clip((t - t0) / r, 0.0, 1.0)
            down = np.clip((t0 + dur - t) / r, 0.0, 1.0)
            a += acc * np.minimum(up, down) * ((t >= t0) & (t <= t0 + dur))
            t0 += dur
        v = self.v0 + np.concatenate([[0.0], np.cumsum(0.5 * (a[1:] + a[:-1]) * np.diff(t))])
        if np.any(v <= 0):
            raise ValueError("SpeedPhases reaches zero or negative speed; shorten the braking phases")
        return v, a


@dataclass(frozen=True)
class RandomSpeed:
    """Smooth random speed between ``v_min`` and ``v_max`` [m/s].

    ``corr_time`` [s] sets how slowly it varies.
    """

    v_min: float
    v_max: float
    corr_time: float = 20.0

    def speed(self, t, rng):
        z = smooth_noise(t, self.corr_time, rng)
        mid = 0.5 * (self.v_min + self.v_max)
        half = 0.5 * (self.v_max - self.v_min)
        v = mid + half * np.tanh(0.8 * z)
        return v, np.gradient(v, t)


# --- steering patterns ---------------------------------------------------------------
@dataclass(frozen=True)
class Straight:
    """Straight driving with small random corrections of std ``ay_std`` [m/s²]."""

    ay_std: float = 0.0
    corr_time: float = 3.0

    def yaw_rate_ref(self, t, v, vehicle, rng):
        if self.ay_std == 0:
            return np.zeros_like(t)
        return self.ay_std * smooth_noise(t, self.corr_time, rng) / v


@dataclass(frozen=True)
class Slalom:
    """Sinusoidal slalom with lateral-acceleration amplitude ``ay_amp`` [m/s²], period [s]."""

    ay_amp: float
    period: float

    def yaw_rate_ref(self, t, v, vehicle, rng):
        return self.ay_amp * np.sin(2 * np.pi * t / self.period) / v


@dataclass(frozen=True)
class SineSweep:
    """Road-wheel angle ``amp sin(phi(t))`` [rad], frequency linear from ``f0`` to ``f1`` [Hz].

    The sweep runs over ``[t0, t0 + sweep_time]`` (relative to the pattern's
    time origin) and is zero outside.
    """

    amp: float
    f0: float
    f1: float
    sweep_time: float
    t0: float = 0.0

    def yaw_rate_ref(self, t, v, vehicle, rng):
        tau = t - self.t0
        phase = 2 * np.pi * (self.f0 * tau + 0.5 * (self.f1 - self.f0) * tau**2 / self.sweep_time)
        d = np.where((tau >= 0) & (tau <= self.sweep_time), self.amp * np.sin(phase), 0.0)
        return _ss_gain(v, vehicle) * d


@dataclass(frozen=True)
class StepSteer:
    """Road-wheel angle step of ``amp`` [rad] at ``t_step`` [s], rising over ``rise`` [s]."""

    amp: float
    t_step: float = 1.0
    rise: float = 0.2

    def yaw_rate_ref(self, t, v, vehicle, rng):
        d = self.amp * np.clip((t - self.t_step) / self.rise, 0.0, 1.0)
        return _ss_gain(v, vehicle) * d


@dataclass(frozen=True)
class DoubleLaneChange:
    """Lateral offset ``offset`` [m] and back: two smooth (cosine) lane changes.

    Each change takes ``change_time`` [s]; the car holds the other lane for
    ``hold_time`` [s]. Starts at ``t0`` [s].
    """

    offset: float = 3.5
    change_time: float = 2.0
    hold_time: float = 1.5
    t0: float = 0.0

    def yaw_rate_ref(self, t, v, vehicle, rng):
        T = self.change_time
        tau = t - self.t0
        w = 2 * np.pi / T
        # y'' = offset w / T sin(w s) on [0, T] integrates to y(T) = offset with
        # y'(T) = y''(T) = 0: a jerk-limited lane change.
        def ydd(s: NDArray) -> NDArray:
            return np.where((s >= 0) & (s <= T), self.offset * w / T * np.sin(w * s), 0.0)

        ay = ydd(tau) - ydd(tau - T - self.hold_time)
        return ay / v


@dataclass(frozen=True)
class RandomSteer:
    """Smooth random lateral acceleration with a slowly varying envelope.

    ``ay = envelope(t) * n(t)`` with ``n`` a unit smooth noise of correlation time
    ``corr_time`` [s] and ``envelope`` a level between ``ay_min`` and ``ay_max``
    [m/s²]. With ``envelope_period`` [s] the envelope is a raised cosine of that
    period with a random phase, so every seed spends the same share of time at
    each level; otherwise it is a smooth random level of correlation time
    ``envelope_time`` [s].
    """

    ay_min: float
    ay_max: float
    corr_time: float = 1.2
    envelope_time: float = 25.0
    envelope_period: float | None = None

    def yaw_rate_ref(self, t, v, vehicle, rng):
        n = smooth_noise(t, self.corr_time, rng)
        n = n / max(float(np.std(n)), 1e-12)  # unit RMS in every realisation
        if self.envelope_period is not None:
            phase = rng.uniform(0.0, 2 * np.pi)
            level = 0.5 * (1.0 - np.cos(2 * np.pi * t / self.envelope_period + phase))
        else:
            level = 0.5 * (1.0 + np.tanh(smooth_noise(t, self.envelope_time, rng)))
        env = self.ay_min + (self.ay_max - self.ay_min) * level
        return env * n / v


@dataclass(frozen=True)
class Schedule:
    """Steering patterns active in time windows ``(t_start, t_end, pattern)``; zero elsewhere.

    Each pattern sees time relative to its window start. Windows fade in and
    out over ``fade`` [s].
    """

    windows: tuple[tuple[float, float, SteeringPattern], ...]
    fade: float = 0.5

    def yaw_rate_ref(self, t, v, vehicle, rng):
        r = np.zeros_like(t)
        for t0, t1, pat in self.windows:
            win = np.clip(np.minimum(t - t0, t1 - t) / self.fade, 0.0, 1.0)
            if not np.any(win > 0):
                rng.standard_normal(1)  # keep the random stream independent of windows
                continue
            r += win * pat.yaw_rate_ref(t - t0, v, vehicle, rng)
        return r


@dataclass(frozen=True)
class Maneuver:
    """Speed pattern + steering pattern + the driver's yaw-rate feedback gain.

    Attributes
    ----------
    speed : SpeedPattern
    steering : SteeringPattern
    yaw_gain : float
        ``k_r`` [rad of steering per rad/s of yaw-rate error].
    sideslip_gain : float
        ``k_b`` [rad of steering per rad of body sideslip ``vy / vx``]: the
        driver counter-steers when the rear slides out (lateral model only).
    """

    speed: SpeedPattern
    steering: SteeringPattern = field(default_factory=Straight)
    yaw_gain: float = 0.0
    sideslip_gain: float = 0.0

    def sample(self, t: NDArray[np.float64], vehicle: VehicleParams, rng: np.random.Generator) -> ManeuverSignals:
        """Driver references on the grid ``t`` (see module docstring)."""
        t = np.asarray(t, float)
        v, a = self.speed.speed(t, rng)
        v = np.asarray(v, float)
        if np.any(v <= 0):
            raise ValueError("the speed pattern must stay positive")
        r = np.asarray(self.steering.yaw_rate_ref(t, v, vehicle, rng), float)
        steer = (vehicle.wheelbase + vehicle.understeer_gradient * v**2) * r / v
        return ManeuverSignals(v, np.asarray(a, float), r, steer)
