"""Kinematic front end of the classifiers: friction-independent slips from the sensors.

Both classifiers of paper 002 read the slips and the speed of the kinematic
stage (:mod:`roadgrip.inference.kinematic`, the paper's ref. [26]). This module
runs that stage sample by sample for the online step (:func:`front_step`,
state :class:`FrontState`) and over a block of samples for the batch run
(:func:`front_batch`, from a :class:`FrontState` to the one after the block: a
whole drive is one block, a long drive streamed in chunks one block per chunk);
the two give the same slips, step and kinematic lateral acceleration. Before the
kinematic stage, the accelerometer and the wheel speeds are aligned in time by the
calibration's latency of the wheel speeds (:mod:`roadgrip.estimators.classify.latency`;
``Front.wheel_latency_s``, 0 = as measured).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.estimators.classify.latency import (
    DelayLine,
    aligned_drive,
    delay_channels,
    delayed_columns,
)
from roadgrip.estimators.protocol import DriveInfo, Prepared
from roadgrip.inference.kinematic import (
    KinematicConfig,
    KinematicInput,
    KinematicOutput,
    KinematicState,
    kinematic_init,
    kinematic_lateral_acceleration,
    kinematic_samples,
    kinematic_step,
    kinematics_from,
    resolve_aid,
    select_lateral_acceleration,
)
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "FIRST_STEP_S",
    "KINEMATIC",
    "Front",
    "FrontBatch",
    "FrontState",
    "classifier_info",
    "first_step",
    "front_batch",
    "front_init",
    "front_step",
    "kinematic_samples",
    "prepare_classifier",
    "wheel_latency",
]

KINEMATIC = KinematicConfig()
"""Tuning of the kinematic front end shared by both classifiers."""

FIRST_STEP_S = 0.01
"""Time step [s] assumed for the first sample (no previous sample)."""


@dataclass(frozen=True)
class Front:
    """What the front end needs to know about a drive: vehicle, kinematic tuning, velocity aid.

    Attributes
    ----------
    params : VehicleParams
    kinematic : KinematicConfig
    aid : {'wheels', 'pose'}
        Velocity aid of the kinematic stage, resolved for the drive
        (:func:`roadgrip.inference.kinematic.resolve_aid`).
    lateral_acceleration : {'auto', 'imu', 'kinematic'}
        Source of the lateral acceleration
        (:func:`roadgrip.inference.kinematic.select_lateral_acceleration`).
    wheel_latency_s : float
        Latency of the wheel speeds behind the accelerometer [s], which the front end
        aligns (:func:`roadgrip.estimators.classify.latency.delay_channels`).
    """

    params: VehicleParams
    kinematic: KinematicConfig
    aid: str
    lateral_acceleration: str
    wheel_latency_s: float = 0.0

    @classmethod
    def for_drive(cls, drive: Drive, lateral_acceleration: str,
                  kinematic: KinematicConfig = KinematicConfig(), wheel_latency_s: float = 0.0) -> Front:
        return cls(drive.vehicle, kinematic, resolve_aid(drive, kinematic), lateral_acceleration,
                   float(wheel_latency_s))


class FrontState(NamedTuple):
    """Kinematic stage state, the previous sample time [s] (NaN before the first sample)
    and the delay line of the latency alignment."""

    kin: KinematicState
    t_prev: float
    delay: DelayLine = DelayLine(np.zeros(0), np.zeros((0, 0)))


class FrontBatch(NamedTuple):
    """The front end over a whole drive (arrays with leading axis time, T samples).

    Attributes
    ----------
    kin : KinematicOutput
    ay : ndarray, shape (T,)
        Lateral acceleration the classifier uses [m/s²].
    ax : ndarray, shape (T,)
        Longitudinal acceleration the classifier uses [m/s²] (aligned with the wheel speeds).
    """

    kin: KinematicOutput
    ay: NDArray[np.float64]
    ax: NDArray[np.float64]


def wheel_latency(config: Any) -> float:
    """The latency of the wheel speeds a classifier's configuration aligns [s]: its saturation
    model's ``wheel_latency_s`` (0 without a model)."""
    grip = getattr(config, "grip", None)
    return float(grip.wheel_latency_s) if grip is not None else 0.0


def front_init() -> FrontState:
    """State before the first sample."""
    return FrontState(kinematic_init(), math.nan)


