r"""Shared input signals: vehicle speed from the wheels or the pose, driven wheels, loads.

One implementation of each signal that several estimators, the simulator and
the readers derive from the same columns. Every function is pure and
vectorised over leading axes; units are SI, axes ISO 8855 (x forward, y left,
yaw positive counter-clockwise), wheels in the order ``fl, fr, rl, rr`` of the
drive schema (:data:`WHEELS`).

================================  ======================================================
function                          what
================================  ======================================================
:func:`driven_wheels`             which wheels the drive layout (``'fwd'``, ...) drives
:func:`undriven_wheels`           the free-rolling ones
:func:`wheel_centre_speeds`       wheel-centre speed along each wheel from the CG motion
:func:`wheel_cg_speeds`           the inverse: CG speed ``vx`` seen by each wheel speed
:func:`wheel_speed_vx`            ``vx`` of a drive from its wheels, ``vx`` column or pose
:func:`body_velocity_from_pose`   body-frame ``(vx, vy)`` differentiated from a pose
:func:`pose_velocity`             the same from a drive's ``x, y, psi`` columns
:func:`axle_loads`                axle normal loads with longitudinal load transfer
:func:`white_noise_std`           white-noise level of a sampled signal
================================  ======================================================

The 95 % normal quantile is :data:`roadgrip.constants.Z95`.

At run time this module imports nothing of roadgrip but :mod:`roadgrip.constants`,
so that the vehicle models, the simulator and the readers can call it without
an import cycle; drives and vehicle parameters are used through their
attributes (``drive.col``, ``drive.require``, ``params.lf``, ...).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

if TYPE_CHECKING:
    from roadgrip.drive import Drive
    from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "VX_SOURCES",
    "WHEELS",
    "axle_loads",
    "body_velocity_from_pose",
    "driven_wheels",
    "pose_velocity",
    "undriven_wheels",
    "wheel_centre_speeds",
    "wheel_cg_speeds",
    "wheel_speed_vx",
    "white_noise_std",
]

WHEELS = ("fl", "fr", "rl", "rr")
"""Wheel order of every per-wheel array (the ``omega_*`` columns of the drive schema)."""

_DRIVEN = {
    "fwd": (True, True, False, False),
    "rwd": (False, False, True, True),
    "awd": (True, True, True, True),
}

VX_SOURCES = ("auto", "wheels", "column", "pose")
"""Accepted ``source`` values of :func:`wheel_speed_vx`."""


# ---------------------------------------------------------------------------------------
# drive layout
# ---------------------------------------------------------------------------------------
def driven_wheels(drive: str) -> NDArray[np.bool_]:
    """Which wheels the drive layout drives.

    Parameters
    ----------
    drive : {'fwd', 'rwd', 'awd'}
        ``VehicleParams.drive``.

    Returns
    -------
    ndarray of bool, shape (4,)
        Order ``fl, fr, rl, rr`` (:data:`WHEELS`); a new array on each call.

    Raises
    ------
    ValueError
        An unknown layout (named in the message).
    """
    try:
        return np.array(_DRIVEN[drive], dtype=bool)
    except (KeyError, TypeError):
        raise ValueError(f"unknown drive layout {drive!r}; known: {sorted(_DRIVEN)}") from None


def undriven_wheels(drive: str) -> NDArray[np.bool_]:
    """The free-rolling wheels, ``~driven_wheels(drive)``: bool, shape (4,), all False for ``'awd'``."""
    return ~driven_wheels(drive)


# ---------------------------------------------------------------------------------------
# wheel kinematics
# ---------------------------------------------------------------------------------------
def wheel_centre_speeds(
    vx: ArrayLike, vy: ArrayLike, yaw_rate: ArrayLike, steer: ArrayLike, params: VehicleParams
) -> NDArray[np.float64]:
    """Speed of each wheel centre along its wheel's heading (the free-rolling ``R omega``).

    The wheels sit at ``x = lf`` (front), ``x = -lr`` (rear) and ``y = ± b/2``
    (``b`` the track width, left positive); a rigid body moving with
    ``(vx, vy, r)`` at the CG moves a wheel centre with ``(vx - r y, vy + r x)``,
    which is projected on the wheel heading (``steer`` at the front, 0 at the rear):

    ``v_fl = (vx - r b/2) cos(delta) + (vy + lf r) sin(delta)``, ``v_rl = vx - r b/2``,
    and ``+ r b/2`` on the right.

    Parameters
    ----------
    vx, vy : array_like, shape (...)
        CG velocity in body axes [m/s].
    yaw_rate : array_like, shape (...)
        [rad/s].
    steer : array_like, shape (...)
        Front road-wheel angle [rad].
    params : VehicleParams
        ``lf`` and ``track_width`` [m] are used.

    Returns
    -------
    ndarray, shape (..., 4)
        Wheel-centre speeds ``fl, fr, rl, rr`` [m/s].
    """
    vx = np.asarray(vx, float)
    hb = 0.5 * params.track_width * np.asarray(yaw_rate, float)
    steer = np.asarray(steer, float)
    c, s = np.cos(steer), np.sin(steer)
    lat_f = (np.asarray(vy, float) + params.lf * np.asarray(yaw_rate, float)) * s
    vl, vr = vx - hb, vx + hb
    return np.stack(np.broadcast_arrays(vl * c + lat_f, vr * c + lat_f, vl, vr), axis=-1)


def wheel_cg_speeds(
    omega: ArrayLike,
    steer: ArrayLike,
    yaw_rate: ArrayLike,
    params: VehicleParams,
    *,
    vy: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The CG speed ``vx`` that each wheel speed implies if the wheel rolls freely.

    The inverse of :func:`wheel_centre_speeds` for ``vx``:
    ``vx = (R omega_f - (vy + lf r) sin(delta)) / cos(delta) ± r b/2`` at the
    front and ``vx = R omega_r ± r b/2`` at the rear (``+`` on the left). The
    front wheels need the lateral velocity; without one the rear axle is taken
    to roll without side slip, ``vy = lr r`` (then ``vy + lf r = l r``), which
    is exact in kinematic cornering and off by ``vx tan(alpha_r) tan(delta)``
    otherwise.

    Parameters
    ----------
    omega : array_like, shape (..., 4)
        Wheel angular speeds ``fl, fr, rl, rr`` [rad/s] (NaN stays NaN).
    steer, yaw_rate : array_like, shape (...)
        Front road-wheel angle [rad] and yaw rate [rad/s].
    params : VehicleParams
        ``wheel_radius``, ``lf``, ``lr``, ``track_width`` [m] are used.
    vy : array_like, shape (...), optional
        CG lateral velocity [m/s]; default ``lr * yaw_rate``.

    Returns
    -------
    ndarray, shape (..., 4)
        [m/s]; a driven or braked wheel's value includes its slip.
    """
    omega = np.asarray(omega, float)
    r = np.asarray(yaw_rate, float)
    steer = np.asarray(steer, float)
    vy = params.lr * r if vy is None else np.asarray(vy, float)
    v = params.wheel_radius * omega
    hb = 0.5 * params.track_width * r
    lat_f = (vy + params.lf * r) * np.sin(steer)
    c = np.cos(steer)
    return np.stack(np.broadcast_arrays(
        (v[..., 0] - lat_f) / c + hb, (v[..., 1] - lat_f) / c - hb, v[..., 2] + hb, v[..., 3] - hb,
    ), axis=-1)


