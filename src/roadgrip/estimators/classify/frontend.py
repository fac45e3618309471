"""Kinematic front end of the classifiers: friction-independent slips from the sensors.

Both classifiers of paper 002 read the slips and the speed of the kinematic
stage (:mod:`roadgrip.inference.kinematic`, the paper's ref. [26]). This module
runs that stage sample by sample for the online step (:func:`front_step`,
state :class:`FrontState`) and over a block of samples for the batch run
(:func:`front_batch`, from a :class:`FrontState` to the one after the block: a
whole drive is one block, a long drive streamed in chunks one block per chunk);
the two give the same slips, step and kinematic lateral acceleration.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive
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
    """

    params: VehicleParams
    kinematic: KinematicConfig
    aid: str
    lateral_acceleration: str

    @classmethod
    def for_drive(cls, drive: Drive, lateral_acceleration: str,
                  kinematic: KinematicConfig = KinematicConfig()) -> Front:
        return cls(drive.vehicle, kinematic, resolve_aid(drive, kinematic), lateral_acceleration)


class FrontState(NamedTuple):
    """Kinematic stage state and the previous sample time [s] (NaN before the first sample)."""

    kin: KinematicState
    t_prev: float


class FrontBatch(NamedTuple):
    """The front end over a whole drive (arrays with leading axis time, T samples).

    Attributes
    ----------
    kin : KinematicOutput
    ay : ndarray, shape (T,)
        Lateral acceleration the classifier uses [m/s²].
    """

    kin: KinematicOutput
    ay: NDArray[np.float64]


def front_init() -> FrontState:
    """State before the first sample."""
    return FrontState(kinematic_init(), math.nan)


def front_step(
    state: FrontState, sample: KinematicInput, front: Front
) -> tuple[FrontState, KinematicOutput, float, float]:
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
    """
    prev = state.kin
    kst, kin = kinematic_step(prev, sample, front.params, front.kinematic, aid=front.aid)
    dt = FIRST_STEP_S if math.isnan(state.t_prev) else float(sample.t) - state.t_prev
    dvy = (float(kin.vy) - prev.vy) / dt if prev.started else 0.0
    ay_kin = float(sample.yaw_rate) * float(kin.vx) + dvy
    ay = float(select_lateral_acceleration(front.lateral_acceleration, front.aid, float(sample.ay), ay_kin))
    return FrontState(kst, float(sample.t)), kin, dt, ay


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
    prev = (state if state is not None else front_init()).kin
    kin, end = kinematics_from(prev, drive, front.kinematic)
    r = drive.col("yaw_rate")
    if prev.started:  # dvy/dt of the first sample from the previous block's last
        ay_kin = kinematic_lateral_acceleration(
            np.r_[prev.t, drive.t], np.r_[prev.vx, kin.vx], np.r_[prev.vy, kin.vy], np.r_[0.0, r])[1:]
    else:
        ay_kin = kinematic_lateral_acceleration(drive.t, kin.vx, kin.vy, r)
    ay = np.asarray(select_lateral_acceleration(front.lateral_acceleration, front.aid, drive.col("ay"),
                                                ay_kin), float)
    return FrontBatch(kin, ay), FrontState(end, float(drive.t[-1]))


def classifier_info(drive: Drive, lateral_acceleration: str) -> DriveInfo:
    """What a classifier derives from a drive before its first sample: the velocity aid
    (``derived['aid']``, from the columns present: a chunk of a drive gives the drive's)."""
    return DriveInfo.from_drive(drive, aid=Front.for_drive(drive, lateral_acceleration, KINEMATIC).aid)


def prepare_classifier(drive: Drive, lateral_acceleration: str) -> Prepared:
    """A classifier's ``prepare``: the drive's info (velocity aid in ``derived['aid']``) and
    its kinematic samples."""
    return Prepared(classifier_info(drive, lateral_acceleration), kinematic_samples(drive))
