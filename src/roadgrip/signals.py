r"""Shared input signals: vehicle speed from the wheels or the pose, driven wheels, loads.

One implementation of each signal that several estimators derive from the same
columns, and the one place where estimators take them from. Every function is
pure and vectorised over leading axes; units are SI, axes ISO 8855 (x forward,
y left, yaw positive counter-clockwise), wheels in the order ``fl, fr, rl, rr``
of the drive schema (:data:`WHEELS`).

================================  ======================================================
function                          what
================================  ======================================================
:func:`driven_wheels`             which wheels the drive layout (``'fwd'``, ...) drives
:func:`undriven_wheels`           the free-rolling ones
:func:`speed_wheels`              the wheels whose speed measures the ground speed
:func:`rolling_speed`             mean rim speed ``R omega`` over those wheels
:func:`wheel_centre_speeds`       wheel-centre speed along each wheel from the CG motion
:func:`wheel_cg_speeds`           the inverse: CG speed ``vx`` seen by each wheel speed
:func:`wheel_speed_vx`            ``vx`` of a drive from its wheels, ``vx`` column or pose
:func:`body_velocity_from_pose`   body-frame ``(vx, vy)`` differentiated from a pose
:func:`pose_velocity`             the same from a drive's ``x, y, psi`` columns
:func:`axle_loads`                axle normal loads with longitudinal load transfer
:func:`level_accelerations`       accelerometer readings with the body's roll and pitch removed
:func:`tilt_gains`                the accelerometer's over-reading that it divides out
:func:`sustained_grip`            largest ``|a_y| / g`` held for a second so far (a friction floor)
:func:`white_noise_std`           white-noise level of a sampled signal
================================  ======================================================

The 95 % normal quantile is :data:`roadgrip.constants.Z95`.

This module sits above the data layer (:mod:`roadgrip.io`). The signals that
the layers below need as well are implemented there and only re-exported here:
:func:`driven_wheels` and :func:`axle_loads` in :mod:`roadgrip.vehicle.params`
(the planar model splits its drive torque and transfers load with them),
:func:`wheel_centre_speeds` in :mod:`roadgrip.vehicle.slip` (the simulators'
slip truth), :func:`body_velocity_from_pose` and :func:`white_noise_std` in
:mod:`roadgrip.io.derived` (the frictionmaps reader).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.io.derived import body_velocity_from_pose, white_noise_std
from roadgrip.vehicle.params import VehicleParams, axle_loads, driven_wheels
from roadgrip.vehicle.slip import wheel_centre_speeds

__all__ = [
    "VX_SOURCES",
    "WHEELS",
    "axle_loads",
    "body_velocity_from_pose",
    "current_grip",
    "driven_wheels",
    "grip_step",
    "level_accelerations",
    "pose_velocity",
    "rolling_speed",
    "speed_wheels",
    "sustained_grip",
    "sustained_grip_step",
    "tilt_gains",
    "undriven_wheels",
    "wheel_centre_speeds",
    "wheel_cg_speeds",
    "wheel_speed_vx",
    "white_noise_std",
]

WHEELS = ("fl", "fr", "rl", "rr")
"""Wheel order of every per-wheel array (the ``omega_*`` columns of the drive schema)."""

VX_SOURCES = ("auto", "wheels", "column", "pose")
"""Accepted ``source`` values of :func:`wheel_speed_vx`."""


def undriven_wheels(drive: str) -> NDArray[np.bool_]:
    """The free-rolling wheels, ``~driven_wheels(drive)``: bool, shape (4,), all False for ``'awd'``."""
    return ~driven_wheels(drive)


def speed_wheels(drive: str) -> NDArray[np.bool_]:
    """The wheels whose speed measures the ground speed: bool, shape (4,).

    The undriven wheels, which roll freely outside braking; all four on an
    all-wheel-driven car, which has none (its wheel speeds then carry the
    traction slip).
    """
    free = undriven_wheels(drive)
    return free if free.any() else np.ones(len(WHEELS), bool)


def rolling_speed(drive: Drive) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """Mean rim speed ``R omega`` [m/s] over :func:`speed_wheels`, and the columns used.

    The raw measurement, without :func:`wheel_cg_speeds`' steering and yaw
    corrections, for estimators that model the wheel speed themselves.

    Raises
    ------
    DriveValidationError
        A column it needs is missing (named in the message).
    """
    use = speed_wheels(drive.vehicle.drive)
    cols = tuple(f"omega_{w}" for w, u in zip(WHEELS, use, strict=True) if u)
    drive.require(*cols, why="the speed from the free-rolling wheels")
    return np.mean([drive.col(c) for c in cols], axis=0) * drive.vehicle.wheel_radius, cols


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
    use = speed_wheels(veh.drive)
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


def level_accelerations(ax: ArrayLike, ay: ArrayLike, vehicle: VehicleParams
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Horizontal accelerations [m/s²] from a body-fixed accelerometer's ``ax, ay``.

    The body rolls by ``phi = roll_gradient a_y`` and pitches by ``theta =
    pitch_gradient a_x`` (vehicle parameters), so the sensor reads gravity's
    component ``g sin(phi)`` with the lateral acceleration (and ``g sin(theta)``
    with the longitudinal): to first order ``ay_meas = a_y (1 + g roll_gradient)``
    and ``ax_meas = a_x (1 + g pitch_gradient)``. On a car with 8.8 deg/g of roll
    that is 15 % of ``a_y``: integrated as ``v_y' = a_y - v_x r`` it is a
    lateral-velocity drift of 0.6 m/s per second at 0.4 g, and the axle forces
    ``m a`` are 15 % too large. With both gradients 0 the inputs are returned.

    Examples
    --------
    >>> from roadgrip.vehicle import load_vehicle
    >>> from dataclasses import replace
    >>> veh = replace(load_vehicle("sedan"), roll_gradient=0.01)
    >>> round(float(level_accelerations(0.0, 1.0 + 0.01 * 9.80665, veh)[1]), 12)
    1.0
    """
    gx, gy = tilt_gains(vehicle)
    return np.asarray(ax, dtype=float) / gx, np.asarray(ay, dtype=float) / gy


