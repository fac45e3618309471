"""Inputs of the Kalman cascade: the measured speed, the sensor noise and the per-sample records.

Sensor noise
------------
Unless given in :class:`~roadgrip.estimators.cascade.config.CascadeConfig`,
the noise standard deviations of the accelerometers, gyro and speed signal are
taken from the reader (``meta.extra['sensor_noise']``, measured on the native
streams before resampling) or else estimated from the drive itself by
:func:`noise_from_drive` (robust scale of second differences, which removes a
smooth signal and leaves white noise with variance ``6 s²``). On a signal
upsampled by linear interpolation the second differences vanish between
native samples, so the estimate from the drive is then far too small; the
reader's values take precedence.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple, overload

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive, DriveValidationError
from roadgrip.estimators.cascade.config import CascadeConfig
from roadgrip.estimators.cascade.kernel import Inputs
from roadgrip.signals import (
    level_accelerations,
    pose_velocity,
    rolling_speed,
    white_noise_std,
)

__all__ = [
    "NOISE_FLOORS",
    "POSE_WINDOWS",
    "CascadeSample",
    "CascadeSamples",
    "derive_pose_velocity",
    "drive_inputs",
    "drive_pose",
    "has_standstill",
    "measured_speed",
    "noise_from_drive",
    "pose_velocity_noise",
    "resolve_noise",
]

NOISE_FLOORS = {"accel_std": 0.02, "gyro_std": 0.002, "speed_std": 0.01}
"""Smallest noise standard deviations used [m/s², rad/s, m/s]: quantised or interpolated
signals are never trusted absolutely."""


class CascadeSample(NamedTuple):
    """One sample of the inputs (SI): time, accelerations, yaw rate, steering, measured speed.

    ``vx_pose, vy_pose`` [m/s] are the optional body velocity derived from a
    localisation pose (NaN: none at this sample). ``x, y`` [m] and ``psi``
    [rad] are the pose carried into the output row for mapping (NaN: none).
    """

    t: float
    ax: float
    ay: float
    yaw_rate: float
    steer: float
    speed: float
    vx_pose: float = float("nan")
    vy_pose: float = float("nan")
    x: float = float("nan")
    y: float = float("nan")
    psi: float = float("nan")


class CascadeSamples(Sequence[CascadeSample]):
    """The samples of a drive, held as columns (the batch kernel reads them at once).

    Attributes
    ----------
    inputs : Inputs
        The filter inputs, each shape (n,).
    pose : tuple of ndarray or None
        ``(x, y, psi)`` [m, m, rad] for the output table, ``(x, y)`` when the
        drive has no heading, ``None`` when it has no position.
    """

    def __init__(self, inputs: Inputs, pose: tuple[NDArray[np.float64], ...] | None) -> None:
        self.inputs = inputs
        self.pose = pose

    def __len__(self) -> int:
        return int(self.inputs.t.shape[0])

    @overload
    def __getitem__(self, k: int) -> CascadeSample: ...
    @overload
    def __getitem__(self, k: slice) -> CascadeSamples: ...

    def __getitem__(self, k: int | slice) -> Any:
        if isinstance(k, slice):
            pose = None if self.pose is None else tuple(a[k] for a in self.pose)
            return CascadeSamples(Inputs(*(a[k] for a in self.inputs)), pose)
        nan = float("nan")
        pose = [float(a[k]) for a in self.pose or ()]
        pose += [nan] * (3 - len(pose))
        return CascadeSample(*(float(a[k]) for a in self.inputs), *pose)


def _robust_noise(x: NDArray[np.float64]) -> float:
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if d2.size < 10:
        return 0.0
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))


def noise_from_drive(drive: Drive, speed: NDArray[np.float64] | None = None) -> dict[str, float]:
    """Estimate white-noise standard deviations of the inputs from the drive.

    The robust standard deviation (1.4826 MAD) of the second difference of a
    signal, divided by ``sqrt(6)``: a smooth signal contributes little to the
    second difference at the sampling rate, white noise contributes ``6 s²``.
    The result is at least :data:`NOISE_FLOORS`.

    Returns
    -------
    dict
        ``accel_std`` [m/s²] (the larger of ``ax``, ``ay``), ``gyro_std`` [rad/s],
        ``speed_std`` [m/s].
    """
    out = {
        "accel_std": max(_robust_noise(drive.col("ax")), _robust_noise(drive.col("ay"))),
        "gyro_std": _robust_noise(drive.col("yaw_rate")),
        "speed_std": _robust_noise(speed) if speed is not None else 0.0,
    }
    return {k: max(v, NOISE_FLOORS[k]) for k, v in out.items()}


def measured_speed(drive: Drive, source: str = "auto") -> tuple[NDArray[np.float64], str, float]:
    """The stage-1 speed measurement (eq. 5) [m/s], a description, the share of front wheels.

    ``'wheels'``: mean of ``omega R`` over the undriven wheels
    (:func:`roadgrip.signals.rolling_speed`; all four on a four-wheel-driven
    car). ``'motor_rpm'``: motor speed [rev/min] through the gear ratio,
    ``rpm 2 pi R / (60 i)``. ``'vx_motor'`` and ``'vx'``: those columns.
    ``'auto'`` takes the first available of wheels, vx, vx_motor, motor_rpm, but
    prefers ``vx`` to wheel speeds on a four-wheel-driven car (all wheels slip).
    The third value is the fraction of steered (front) wheels in the mean, which
    stage 1 uses to model their speed, ``vx cos d + (vy + lf r) sin d``.

    Raises
    ------
    DriveValidationError
        When the requested (or any, for ``'auto'``) source is missing.
    """
    veh = drive.vehicle
    if source == "auto":
        # undriven wheels measure the ground speed; on a four-wheel-driven car every
        # wheel slips under drive, so a measured vx (odometry, GNSS) comes first there
        order = ("vx", "wheels", "vx_motor", "motor_rpm") if veh.drive == "awd" else (
            "wheels", "vx", "vx_motor", "motor_rpm")
    else:
        order = (source,)
    for src in order:
        if src == "wheels" and drive.has_wheel_speeds:
            speed, cols = rolling_speed(drive)
            share = sum(c.startswith("omega_f") for c in cols) / len(cols)
            return speed, f"wheel speeds {'+'.join(cols)} x R", share
        if src in ("vx", "vx_motor") and drive.has(src):
            return drive.col(src), f"column {src}", 0.0
        if src == "motor_rpm" and drive.has("motor_rpm"):
            v = drive.col("motor_rpm") * 2 * np.pi * veh.wheel_radius / (60.0 * veh.gear_ratio)
            return v, "motor_rpm through the gear ratio (eq. 5)", 0.0
    raise DriveValidationError(
        f"drive from {drive.meta.source} has no speed measurement for the cascade "
        f"(source {source!r}; need wheel speeds omega_*, vx, vx_motor or motor_rpm)"
    )


def resolve_noise(cfg: CascadeConfig, drive: Drive, speed: NDArray[np.float64],
                  speed_source: str = "") -> dict[str, float]:
    """Noise standard deviations: the config's, else the reader's, else estimated from the drive.

    A reader that resamples asynchronous streams may record the noise it measured
    on the native streams in ``meta.extra['sensor_noise']`` (``accel_std``,
    ``gyro_std``, and ``speed_std`` of the ``vx`` column), per tick of the
    drive's clock; it replaces the estimate of :func:`noise_from_drive`.
    """
    given = {k: getattr(cfg, k) for k in NOISE_FLOORS}
    if all(v is not None for v in given.values()):
        return {k: float(v) for k, v in given.items()}
    est = noise_from_drive(drive, speed)
    native = dict(drive.meta.extra.get("sensor_noise", {}) or {})
    if speed_source != "column vx":
        native.pop("speed_std", None)
    for k in NOISE_FLOORS:
        if k in native and np.isfinite(native[k]) and native[k] > 0:
            est[k] = max(float(native[k]), NOISE_FLOORS[k])
    return {k: float(given[k]) if given[k] is not None else est[k] for k in given}


def pose_velocity_noise(drive: Drive, window: float) -> float:
    """Standard deviation [m/s] of the white-noise part of the body velocity differentiated
    from the pose over ``window`` [s].

    A local fit over ``N`` samples ``h`` apart to positions with white noise
    ``s`` (:func:`roadgrip.signals.white_noise_std` of ``x`` and ``y``) has a
    slope error of ``s sqrt(12 / (N (N² - 1))) / h``; a heading noise ``s_psi``
    adds ``|v|`` times the error of the fitted heading, ``1.5 s_psi / sqrt(N)``
    (centre value of a local quadratic fit; the velocity is rotated into the
    body frame with it).
    """
    h = float(np.median(np.diff(drive.t)))
    n = max(round(window / h) | 1, 5)
    s_pos = max(white_noise_std(drive.col("x")), white_noise_std(drive.col("y")))
    s_psi = white_noise_std(np.unwrap(drive.col("psi")))
    v = float(np.percentile(np.abs(drive.col("vx")), 90)) if drive.has("vx") else 0.0
    sd = np.hypot(s_pos * np.sqrt(12.0 / (n * (n * n - 1.0))) / h, 1.5 * v * s_psi / np.sqrt(n))
    return float(sd) if np.isfinite(sd) else float("nan")


POSE_WINDOWS = (0.25, 0.5, 1.0)
"""Candidate differentiation windows [s] of the pose velocity (up to ``pose_window``)."""


def derive_pose_velocity(drive: Drive, speed: NDArray[np.float64], max_window: float
                         ) -> tuple[NDArray, NDArray, float, float] | None:
    """Body velocity from the drive's ``x, y, psi``, the window that fits best, and its error.

    A short window follows fast manoeuvres but passes the position noise; a
    long one averages the noise but bends the velocity of a car that changes
    direction within it. Each window of :data:`POSE_WINDOWS` up to
    ``max_window`` is judged by the error of its ``vx`` against the measured
    speed ``speed`` [m/s] (robust root mean square, which also contains the
    speed sensor's own error, so it errs on the side of caution), at least the
    white-noise level of :func:`pose_velocity_noise`; the window with the
    smallest error is used and that error is the velocity's standard deviation.

    Returns
    -------
    (vx, vy, window, std) or None
        [m/s, m/s, s, m/s]; None when no window gives a finite error.
    """
    best = None
    for w in [w for w in POSE_WINDOWS if w <= max_window + 1e-12] or [max_window]:
        try:
            vx, vy = pose_velocity(drive, window=w)
        except ValueError:
            continue
        e = (vx - speed)[np.isfinite(vx)]
        if len(e) < 20:
            continue
        sd = max(float(np.sqrt(np.median(e * e) / 0.4549)), pose_velocity_noise(drive, w), 0.01)
        if np.isfinite(sd) and (best is None or sd < best[3]):
            best = (vx, vy, w, sd)
    return best


def drive_inputs(drive: Drive, config: CascadeConfig) -> tuple[Inputs, str, float, dict[str, Any]]:
    """The filter inputs of a drive, the speed source's description, its front-wheel share, pose use.

    The accelerations are levelled (:func:`roadgrip.signals.level_accelerations`,
    the vehicle's roll and pitch gradients). The body velocity from the pose is
    the drive's ``vx_pose, vy_pose`` columns; without them, on a drive with
    ``x, y, psi``, it is differentiated here (:func:`derive_pose_velocity`,
    windows up to ``pose_window`` seconds). The fourth value says which (``pose_velocity``:
    ``'columns'``, ``'derived'`` or ``'none'``), with ``pose_velocity_std`` [m/s]
    and ``pose_velocity_corr_time`` [s].

    Raises
    ------
    DriveValidationError
        Missing IMU, steering or speed columns, NaN/inf in them, inf in the pose velocity.
    """
    drive.require("t", "ax", "ay", "yaw_rate", "steer", why="the cascade needs IMU and steering")
    speed, src, share = measured_speed(drive, config.speed_source)
    cols = {c: drive.col(c) for c in ("t", "ax", "ay", "yaw_rate", "steer")}
    cols["speed"] = np.asarray(speed, dtype=float)
    for k, v in cols.items():
        if not np.all(np.isfinite(v)):
            raise DriveValidationError(f"cascade input {k!r} holds NaN/inf")
    cols["ax"], cols["ay"] = level_accelerations(cols["ax"], cols["ay"], drive.vehicle)
    n = len(cols["t"])
    pose: dict[str, Any] = {"pose_velocity": "none", "pose_velocity_std": float(config.pose_velocity_std),
                            "pose_velocity_corr_time": float(config.pose_velocity_corr_time)}
    vxp = vyp = np.full(n, np.nan)
    if config.pose_velocity_std > 0 and drive.has("vx_pose", "vy_pose"):
        vxp, vyp = drive.col("vx_pose"), drive.col("vy_pose")
        pose["pose_velocity"] = "columns"
    elif config.pose_velocity_std > 0 and config.pose_window > 0 and drive.has("x", "y", "psi") and n >= 50:
        got = derive_pose_velocity(drive, cols["speed"], config.pose_window)
        if got is not None:
            vxp, vyp, w, sd = got
            pose.update(pose_velocity="derived", pose_velocity_std=sd, pose_velocity_corr_time=w)
    for c, v in (("vx_pose", vxp), ("vy_pose", vyp)):
        v = np.asarray(v, dtype=float)
        if np.isinf(v).any():
            raise DriveValidationError(f"cascade input {c!r} holds inf (NaN marks a missing pose)")
        cols[c] = v
    # fresh writable C-contiguous copies: one array type for the compiled kernel (drive
    # columns may be read-only views, which numba would compile a second time for)
    arrays = {k: np.array(v, dtype=np.float64, order="C", copy=True) for k, v in cols.items()}
    return Inputs(**arrays), src, share, pose


def drive_pose(drive: Drive) -> tuple[NDArray[np.float64], ...] | None:
    """``(x, y, psi)`` of the drive for the output table, ``(x, y)`` without a heading, None without x, y."""
    if not drive.has("x", "y"):
        return None
    if drive.has("psi"):
        return drive.col("x"), drive.col("y"), drive.col("psi")
    return drive.col("x"), drive.col("y")


def has_standstill(inputs: Inputs, min_duration: float = 1.0) -> bool:
    """True when the speed stays below 0.05 m/s for ``min_duration`` [s] somewhere."""
    still = (np.abs(inputs.speed) < 0.05) & (np.abs(inputs.yaw_rate) < 0.05)
    if not still.any():
        return False
    t = inputs.t
    edges = np.flatnonzero(np.diff(np.concatenate([[0], still.astype(np.int8), [0]])))
    starts, ends = edges[::2], edges[1::2] - 1
    return bool(np.any(t[ends] - t[starts] >= min_duration))
