"""Signal preparation shared by the parts of ``roadgrip vehicle fit``: the drive's step,
Savitzky-Golay smoothing and differentiation, delays applied, the pose's lateral velocity,
and masks widened."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.io.derived import body_velocity_from_pose, savgol_quadratic

__all__ = ["POSE_WINDOW", "SMOOTH", "dilate", "half_width", "pose_velocity", "shifted", "smooth", "uniform_dt",
           "usable"]

SMOOTH = 0.3
"""Savitzky-Golay window [s] of the signals and of ``r'`` in the single-track fit: one
linear filter on both sides of the identity, which holds through it; 0.3 s passes the
manoeuvres (a quadratic fit over 0.3 s keeps 1 Hz to within 2 %) and leaves the
differentiated gyro noise (0.005 rad/s at 100 Hz) under 0.5 % of ``r'``'s variance."""
POSE_WINDOW = 0.5
"""Savitzky-Golay window [s] of the rear-axle equation with the pose's ``v_y`` (and of every
signal in it)."""


def uniform_dt(t: NDArray) -> float:
    return float(np.median(np.diff(t)))


def half_width(dt: float, window: float = SMOOTH) -> int:
    """Half-width [samples] of the Savitzky-Golay filter of ``window`` [s]."""
    return max(round(window / dt / 2), 2)


def smooth(v: NDArray, dt: float, window: float = SMOOTH, deriv: int = 0) -> NDArray:
    m = half_width(dt, window)
    out = savgol_quadratic(v, 2 * m + 1, deriv=deriv, delta=dt)
    ok = np.isfinite(out)
    if ok.any() and not ok.all():  # hold the first and last centred values at the ends
        i = np.flatnonzero(ok)
        out = np.interp(np.arange(len(out)), i, out[i])
    return out


def shifted(t: NDArray, v: NDArray, delay: float) -> NDArray:
    """``v`` moved back by ``delay`` [s] (``out(t) = v(t + delay)``), held at the ends."""
    return v if delay == 0.0 else np.interp(t + delay, t, v)


def pose_velocity(drive: Drive) -> tuple[NDArray, NDArray] | None:
    """The pose's body velocity, longitudinal and lateral [m/s] (0.5 s windows,
    :func:`~roadgrip.io.derived.body_velocity_from_pose`); None without a pose."""
    if not drive.has_pose:
        return None
    v = body_velocity_from_pose(drive.t, drive.col("x"), drive.col("y"), drive.col("psi"), window=0.5)
    return v[0], v[1]


def usable(v: NDArray | None) -> NDArray | None:
    """``v`` where it is known on more than half the drive, else None."""
    return v if v is not None and np.isfinite(v).mean() > 0.5 else None


def dilate(mask: NDArray, k: int) -> NDArray:
    """``mask`` widened by ``k`` samples on both sides."""
    if not mask.any() or k <= 0:
        return mask
    c = np.concatenate(([0], np.cumsum(mask)))
    i = np.arange(len(mask))
    return (c[np.minimum(i + k + 1, len(mask))] - c[np.maximum(i - k, 0)]) > 0
