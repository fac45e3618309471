"""Inputs of the Kalman cascade: the measured speed, the sensor noise and the per-sample records.

Sensor noise
------------
Unless given in :class:`~roadgrip.estimators.cascade.config.CascadeConfig`,
the noise standard deviations of the accelerometers, gyro and speed signal are
taken from the reader (``meta.extra['sensor_noise']``, measured on the native
streams before resampling) or else estimated on the run from the samples so far
(:mod:`~roadgrip.estimators.cascade.running_noise`: robust scale of second
differences, which removes a smooth signal and leaves white noise with variance
``6 s²``). On a signal upsampled by linear interpolation the second differences
vanish between native samples, so the estimate from the drive is then far too
small; the reader's values take precedence (:func:`given_noise`).
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
)

__all__ = [
    "NOISE_FLOORS",
    "NOISE_PRIOR",
    "POSE_WINDOWS",
    "CascadeSample",
    "CascadeSamples",
    "drive_inputs",
    "drive_pose",
    "given_noise",
    "measured_speed",
]

NOISE_FLOORS = {"accel_std": 0.02, "gyro_std": 0.002, "speed_std": 0.01}
"""Smallest noise standard deviations used [m/s², rad/s, m/s]: quantised or interpolated
signals are never trusted absolutely."""

NOISE_PRIOR = {"accel_std": 0.1, "gyro_std": 0.005, "speed_std": 0.05}
"""Noise standard deviations [m/s², rad/s, m/s] before the run has estimated them
(:mod:`~roadgrip.estimators.cascade.running_noise`): an automotive-grade IMU and
wheel-speed signal."""


class CascadeSample(NamedTuple):
    """One sample of the inputs (SI): time, accelerations, yaw rate, steering, measured speed.

    ``vx_pose, vy_pose`` [m/s] are the optional body velocity derived from a
    localisation pose (NaN: none at this sample). ``x, y`` [m] and ``psi``
    [rad] are the pose carried into the output row for mapping (NaN: none).
    ``pose_candidates`` holds, when the cascade differentiates the pose itself, the
    body velocity over each window of ``derived['pose_windows']`` as ``(vx, vy)`` pairs
    [m/s] (the run picks one, :mod:`~roadgrip.estimators.cascade.running_noise`).
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
    pose_candidates: tuple[float, ...] = ()


class CascadeSamples(Sequence[CascadeSample]):
    """The samples of a drive, held as columns (the batch kernel reads them at once).

    Attributes
    ----------
    inputs : Inputs
        The filter inputs, each shape (n,).
    pose : tuple of ndarray or None
        ``(x, y, psi)`` [m, m, rad] for the output table, ``(x, y)`` when the
        drive has no heading, ``None`` when it has no position.
    candidates : ndarray, shape (C, 2, n), or None
        The body velocity ``(vx, vy)`` [m/s] differentiated from the pose over each of
        ``C`` windows (:func:`drive_inputs`); None when the pose velocity is not derived.
    """

    def __init__(self, inputs: Inputs, pose: tuple[NDArray[np.float64], ...] | None,
                 candidates: NDArray[np.float64] | None = None) -> None:
        self.inputs = inputs
        self.pose = pose
        self.candidates = candidates

    def __len__(self) -> int:
        return int(self.inputs.t.shape[0])

    @overload
    def __getitem__(self, k: int) -> CascadeSample: ...
    @overload
    def __getitem__(self, k: slice) -> CascadeSamples: ...

    def __getitem__(self, k: int | slice) -> Any:
        if isinstance(k, slice):
            pose = None if self.pose is None else tuple(a[k] for a in self.pose)
            cand = None if self.candidates is None else np.ascontiguousarray(self.candidates[:, :, k])
            return CascadeSamples(Inputs(*(a[k] for a in self.inputs)), pose, cand)
        nan = float("nan")
        pose = [float(a[k]) for a in self.pose or ()]
        pose += [nan] * (3 - len(pose))
        cand = () if self.candidates is None else tuple(float(v) for v in self.candidates[:, :, k].ravel())
        return CascadeSample(*(float(a[k]) for a in self.inputs), *pose, cand)


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


