"""Signal preparation shared by the parts of ``roadgrip vehicle fit``: the drive's step,
Savitzky-Golay smoothing and differentiation, delays applied, the pose's lateral velocity,
and masks widened."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.inference.least_squares import held_samples
from roadgrip.io.derived import body_velocity_from_pose, savgol_quadratic

__all__ = ["POSE_WINDOW", "SMOOTH", "dilate", "fill_held", "half_width", "pose_columns", "pose_velocity",
           "shifted", "smooth", "uniform_dt", "usable"]

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


def fill_held(t: NDArray, v: NDArray) -> NDArray:
    """``v`` with each value the logger held (:func:`~roadgrip.inference.least_squares.held_samples`),
    after the first of its run, replaced by linear interpolation between the samples around
    the run: a held value is a missing one.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Time [s].
    v : ndarray, shape (n,)
        One channel as logged (an angle unwrapped first).

    Returns
    -------
    ndarray, shape (n,)
        A copy; ``v`` itself where nothing is held.

    Examples
    --------
    >>> t = np.arange(10.0)
    >>> v = np.sin(t)
    >>> v[3:8] = v[3]
    >>> bool(np.allclose(fill_held(t, v)[4:7], np.interp(t[4:7], [3, 8], [np.sin(3), np.sin(8)])))
    True
    """
    held = held_samples(v)
    missing = held & np.concatenate(([False], held[:-1]))
    if not missing.any() or missing.all():
        return v
    out = np.array(v, float)
    out[missing] = np.interp(t[missing], t[~missing], out[~missing])
    return out


def pose_columns(drive: Drive) -> tuple[NDArray, NDArray, NDArray]:
    """The pose's ``x, y`` [m] and unwrapped ``psi`` [rad] with the logger's holds filled
    (:func:`fill_held`). Differentiated, a held pose is a standstill and then a jump: on the
    random family's ``vehicle-id`` drives (0.2-0.6 % of the samples held) it left ``a_x``'s
    delay against the pose undetermined on two cars of 20, 14-21 ms off; filled, all 20
    within 2-11 ms. Needs ``drive.has_pose``."""
    t = drive.t
    return (fill_held(t, drive.col("x")), fill_held(t, drive.col("y")),
            fill_held(t, np.unwrap(drive.col("psi"))))


def pose_velocity(drive: Drive) -> tuple[NDArray, NDArray] | None:
    """The pose's body velocity, longitudinal and lateral [m/s] (:data:`POSE_WINDOW` windows,
    :func:`~roadgrip.io.derived.body_velocity_from_pose` of :func:`pose_columns`); None without
    a pose."""
    if not drive.has_pose:
        return None
    v = body_velocity_from_pose(drive.t, *pose_columns(drive), window=POSE_WINDOW)
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