def wheel_speed_vx(
    drive: Drive, source: str = "auto", *, vy: ArrayLike | None = None
) -> tuple[NDArray[np.float64], str]:
    """Longitudinal CG speed of a drive [m/s], and the source it came from.

    Sources:

    ``'wheels'``
        Mean of :func:`wheel_cg_speeds` over the undriven wheels (a driven wheel
        spins under traction); all four wheels on an all-wheel-driven car, which
        has no undriven wheel. Needs those ``omega_*`` columns, ``steer`` and
        ``yaw_rate`` (the yaw terms of a left-right pair cancel in the mean; the
        steer term corrects the front wheels).
    ``'column'``
        The ``vx`` column (odometry, GNSS, an upstream estimate).
    ``'pose'``
        ``vx`` of :func:`pose_velocity` (central differences of ``x, y``
        rotated by ``psi``); signed.
    ``'auto'``
        The undriven wheels when the car has undriven wheels and their columns
        exist; else the ``vx`` column; else all four wheels (all-wheel drive);
        else the pose.

    Parameters
    ----------
    drive : Drive
        Uses ``drive.vehicle`` (``drive``, ``wheel_radius``, ``lf``, ``lr``,
        ``track_width``) and the columns named above.
    source : {'auto', 'wheels', 'column', 'pose'}
    vy : array_like, shape (n,), optional
        CG lateral velocity for the front-wheel correction (:func:`wheel_cg_speeds`).

    Returns
    -------
    vx : ndarray, shape (n,)
        [m/s].
    source_used : {'wheels', 'column', 'pose'}

    Raises
    ------
    DriveValidationError
        A column the source needs is missing (named in the message); with
        ``'auto'``, none of the sources is available.
    ValueError
        An unknown ``source``.
    """
    if source not in VX_SOURCES:
        raise ValueError(f"vx source must be one of {VX_SOURCES}, got {source!r}")
    veh = drive.vehicle
    free = undriven_wheels(veh.drive)
    use = free if free.any() else np.ones(4, bool)
    wheel_cols = [f"omega_{w}" for w, u in zip(WHEELS, use, strict=True) if u]
    if source == "auto":
        if free.any() and drive.has(*wheel_cols):
            source = "wheels"
        elif drive.has("vx"):
            source = "column"
        elif drive.has(*wheel_cols):
            source = "wheels"
        elif drive.has("x", "y", "psi"):
            source = "pose"
        else:
            drive.require(*wheel_cols, "vx", "x", "y", "psi",
                          why="vx needs the undriven wheel speeds, a vx column or a pose")
    if source == "wheels":
        drive.require(*wheel_cols, "steer", "yaw_rate", why="vx from the wheel speeds")
        omega = np.full((drive.n, 4), np.nan)
        for i in np.flatnonzero(use):
            omega[:, i] = drive.col(f"omega_{WHEELS[i]}")
        v = wheel_cg_speeds(omega, drive.col("steer"), drive.col("yaw_rate"), veh, vy=vy)
        return v[:, use].mean(axis=1), "wheels"
    if source == "column":
        drive.require("vx", why="vx from the vx column")
        return drive.col("vx"), "column"
    return pose_velocity(drive)[0], "pose"