def _aligned_sample(state: FrontState, sample: KinematicInput, latency: float) -> tuple[KinematicInput, DelayLine]:
    """The sample with its earlier channel delayed (:func:`~roadgrip.estimators.classify.latency.delay_channels`)."""
    cols = delayed_columns(latency)
    if not cols:
        return sample, state.delay
    t = np.array([float(sample.t)])
    if cols == ("ax",):
        v, line = delay_channels(state.delay, t, np.array([[float(sample.ax)]]), latency)
        return sample._replace(ax=float(v[0, 0])), line
    v, line = delay_channels(state.delay, t, np.asarray(sample.omega, float).reshape(1, -1), latency)
    return sample._replace(omega=v[0].copy()), line


def front_step(
    state: FrontState, sample: KinematicInput, front: Front
) -> tuple[FrontState, KinematicOutput, float, float, float]:
    """Run the kinematic stage on one sample (pure).

    Returns
    -------
    state : FrontState
    kin : KinematicOutput
        Scalars for this sample.
    dt : float
        Step since the previous sample [s] (:data:`FIRST_STEP_S` at the first).
    ay : float
        Lateral acceleration the classifier uses [m/s²]: the accelerometer's or
        the kinematic ``r vx + dvy/dt`` (same backward difference as
        :func:`roadgrip.inference.kinematic.kinematic_lateral_acceleration`).
    ax : float
        Longitudinal acceleration the classifier uses [m/s²] (aligned).
    """
    sample, line = _aligned_sample(state, sample, front.wheel_latency_s)
    prev = state.kin
    kst, kin = kinematic_step(prev, sample, front.params, front.kinematic, aid=front.aid)
    dt = FIRST_STEP_S if math.isnan(state.t_prev) else float(sample.t) - state.t_prev
    dvy = (float(kin.vy) - prev.vy) / dt if prev.started else 0.0
    ay_kin = float(sample.yaw_rate) * float(kin.vx) + dvy
    ay = float(select_lateral_acceleration(front.lateral_acceleration, front.aid, float(sample.ay), ay_kin))
    return FrontState(kst, float(sample.t), line), kin, dt, ay, float(sample.ax)


def first_step(state: FrontState, t0: float) -> float:
    """Step before a block's first sample at ``t0`` [s]: from the previous sample, or
    :data:`FIRST_STEP_S` at the start of the drive."""
    return FIRST_STEP_S if math.isnan(state.t_prev) else float(t0) - state.t_prev


def front_batch(drive: Drive, front: Front, state: FrontState | None = None) -> tuple[FrontBatch, FrontState]:
    """The kinematic stage and the lateral acceleration over a block of samples (equals stepping).

    Parameters
    ----------
    drive : Drive
        The block (a whole drive, or a chunk of one whose samples follow ``state``'s).
    front : Front
    state : FrontState, optional
        State before the block (default :func:`front_init`, the start of a drive).

    Returns
    -------
    batch : FrontBatch
    state : FrontState
        After the block's last sample: the next block of the drive continues from it.
    """
    state = state if state is not None else front_init()
    prev = state.kin
    drive, line = aligned_drive(drive, front.wheel_latency_s, state.delay)
    kin, end = kinematics_from(prev, drive, front.kinematic)
    r = drive.col("yaw_rate")
    if prev.started:  # dvy/dt of the first sample from the previous block's last
        ay_kin = kinematic_lateral_acceleration(
            np.r_[prev.t, drive.t], np.r_[prev.vx, kin.vx], np.r_[prev.vy, kin.vy], np.r_[0.0, r])[1:]
    else:
        ay_kin = kinematic_lateral_acceleration(drive.t, kin.vx, kin.vy, r)
    ay = np.asarray(select_lateral_acceleration(front.lateral_acceleration, front.aid, drive.col("ay"),
                                                ay_kin), float)
    return FrontBatch(kin, ay, drive.col("ax")), FrontState(end, float(drive.t[-1]), line)


def classifier_info(drive: Drive, lateral_acceleration: str) -> DriveInfo:
    """What a classifier derives from a drive before its first sample: the velocity aid
    (``derived['aid']``, from the columns present: a chunk of a drive gives the drive's)."""
    return DriveInfo.from_drive(drive, aid=Front.for_drive(drive, lateral_acceleration, KINEMATIC).aid)


def prepare_classifier(drive: Drive, lateral_acceleration: str) -> Prepared:
    """A classifier's ``prepare``: the drive's info (velocity aid in ``derived['aid']``) and
    its kinematic samples."""
    return Prepared(classifier_info(drive, lateral_acceleration), kinematic_samples(drive))