def given_noise(cfg: CascadeConfig, drive: Drive, speed_source: str = "") -> tuple[dict[str, float], tuple[str, ...]]:
    """Noise standard deviations before the first sample, and the keys estimated on the run.

    Each of ``accel_std, gyro_std, speed_std`` is the configuration's, else the reader's
    (``meta.extra['sensor_noise']``, measured on the native streams before resampling, per
    tick of the drive's clock; ``speed_std`` only for the ``vx`` column), at least
    :data:`NOISE_FLOORS`; else it starts at :data:`NOISE_PRIOR` and is estimated on the
    run from the samples so far (:mod:`~roadgrip.estimators.cascade.running_noise`).

    Returns
    -------
    noise : dict
        ``accel_std`` [m/s²], ``gyro_std`` [rad/s], ``speed_std`` [m/s].
    running : tuple of str
        The keys estimated on the run.
    """
    native = dict(drive.meta.extra.get("sensor_noise", {}) or {})
    if speed_source != "column vx":
        native.pop("speed_std", None)
    noise, running = {}, []
    for k in NOISE_FLOORS:
        given = getattr(cfg, k)
        if given is not None:
            noise[k] = float(given)
        elif k in native and np.isfinite(native[k]) and native[k] > 0:
            noise[k] = max(float(native[k]), NOISE_FLOORS[k])
        else:
            noise[k] = NOISE_PRIOR[k]
            running.append(k)
    return noise, tuple(running)


POSE_WINDOWS = (0.25, 0.5, 1.0)
"""Candidate differentiation windows [s] of the pose velocity (up to ``pose_window``)."""


def drive_inputs(drive: Drive, config: CascadeConfig
                 ) -> tuple[Inputs, str, float, dict[str, Any], NDArray[np.float64] | None]:
    """The filter inputs of a drive, the speed source's description, its front-wheel share, pose use,
    and the candidate pose velocities.

    The accelerations are levelled (:func:`roadgrip.signals.level_accelerations`,
    the vehicle's roll and pitch gradients). The body velocity from the pose is
    the drive's ``vx_pose, vy_pose`` columns; without them, on a drive with
    ``x, y, psi``, it is differentiated here by local quadratic fits centred on each
    sample (:func:`roadgrip.signals.pose_velocity`) over each window of
    :data:`POSE_WINDOWS` up to ``pose_window`` seconds: the fifth value, shape
    ``(C, 2, n)``, ``(vx, vy)`` of each window (None otherwise). Each value depends on
    the pose up to half its window later, the cascade's look-ahead; the run picks the
    window whose velocity has fitted the measured speed best over the samples so far
    (:mod:`~roadgrip.estimators.cascade.running_noise`), the longest one until it knows.
    The fourth value says which (``pose_velocity``: ``'columns'``, ``'derived'`` or
    ``'none'``), with ``pose_velocity_std`` [m/s] (the configured value; for a derived
    velocity only until the run has estimated it), ``pose_velocity_corr_time`` [s] and,
    for a derived one, ``pose_windows`` [s].

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
        if not np.isfinite(v).all():
            raise DriveValidationError(f"cascade input {k!r} holds NaN/inf")
    cols["ax"], cols["ay"] = level_accelerations(cols["ax"], cols["ay"], drive.vehicle)
    n = len(cols["t"])
    pose: dict[str, Any] = {"pose_velocity": "none", "pose_velocity_std": float(config.pose_velocity_std),
                            "pose_velocity_corr_time": float(config.pose_velocity_corr_time)}
    vxp = vyp = np.full(n, np.nan)
    candidates = None
    if config.pose_velocity_std > 0 and drive.has("vx_pose", "vy_pose"):
        vxp, vyp = drive.col("vx_pose"), drive.col("vy_pose")
        pose["pose_velocity"] = "columns"
    elif config.pose_velocity_std > 0 and config.pose_window > 0 and drive.has("x", "y", "psi"):
        windows = [w for w in POSE_WINDOWS if w <= config.pose_window + 1e-12] or [float(config.pose_window)]
        try:
            cand = [pose_velocity(drive, window=w) for w in windows]
        except ValueError:
            cand = []
        if cand:
            candidates = np.ascontiguousarray(np.array(cand, dtype=np.float64))
            if np.isinf(candidates).any():
                raise DriveValidationError("cascade input 'vx_pose' holds inf (NaN marks a missing pose)")
            vxp, vyp = candidates[-1]
            pose.update(pose_velocity="derived", pose_velocity_corr_time=float(windows[-1]),
                        pose_windows=[float(w) for w in windows])
    for c, v in (("vx_pose", vxp), ("vy_pose", vyp)):
        v = np.asarray(v, dtype=float)
        if np.isinf(v).any():
            raise DriveValidationError(f"cascade input {c!r} holds inf (NaN marks a missing pose)")
        cols[c] = v
    # fresh writable C-contiguous copies: one array type for the compiled kernel (drive
    # columns may be read-only views, which numba would compile a second time for)
    arrays = {k: np.array(v, dtype=np.float64, order="C", copy=True) for k, v in cols.items()}
    return Inputs(**arrays), src, share, pose, candidates


def drive_pose(drive: Drive) -> tuple[NDArray[np.float64], ...] | None:
    """``(x, y, psi)`` of the drive for the output table, ``(x, y)`` without a heading, None without x, y."""
    if not drive.has("x", "y"):
        return None
    if drive.has("psi"):
        return drive.col("x"), drive.col("y"), drive.col("psi")
    return drive.col("x"), drive.col("y")