# ---------------------------------------------------------------------------------------
# pose
# ---------------------------------------------------------------------------------------
def body_velocity_from_pose(
    t: ArrayLike,
    x: ArrayLike,
    y: ArrayLike,
    psi: ArrayLike,
    *,
    window: float | None = None,
    bad: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body-frame velocity ``(vx, vy)`` [m/s] differentiated from a pose.

    The map-frame velocity ``(x', y')`` is rotated into the body frame at the
    sample's heading: ``vx = cos(psi) x' + sin(psi) y'``,
    ``vy = -sin(psi) x' + cos(psi) y'``; ``psi`` is unwrapped first.

    ``window=None`` differentiates by central differences in ``t``
    (:func:`numpy.gradient`, second order, one-sided at the ends). With a
    ``window`` [s], a local quadratic (Savitzky-Golay) fit over that window on a
    uniform clock gives ``x'``, ``y'`` and a smoothed ``psi``, for noisy poses;
    the fit never spans a missing tick (a gap in ``t`` over 1.5 steps) or a
    sample flagged in ``bad``: samples within half a window of either, and
    segments shorter than a window, get NaN.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s], increasing.
    x, y : array_like, shape (n,)
        Position of the reference point in the map frame [m].
    psi : array_like, shape (n,)
        Heading [rad], wrapped or not.
    window : float, optional
        Fit window [s] (odd number of samples, at least 5).
    bad : array_like of bool, shape (n,), optional
        Samples not to use (localisation jumps); only with ``window``.

    Returns
    -------
    vx, vy : ndarray, shape (n,)
        Body velocity of the reference point [m/s].
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    psi = np.unwrap(np.asarray(psi, float))
    if window is None:
        if bad is not None:
            raise ValueError("bad samples are only handled by the windowed fit (give window)")
        return _rotate_to_body(np.gradient(x, t), np.gradient(y, t), psi)
    return _savgol_body_velocity(t, x, y, psi, float(window), bad)