def tilt_gains(vehicle: VehicleParams) -> tuple[float, float]:
    """How much a body-fixed accelerometer over-reads ``a_x`` and ``a_y`` [-]:
    ``1 + g pitch_gradient`` and ``1 + g roll_gradient`` (:func:`level_accelerations`
    divides by them)."""
    return 1.0 + GRAVITY * vehicle.pitch_gradient, 1.0 + GRAVITY * vehicle.roll_gradient


SUSTAIN_WINDOW = 1.0
"""Window [s] over which a lateral acceleration counts as sustained."""


def current_grip(t: ArrayLike, ay: ArrayLike, window: float = SUSTAIN_WINDOW) -> NDArray[np.float64]:
    """The ``|a_y| / g`` sustained over the last ``window`` seconds at each sample [-].

    The mean lateral acceleration over the samples of the trailing window
    ``(t_k - window, t_k]``, its absolute value over ``g``: the friction the car
    uses on the surface under it now. 0 until the drive is ``window`` long. It is
    the lower-bound floor of a claim about the present surface: unlike its running
    maximum (:func:`sustained_grip`), it forgets a surface the car has left (a
    claim judged 1 s after the car reaches the new surface's grip never meets the
    old surface's floor).

    Examples
    --------
    >>> t = [0.0, 0.5, 1.0, 1.5, 2.0]
    >>> current_grip(t, [0.0, 4.903325, 4.903325, 4.903325, 0.0]).round(3).tolist()
    [0.0, 0.0, 0.333, 0.5, 0.333]
    """
    t = np.asarray(t, dtype=float)
    ay = np.asarray(ay, dtype=float)
    if t.size == 0:
        return np.zeros(0)
    c = np.concatenate([[0.0], np.cumsum(ay)])
    lo = np.searchsorted(t, t - window + 1e-9, side="left")
    hi = np.arange(1, len(t) + 1)
    mean = (c[hi] - c[lo]) / (hi - lo)
    full = t - t[0] >= window - 1e-9
    return np.where(full, np.abs(mean), 0.0) / GRAVITY


def sustained_grip(t: ArrayLike, ay: ArrayLike, window: float = SUSTAIN_WINDOW) -> NDArray[np.float64]:
    """The largest ``|a_y| / g`` sustained for ``window`` seconds up to each sample [-].

    The running maximum of :func:`current_grip`: a friction the car demonstrably
    used by then, which no honest upper bound of the friction may undercut (it
    needs no truth). 0 until the drive is ``window`` long. The mean, not the
    smallest value, so that sensor noise does not lower it.

    Examples
    --------
    >>> t = [0.0, 0.5, 1.0, 1.5, 2.0]
    >>> sustained_grip(t, [0.0, 4.903325, 4.903325, 4.903325, 0.0]).round(3).tolist()
    [0.0, 0.0, 0.333, 0.5, 0.5]
    """
    return np.maximum.accumulate(current_grip(t, ay, window)) if np.size(t) else np.zeros(0)


def grip_step(memory: tuple | None, t: float, ay: float,
              window: float = SUSTAIN_WINDOW) -> tuple[tuple, float, float]:
    """One sample of :func:`current_grip` and :func:`sustained_grip`, online.

    Returns ``(memory, now, floor)``: the memory after the sample, the current and
    the sustained grip [-]. ``memory`` is ``None`` before the first sample, then the
    returned tuple (first time, the window's times and running sums of ``a_y`` with
    the sum before the window, the floor so far); it is never modified. Both values
    equal those of the batch functions to the last bit.
    """
    t0, ts, cs, c_before, best = (t, (), (), 0.0, 0.0) if memory is None else memory
    c = (cs[-1] if cs else c_before) + ay
    ts, cs = (*ts, t), (*cs, c)
    first = next(i for i, tj in enumerate(ts) if tj >= t - window + 1e-9)
    if first > 0:
        c_before = cs[first - 1]
        ts, cs = ts[first:], cs[first:]
    now = abs((c - c_before) / len(ts)) / GRAVITY if t - t0 >= window - 1e-9 else 0.0
    best = max(best, now)
    return (t0, ts, cs, c_before, best), now, best


def sustained_grip_step(memory: tuple | None, t: float, ay: float,
                        window: float = SUSTAIN_WINDOW) -> tuple[tuple, float]:
    """One sample of :func:`sustained_grip`, online: ``(memory, floor)`` after the sample
    (:func:`grip_step` without the current grip)."""
    memory, _, best = grip_step(memory, t, ay, window)
    return memory, best
