"""Inputs of the GP-SSM filter from a drive: speeds, lateral acceleration, sub-steps.

The pose velocities are :func:`roadgrip.signals.pose_velocity`'s. The longitudinal
speed from the wheels is this filter's own (the mean wheel speed times the radius, no
steer or yaw correction as in :func:`roadgrip.signals.wheel_speed_vx`), and so is the
choice of source.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.inference.kinematic import kinematic_lateral_acceleration
from roadgrip.signals import WHEELS, pose_velocity, rolling_speed, speed_wheels

__all__ = ["POSE_DIFFERENCE_LOOKAHEAD", "SUBSTEP_INTERVALS", "SUBSTEP_TOLERANCE", "Sample", "accelerometer_ay",
           "drive_inputs", "drive_vx", "drive_vy", "input_lookahead", "substeps", "upsample_inputs"]

POSE_DIFFERENCE_LOOKAHEAD = 1.5
"""Look-ahead of a velocity differentiated from the pose by central differences, in
nominal sample intervals: the next sample, on a clock jittered by up to half a tick."""


class Sample(NamedTuple):
    """One time step of the filter's inputs (SI units).

    ``vy`` is a measured lateral velocity (NaN: none, ``GPSSMConfig.vy_source``);
    ``ax`` the longitudinal acceleration [m/s²] of the axle loads (NaN: none,
    ``GPSSMConfig.axle_loads``);
    ``recorded`` is False for a sub-step interpolated between recorded samples
    (:func:`upsample_inputs`), which gives no output row;
    ``ay_accel`` the accelerometer's lateral acceleration [m/s²] where ``ay`` is another
    source (``GPSSMConfig.ay_source='kinematic'``; NaN: ``ay`` is the accelerometer's):
    the guard's physics floor of the upper bands counts what either shows the car used.
    """

    t: float
    ay: float
    yaw_rate: float
    steer: float
    vx: float
    vy: float = math.nan
    ax: float = math.nan
    recorded: bool = True
    ay_accel: float = math.nan


def drive_vx(drive: Any, source: str = "auto") -> NDArray[np.float64]:
    """Longitudinal speed [m/s] for the filter's input.

    ``source``:

    ``'wheels'``  mean wheel speed times radius over the non-driven axle (all four wheels
                  for all-wheel drive); driven wheels spin and are not used;
    ``'column'``  the drive's ``vx`` column;
    ``'pose'``    the body-axis projection of the pose derivative
                  (:func:`roadgrip.signals.pose_velocity`, motion capture), at least 0;
    ``'auto'``    ``'wheels'`` when those wheel speeds exist, else ``'column'``, else
                  ``'pose'``.
    """
    wheels = tuple(f"omega_{w}" for w, u in zip(WHEELS, speed_wheels(drive.vehicle.drive), strict=True) if u)
    if source == "auto":
        if drive.has(*wheels):
            source = "wheels"
        elif drive.has("vx"):
            source = "column"
        elif drive.has("x", "y", "psi"):
            source = "pose"
        else:
            raise ValueError(
                f"drive from {drive.meta.source} has no non-driven wheel speeds, no 'vx' column "
                "and no pose: the GP-SSM filter needs the longitudinal speed"
            )
    if source == "wheels":
        return rolling_speed(drive)[0]
    if source == "column":
        return drive.col("vx")
    if source == "pose":
        return np.maximum(pose_velocity(drive)[0], 0.0)
    raise ValueError(f"vx source must be 'auto', 'wheels', 'column' or 'pose', got {source!r}")


def drive_vy(drive: Any, source: str = "pose") -> NDArray[np.float64]:
    """Measured body lateral velocity [m/s] (``GPSSMConfig.vy_source``).

    ``'pose'``: the drive's ``vy_pose`` column where it has one (a reader's body velocity
    from the pose, NaN where the pose jumps or has a gap, as
    :mod:`roadgrip.io.frictionmaps` writes it: a NaN sample is no measurement), else
    ``-sin(psi) dx/dt + cos(psi) dy/dt`` (central differences of the pose,
    :func:`roadgrip.signals.pose_velocity`);
    ``'none'``: NaN, no measurement.
    """
    if source == "none":
        return np.full(drive.n, np.nan)
    if source != "pose":
        raise ValueError(f"vy source must be 'none' or 'pose', got {source!r}")
    if drive.has("vy_pose"):
        return np.asarray(drive.col("vy_pose"), float)
    return pose_velocity(drive)[1]


def input_lookahead(config: Any, info: Any = None) -> float:
    """Look-ahead [s] of the filter's inputs: each input row depends on the samples up to
    its time plus this.

    A velocity differentiated from the pose here (``vx_source='pose'``, or ``'auto'`` on
    a drive with neither the speed wheels' ``omega_*`` nor a ``vx`` column; ``vy_source=
    'pose'`` on a drive without a ``vy_pose`` column; the kinematic lateral acceleration
    from it) takes central differences, which reach the next sample:
    :data:`POSE_DIFFERENCE_LOOKAHEAD` nominal intervals, ``1.5 / info.sample_rate``. Else 0.

    Parameters
    ----------
    config : GPSSMConfig
    info : DriveInfo, optional
        The drive's columns and nominal rate; without it a pose-differentiating
        configuration returns ``inf`` (the rate is unknown).
    """
    if info is None:
        uses = config.vx_source == "pose" or config.vy_source == "pose"
        return math.inf if uses else 0.0
    cols = info.columns
    wheels = {f"omega_{w}" for w, u in zip(WHEELS, speed_wheels(info.vehicle.drive), strict=True) if u}
    vx_pose = config.vx_source == "pose" or (
        config.vx_source == "auto" and not wheels <= cols and "vx" not in cols)
    vy_pose = config.vy_source == "pose" and "vy_pose" not in cols
    if not (vx_pose or vy_pose) or not {"x", "y", "psi"} <= cols:
        return 0.0
    rate = float(info.sample_rate)
    return POSE_DIFFERENCE_LOOKAHEAD / rate if rate > 0 else math.inf


def drive_inputs(
    drive: Any, vx_source: str = "auto", vy_source: str = "none", ay_source: str = "imu",
    *, max_sideslip_ratio: float | None = None, min_speed: float = 0.0,
) -> NDArray[np.float64]:
    """Columns ``t, ay, yaw_rate, steer, vx, vy, ax`` of a drive as an array (n, 7), the
    fields of :class:`Sample` (``vy`` NaN unless ``vy_source`` measures it; ``ay`` the
    accelerometer or, with ``ay_source='kinematic'``, ``r vx + dvy/dt``; ``ax`` the
    accelerometer's, NaN without one).

    With ``max_sideslip_ratio`` (``GPSSMConfig.max_sideslip_ratio``), a measured lateral
    velocity beyond ``max_sideslip_ratio vx`` at ``min_speed`` [m/s] or faster is no
    measurement (NaN): no car that is not spinning out moves so, and a localisation that
    jumps without the reader noticing does (the F1/10 recordings' ``vy_pose`` reaches
    3 m/s at 3-5 m/s for a sample or two). The filter then propagates its own there.
    """
    drive.require("t", "yaw_rate", "steer", why="inputs of the GP-SSM filter")
    vx, vy = drive_vx(drive, vx_source), drive_vy(drive, vy_source)
    if ay_source == "kinematic":
        if np.isnan(vy).all():
            raise ValueError("the kinematic lateral acceleration needs a measured lateral velocity")
        ay = kinematic_lateral_acceleration(drive.t, vx, vy, drive.col("yaw_rate"))
    else:
        drive.require("ay", why="the lateral acceleration of the GP-SSM filter")
        ay = drive.col("ay")
    ax = drive.col("ax") if drive.has("ax") else np.full(drive.n, np.nan)
    if max_sideslip_ratio is not None:
        vy = np.where((vx >= min_speed) & (np.abs(vy) > max_sideslip_ratio * np.abs(vx)), np.nan, vy)
    return np.column_stack([drive.col("t"), ay, drive.col("yaw_rate"), drive.col("steer"), vx, vy, ax])


def accelerometer_ay(drive: Any, ay_source: str = "imu") -> NDArray[np.float64]:
    """The :attr:`Sample.ay_accel` column of a drive, shape (n,) [m/s²]: the accelerometer's
    ``ay`` where the filter's ``ay`` is another source (``ay_source='kinematic'``), else NaN
    (the filter's ``ay`` is the accelerometer's, or there is none)."""
    if ay_source == "kinematic" and drive.has("ay"):
        return drive.col("ay").astype(float)
    return np.full(drive.n, np.nan)


SUBSTEP_INTERVALS = 20
"""Sample intervals of the start of a drive that fix its sub-step count (:func:`substeps`)."""

SUBSTEP_TOLERANCE = 0.05
"""An interval up to this fraction of ``max_dt`` longer than a whole number of ``max_dt``
takes that number of steps (a jittered clock at a multiple of ``max_dt``)."""


def substeps(t: NDArray, max_dt: float) -> int:
    """Filter steps per sample interval of :func:`upsample_inputs`: ``ceil(median dt /
    max_dt - SUBSTEP_TOLERANCE)``, the median over the first :data:`SUBSTEP_INTERVALS`
    intervals of the times ``t`` [s] (1 for fewer than two).

    The start of the drive fixes it, so that a later sample never changes it (the
    filter is causal), and the tolerance keeps the jitter of a clock that ticks at a
    multiple of ``max_dt`` from changing it by one."""
    if len(t) < 2:
        return 1
    dt = float(np.median(np.diff(np.asarray(t, float)[:SUBSTEP_INTERVALS + 1])))
    return max(1, math.ceil(dt / max_dt - SUBSTEP_TOLERANCE))


def upsample_inputs(data: NDArray, max_dt: float, k: int | None = None) -> tuple[NDArray, NDArray, int]:
    """Linear interpolation of the input rows onto ``k`` sub-steps per sample interval.

    The lateral model is integrated by forward Euler with the friction held over a step;
    for small, stiff vehicles at low sample rates (the JetRacer at 10 Hz) that step is
    unstable. With ``k`` steps per interval (:func:`substeps`) the filter runs on ``k - 1``
    interpolated rows between recorded ones (and the filter widens ``R`` by ``sqrt(k)`` so
    that the information per recorded sample is unchanged).

    Parameters
    ----------
    data : ndarray, shape (n, columns)
        Input rows, time [s] in the first column.
    max_dt : float
        Longest filter step [s].
    k : int, optional
        Filter steps per sample interval; default :func:`substeps` of the times of
        ``data`` (a drive read in chunks passes the first chunk's).

    Returns
    -------
    rows : ndarray, shape (n', columns)
    recorded : ndarray of bool, shape (n',)
        The rows that are samples of ``data`` (every ``k``-th).
    k : int
    """
    t = data[:, 0]
    if k is not None and (int(k) != k or k < 1):
        raise ValueError(f"filter steps per sample interval must be an integer >= 1, got {k!r}")
    if len(t) < 2:
        return data, np.ones(len(t), dtype=bool), 1 if k is None else int(k)
    k = substeps(t, max_dt) if k is None else int(k)
    if k == 1:
        return data, np.ones(len(t), dtype=bool), 1
    frac = np.arange(k) / k
    tf = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    tf = np.append(tf, t[-1])
    out = np.column_stack([tf] + [np.interp(tf, t, data[:, j]) for j in range(1, data.shape[1])])
    keep = np.zeros(len(tf), dtype=bool)
    keep[::k] = True
    return out, keep, k