def _rotate_to_body(xd, yd, psi):
    c, s = np.cos(psi), np.sin(psi)
    return c * xd + s * yd, -s * xd + c * yd


def _savgol_body_velocity(t, x, y, psi, window, bad):
    from scipy.signal import savgol_filter

    n = len(t)
    vx = np.full(n, np.nan)
    vy = np.full(n, np.nan)
    if n < 5:
        return vx, vy
    h = float(np.median(np.diff(t)))
    w = max(round(window / h) // 2 * 2 + 1, 5)
    half = w // 2
    bad = np.zeros(n, bool) if bad is None else np.asarray(bad, bool)
    # segments between missing ticks and bad samples
    brk = np.r_[True, np.diff(t) > 1.5 * h] | bad
    seg = np.cumsum(brk)
    for s in np.unique(seg):
        idx = np.flatnonzero((seg == s) & ~bad)
        if len(idx) < w:
            continue
        i0, i1 = idx[0], idx[-1] + 1
        xd = savgol_filter(x[i0:i1], w, 2, deriv=1, delta=h)
        yd = savgol_filter(y[i0:i1], w, 2, deriv=1, delta=h)
        bx, by = _rotate_to_body(xd, yd, savgol_filter(psi[i0:i1], w, 2))
        # the edges use a one-sided fit: keep only the centred part
        bx[:half] = bx[-half:] = np.nan
        by[:half] = by[-half:] = np.nan
        vx[i0:i1], vy[i0:i1] = bx, by
    return vx, vy


def pose_velocity(
    drive: Drive, *, window: float | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`body_velocity_from_pose` of a drive's ``t, x, y, psi`` columns.

    Returns
    -------
    vx, vy : ndarray, shape (n,)
        [m/s].

    Raises
    ------
    DriveValidationError
        ``x``, ``y`` or ``psi`` is missing (named in the message).
    """
    drive.require("x", "y", "psi", why="the body velocity from the pose")
    return body_velocity_from_pose(drive.t, drive.col("x"), drive.col("y"), drive.col("psi"),
                                   window=window)


# ---------------------------------------------------------------------------------------
# loads
# ---------------------------------------------------------------------------------------
def axle_loads(params: VehicleParams, ax: ArrayLike = 0.0) -> tuple[NDArray, NDArray]:
    """Axle normal loads with quasi-steady longitudinal load transfer.

    ``F_zf = m g lr / l - m a_x h / l`` and ``F_zr = m g lf / l + m a_x h / l``
    (``l = lf + lr``, ``h`` the CG height), each clipped at zero (a lifted
    axle); ``ax = 0`` gives the static loads ``params.fz_front``,
    ``params.fz_rear``.

    Parameters
    ----------
    params : VehicleParams
        ``mass``, ``lf``, ``lr``, ``cg_height`` are used.
    ax : array_like, shape (...)
        Longitudinal acceleration (specific force) at the CG [m/s²], positive forward.

    Returns
    -------
    fz_front, fz_rear : ndarray, shape (...)
        [N].
    """
    ax = np.asarray(ax, dtype=float)
    dfz = params.mass * ax * params.cg_height / params.wheelbase
    return np.maximum(params.fz_front - dfz, 0.0), np.maximum(params.fz_rear + dfz, 0.0)


# ---------------------------------------------------------------------------------------
# noise
# ---------------------------------------------------------------------------------------
def white_noise_std(x: ArrayLike) -> float:
    """Standard deviation of the white noise on a sampled signal [unit of ``x``].

    The robust scale (1.4826 times the median absolute deviation) of the second
    differences, divided by ``sqrt(6)``: white noise of standard deviation
    ``s`` gives second differences of variance ``6 s²``, while a signal that is
    smooth at the sampling rate contributes little to them. Linear
    interpolation has zero second difference, so the signal must be taken as
    sampled, not resampled onto a finer clock.

    Parameters
    ----------
    x : array_like, shape (n,)
        Samples on a (roughly) uniform clock.

    Returns
    -------
    float
        NaN when there are fewer than 10 second differences (``n < 12``).
    """
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if d2.size < 10:
        return float("nan")
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))
