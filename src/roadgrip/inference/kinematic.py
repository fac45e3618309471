r"""Friction-independent kinematic state estimation: speed, sideslip and tire slips.

The upstream stage of the paper 002 classifiers (its ref. [26], Selmanaj et al.,
"Vehicle sideslip estimation: a kinematic based approach", 2017): nothing here
uses a tire model or the friction, so the classifiers' inputs do not depend on
the quantity they classify. Other estimators can reuse it.

Model (body axes, ISO 8855; ``ax``, ``ay`` the accelerometer specific force)::

    d vx / dt = ax + r vy          d vy / dt = ay - r vx

with ``ax``, ``ay`` levelled first by the vehicle's pitch and roll gradients (the
factors of :func:`roadgrip.signals.level_accelerations`: a body pitched by braking
leaks gravity into ``ax``, which on the multi-body van drifted the coasting speed
by 0.4 m/s over a 1.2 s stop from 22 m/s, and 0.03 m/s once levelled), integrated
with forward Euler at the sample times and corrected by
complementary-filter gains (``k = dt / tau``, at most 1) from:

* **wheel speeds** (speed). Each measured wheel speed ``R omega`` is moved to the
  CG (track offset ``-/+ r w / 2`` for left/right, the steering rotation for the
  front wheels). Robust selection against spin and braking slip: in traction
  (``ax > accel_threshold``) the undriven wheels are used, or the slowest wheel
  when all are driven; in braking (``ax < -accel_threshold``) all wheels slip,
  so none is used and the speed coasts on the accelerometer (a braking
  manoeuvre lasts seconds, over which the integrated accelerometer drifts far
  less than the braking slip of the wheels); otherwise the mean. A selected speed that disagrees with the
  prediction by more than ``gate_abs + gate_rel |vx|`` is treated as slip and
  ignored (the estimate then coasts on ``ax``).
* **pose** (speed and lateral velocity), when the drive carries a map pose
  ``x, y, psi`` (motion capture, RTK GNSS): the body velocity from the
  backward difference of consecutive poses. Used when ``velocity_aid`` is
  ``'pose'``, or ``'auto'`` and not all four wheel speeds are present.
* **sideslip drift correction** (lateral velocity, without pose): the
  integrated ``vy`` is pulled towards the zero-rear-slip value ``lr r`` with a
  weight ``exp(-(ay / a_linear)^2)``, i.e. only in quasi-linear driving where
  the rear slip angle is small for any friction, which removes the integration
  drift without assuming a tire stiffness. Below ``v_min`` the lateral velocity
  relaxes to zero.

Slips from the estimated state: per-wheel longitudinal slip (paper 002 eq. 2,
:func:`roadgrip.vehicle.slip.longitudinal_slip`, wheel-frame speeds including
track and steering) and axle slip angles (eq. 3, :func:`roadgrip.vehicle.slip.slip_angles`,
roadgrip sign convention: positive alpha gives positive lateral force).

**Kinematic lateral acceleration** (:func:`kinematic_lateral_acceleration`):
``ay_kin = r vx + dvy/dt`` with the backward difference of the estimated ``vy``.
It is the CG lateral acceleration by definition (body-frame kinematics), and
with the pose aid (tau_pose shorter than the sample step) it comes from the
gyro and the pose alone, independent of the accelerometer. The classifiers use
it in place of the accelerometer's ``ay`` when the pose aid runs
(:func:`select_lateral_acceleration`, source ``'auto'``): on the DART car the
accelerometer's ``ay`` scatters by 1.6-5 m/s² (standard deviation of
``ay - ay_kin`` over a run) around it, mostly chassis vibration sampled at
10 Hz, whereas ``r vx`` needs no differentiation in steady cornering. Without
a pose, ``ay_kin`` is the accelerometer's ``ay`` plus the drift correction and
brings nothing new, so ``'auto'`` keeps the accelerometer.

The per-sample update is one compiled function
(:func:`roadgrip.inference.kinematic_kernel.kinematic_update`) used by both
the online step and the batch loop, so ``run`` equals stepping exactly. The
batch loop starts from a given state and returns the state after its last
sample (:func:`kinematics_from`): a long drive runs in consecutive blocks with
the estimates of one run over the whole drive.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import V_EPS
from roadgrip.drive import WHEEL_COLUMNS, Drive
from roadgrip.inference.kinematic_kernel import (
    AID_CODES,
    KinematicInput,
    KinematicParams,
    KinematicSeries,
    KinematicState,
    kinematic_batch,
    kinematic_update,
)
from roadgrip.signals import tilt_gains
from roadgrip.vehicle.params import VehicleParams, driven_wheels
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles

__all__ = [
    "LATERAL_ACCELERATION_SOURCES",
    "KinematicConfig",
    "KinematicEstimator",
    "KinematicInput",
    "KinematicOutput",
    "KinematicState",
    "drive_lateral_acceleration",
    "estimate_kinematics",
    "inputs_from_drive",
    "kinematic_init",
    "kinematic_lateral_acceleration",
    "kinematic_params",
    "kinematic_samples",
    "kinematic_step",
    "kinematics_from",
    "resolve_aid",
    "select_lateral_acceleration",
    "slip_v_eps",
    "wheel_slips",
]


@dataclass(frozen=True)
class KinematicConfig:
    """Tuning of the kinematic estimator (all SI).

    Attributes
    ----------
    velocity_aid : {'auto', 'wheels', 'pose'}
        Source of the speed correction (module docstring).
    tau_vx : float
        Time constant of the wheel-speed correction [s].
    tau_pose : float
        Time constant of the pose-velocity correction of ``vx`` and ``vy`` [s].
    tau_beta : float
        Time constant of the quasi-linear sideslip drift correction [s].
    a_linear : float
        Lateral acceleration scale of the quasi-linear region [m/s²].
    accel_threshold : float
        ``|ax|`` above which the vehicle counts as driving or braking [m/s²].
    gate_abs, gate_rel : float
        Slip gate on the wheel-speed innovation: ``gate_abs`` [m/s] + ``gate_rel`` [-] times speed.
    v_min : float
        Speed below which the lateral velocity relaxes to zero [m/s].
    v_eps : float or None
        Low-speed regularisation of the slips [m/s]; ``None`` uses
        :data:`roadgrip.constants.V_EPS` for wheelbases of 1 m and more and one
        tenth of it for model-scale cars (whose speeds are a few m/s).
    """

    velocity_aid: str = "auto"
    tau_vx: float = 0.3
    tau_pose: float = 0.05
    tau_beta: float = 1.0
    a_linear: float = 1.5
    accel_threshold: float = 0.5
    gate_abs: float = 0.3
    gate_rel: float = 0.05
    v_min: float = 0.2
    v_eps: float | None = None

    def __post_init__(self) -> None:
        if self.velocity_aid not in ("auto", "wheels", "pose"):
            raise ValueError(
                f"velocity_aid must be 'auto', 'wheels' or 'pose', got {self.velocity_aid!r}"
            )
        for name in ("tau_vx", "tau_pose", "tau_beta", "a_linear", "accel_threshold", "v_min"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be positive, got {v!r}")
        for name in ("gate_abs", "gate_rel"):
            v = getattr(self, name)
            if not np.isfinite(v) or v < 0:
                raise ValueError(f"{name} must be >= 0, got {v!r}")


class KinematicOutput(NamedTuple):
    """Estimates of one sample (or arrays of them, leading axis time).

    Attributes
    ----------
    vx, vy : float [m/s]
    beta : float
        Sideslip ``arctan(vy / vx)`` [rad].
    kappa : ndarray, shape (4,) or (T, 4)
        Longitudinal slip ``fl, fr, rl, rr`` [-], 0 where the wheel speed is absent.
    alpha_f, alpha_r : float
        Axle slip angles [rad].
    wheels_valid : ndarray of bool, shape (4,) or (T, 4)
        Which wheel speeds were measured.
    """

    vx: float | NDArray[np.float64]
    vy: float | NDArray[np.float64]
    beta: float | NDArray[np.float64]
    kappa: NDArray[np.float64]
    alpha_f: float | NDArray[np.float64]
    alpha_r: float | NDArray[np.float64]
    wheels_valid: NDArray[np.bool_]


def _aid(cfg: KinematicConfig, have_all_wheels: bool, have_pose: bool) -> str:
    if cfg.velocity_aid == "pose":
        if not have_pose:
            raise ValueError("velocity_aid='pose' needs the pose columns x, y, psi")
        return "pose"
    if cfg.velocity_aid == "wheels":
        return "wheels"
    return "pose" if (have_pose and not have_all_wheels) else "wheels"


@functools.lru_cache(maxsize=64)
def kinematic_params(params: VehicleParams, cfg: KinematicConfig, aid: str) -> KinematicParams:
    """The compiled update's parameters for a vehicle, tuning and resolved velocity aid
    (cached: the online step asks at every sample; the record is not to be modified)."""
    return KinematicParams(
        AID_CODES[aid], driven_wheels(params.drive).astype(np.int64), params.wheel_radius,
        params.lf, params.lr, 0.5 * params.track_width, cfg.tau_vx, cfg.tau_pose, cfg.tau_beta,
        cfg.a_linear, cfg.accel_threshold, cfg.gate_abs, cfg.gate_rel, cfg.v_min,
        *tilt_gains(params),
    )


def kinematic_init() -> KinematicState:
    """The state before the first sample (initialised from the first measurement)."""
    nan = float("nan")
    return KinematicState(0.0, 0.0, nan, nan, nan, nan, False)


def wheel_slips(
    vx: NDArray, vy: NDArray, yaw_rate: NDArray, steer: NDArray, omega: NDArray,
    params: VehicleParams,
    *,
    v_eps: float = V_EPS,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per-wheel longitudinal slips (eq. 2) and axle slip angles (eq. 3), vectorised.

    Parameters
    ----------
    vx, vy, yaw_rate, steer : ndarray, shape (T,)
        CG velocity [m/s], yaw rate [rad/s], front road-wheel angle [rad].
    omega : ndarray, shape (T, 4)
        Wheel speeds ``fl, fr, rl, rr`` [rad/s], NaN where absent.
    params : VehicleParams
    v_eps : float
        Low-speed regularisation of the slips [m/s].

    Returns
    -------
    kappa : ndarray, shape (T, 4)
        Slip ratio per wheel [-], 0 where the wheel speed is absent.
    alpha_f, alpha_r : ndarray, shape (T,)
        Axle slip angles [rad] (roadgrip sign convention).
    """
    vx = np.asarray(vx, float)
    vy = np.asarray(vy, float)
    r = np.asarray(yaw_rate, float)
    d = np.asarray(steer, float)
    h = 0.5 * params.track_width
    # wheel-centre longitudinal speed in each wheel's frame
    vl, vr = vx - r * h, vx + r * h
    lat_f = vy + params.lf * r
    cos_d, sin_d = np.cos(d), np.sin(d)
    front_left = vl * cos_d + lat_f * sin_d
    v_wheel = np.empty((*np.shape(front_left), 4))
    v_wheel[..., 0] = front_left
    v_wheel[..., 1] = vr * cos_d + lat_f * sin_d
    v_wheel[..., 2] = vl
    v_wheel[..., 3] = vr
    omega = np.asarray(omega, float)
    measured = np.isfinite(omega)
    kappa = longitudinal_slip(np.where(measured, omega, 0.0), v_wheel, params.wheel_radius, v_eps=v_eps)
    kappa = np.where(measured, kappa, 0.0)
    a_f, a_r = slip_angles(vx, vy, r, d, params, v_eps=v_eps)
    return kappa, a_f, a_r


def slip_v_eps(params: VehicleParams, config: KinematicConfig) -> float:
    """The slip regularisation speed for this vehicle [m/s] (``KinematicConfig.v_eps``)."""
    if config.v_eps is not None:
        return float(config.v_eps)
    return V_EPS if params.lf + params.lr >= 1.0 else 0.1 * V_EPS


def _output(vx, vy, r, steer, omega, params, config) -> KinematicOutput:
    kappa, a_f, a_r = wheel_slips(vx, vy, r, steer, omega, params, v_eps=slip_v_eps(params, config))
    beta = np.arctan2(vy, np.abs(vx) + 1e-9)
    return KinematicOutput(vx, vy, beta, kappa, a_f, a_r, np.isfinite(omega))


def kinematic_step(
    state: KinematicState,
    sample: KinematicInput,
    params: VehicleParams,
    config: KinematicConfig = KinematicConfig(),
    *,
    aid: str = "wheels",
) -> tuple[KinematicState, KinematicOutput]:
    """One online update (pure).

    Parameters
    ----------
    state : KinematicState
    sample : KinematicInput
    params : VehicleParams
    config : KinematicConfig
    aid : {'wheels', 'pose'}
        Resolved velocity aid (``'auto'`` is resolved once per drive by the caller;
        :class:`KinematicEstimator` does it).

    Returns
    -------
    state : KinematicState
    output : KinematicOutput
        Scalars for this sample (``kappa`` shape (4,)).
    """
    if state.started and not sample.t > state.t:
        raise ValueError(f"time must increase: got t = {sample.t} after {state.t}")
    omega = np.asarray(sample.omega, dtype=float)
    if omega.shape != (4,):
        raise ValueError(f"omega must have shape (4,), got {omega.shape}")
    s = KinematicInput(
        float(sample.t), float(sample.ax), float(sample.ay), float(sample.yaw_rate),
        float(sample.steer), omega, float(sample.x), float(sample.y), float(sample.psi),
        float(sample.vx_meas),
    )
    st = KinematicState(float(state.vx), float(state.vy), float(state.t), float(state.x),
                        float(state.y), float(state.psi), bool(state.started))
    vx, vy = kinematic_update(st, s, kinematic_params(params, config, aid))
    new = KinematicState(vx, vy, float(sample.t), float(sample.x), float(sample.y),
                         float(sample.psi), True)
    out = _output(np.asarray(vx), np.asarray(vy), np.asarray(sample.yaw_rate),
                  np.asarray(sample.steer), omega, params, config)
    out = KinematicOutput(float(out.vx), float(out.vy), float(out.beta), out.kappa,
                          float(out.alpha_f), float(out.alpha_r), out.wheels_valid)
    return new, out


def inputs_from_drive(drive: Drive) -> dict[str, NDArray[np.float64]]:
    """The estimator's input arrays from a drive (NaN for absent optional signals).

    Raises
    ------
    DriveValidationError
        When ``ax``, ``ay``, ``yaw_rate`` or ``steer`` are missing, or when the
        drive has neither wheel speeds, nor a pose, nor a ``vx`` column.
    """
    drive.require("ax", "ay", "yaw_rate", "steer", why="kinematic state estimation")
    n = drive.n
    nan = np.full(n, np.nan)
    omega = np.empty((n, len(WHEEL_COLUMNS)))
    for i, c in enumerate(WHEEL_COLUMNS):
        omega[:, i] = drive.col(c) if drive.has(c) else nan
    has_pose, has_vx = drive.has_pose, drive.has("vx")
    pose = {c: (drive.col(c) if has_pose else nan) for c in ("x", "y", "psi")}
    vxm = drive.col("vx") if has_vx else nan
    if not has_pose and not has_vx and not np.isfinite(omega).any():
        from roadgrip.drive import DriveValidationError

        raise DriveValidationError(
            f"drive from {drive.meta.source} has no wheel speeds, pose or vx: "
            "the vehicle speed cannot be estimated"
        )
    return {
        "t": drive.t, "ax": drive.col("ax"), "ay": drive.col("ay"),
        "yaw_rate": drive.col("yaw_rate"), "steer": drive.col("steer"),
        "omega": omega, **pose, "vx_meas": vxm,
    }


def resolve_aid(drive: Drive, config: KinematicConfig) -> str:
    """``'wheels'`` or ``'pose'`` for this drive (see ``KinematicConfig.velocity_aid``)."""
    return _aid(config, drive.has_wheel_speeds, drive.has_pose)


def estimate_kinematics(
    drive: Drive, config: KinematicConfig = KinematicConfig()
) -> KinematicOutput:
    """Batch estimate over a whole drive (compiled loop; equals stepping).

    Returns
    -------
    KinematicOutput
        Arrays with leading axis time (``kappa`` shape (T, 4)).
    """
    return kinematics_from(kinematic_init(), drive, config)[0]


def kinematics_from(
    state: KinematicState, drive: Drive, config: KinematicConfig = KinematicConfig()
) -> tuple[KinematicOutput, KinematicState]:
    """Batch estimate over a block of a drive from ``state`` (compiled loop; equals stepping).

    A drive in consecutive blocks, each started from the state the block before
    ended in (the first from :func:`kinematic_init`), gives the estimates of the
    whole drive in one block: memory follows the block, not the drive.

    Parameters
    ----------
    state : KinematicState
        State before the block's first sample (its time earlier than the block's).
    drive : Drive
        The block's samples.
    config : KinematicConfig

    Returns
    -------
    output : KinematicOutput
        Arrays with leading axis time (``kappa`` shape (T, 4)).
    state : KinematicState
        After the block's last sample.
    """
    a = inputs_from_drive(drive)
    if state.started and not a["t"][0] > state.t:
        raise ValueError(f"time must increase: the block starts at t = {a['t'][0]} after {state.t}")
    aid = resolve_aid(drive, config)
    st = KinematicState(float(state.vx), float(state.vy), float(state.t), float(state.x),
                        float(state.y), float(state.psi), bool(state.started))
    vx, vy, end = kinematic_batch(KinematicSeries(**a), kinematic_params(drive.vehicle, config, aid), st)
    out = _output(vx, vy, a["yaw_rate"], a["steer"], a["omega"], drive.vehicle, config)
    return out, KinematicState(*end)


class KinematicEstimator:
    """Online wrapper: ``step(sample) -> KinematicOutput``, ``run(drive) -> KinematicOutput``.

    Parameters
    ----------
    params : VehicleParams
    config : KinematicConfig
    aid : {'wheels', 'pose'}
        Velocity aid for :meth:`step`; :meth:`run` resolves ``config.velocity_aid`` per drive.
    """

    def __init__(
        self, params: VehicleParams, config: KinematicConfig = KinematicConfig(), aid: str = "wheels"
    ) -> None:
        if aid not in AID_CODES:
            raise ValueError(f"aid must be 'wheels' or 'pose', got {aid!r}")
        self.params = params
        self.config = config
        self.aid = aid
        self.state = kinematic_init()

    def step(self, sample: KinematicInput) -> KinematicOutput:
        self.state, out = kinematic_step(self.state, sample, self.params, self.config, aid=self.aid)
        return out

    def run(self, drive: Drive) -> KinematicOutput:
        return estimate_kinematics(drive, self.config)



def kinematic_samples(drive: Drive) -> list[KinematicInput]:
    """The drive as :class:`KinematicInput` samples (for :func:`kinematic_step`)."""
    a = inputs_from_drive(drive)
    return [
        KinematicInput(
            float(a["t"][i]), float(a["ax"][i]), float(a["ay"][i]), float(a["yaw_rate"][i]),
            float(a["steer"][i]), a["omega"][i], float(a["x"][i]), float(a["y"][i]),
            float(a["psi"][i]), float(a["vx_meas"][i]),
        )
        for i in range(drive.n)
    ]


LATERAL_ACCELERATION_SOURCES = ("auto", "imu", "kinematic")
"""Lateral acceleration fed to the classifiers (:func:`select_lateral_acceleration`)."""


def kinematic_lateral_acceleration(
    t: NDArray, vx: NDArray, vy: NDArray, yaw_rate: NDArray
) -> NDArray[np.float64]:
    """CG lateral acceleration from the estimated velocity: ``r vx + dvy/dt``.

    Body-frame kinematics (ISO 8855): ``ay = dvy/dt + r vx``. ``dvy/dt`` is the
    backward difference of ``vy`` (causal, as in the online step); it is 0 at
    the first sample.

    Parameters
    ----------
    t : ndarray, shape (T,)
        Sample times [s], strictly increasing.
    vx, vy : ndarray, shape (T,)
        Estimated CG velocity [m/s] (:class:`KinematicOutput`).
    yaw_rate : ndarray, shape (T,)
        [rad/s].

    Returns
    -------
    ndarray, shape (T,)
        [m/s²].
    """
    t = np.asarray(t, float)
    vy = np.asarray(vy, float)
    dvy = np.zeros_like(vy)
    if vy.size > 1:
        dvy[1:] = np.diff(vy) / np.diff(t)
    return np.asarray(yaw_rate, float) * np.asarray(vx, float) + dvy


def select_lateral_acceleration(
    source: str, aid: str, ay_imu: NDArray | float, ay_kin: NDArray | float
) -> NDArray[np.float64] | float:
    """The lateral acceleration a classifier uses.

    Parameters
    ----------
    source : {'auto', 'imu', 'kinematic'}
        ``'imu'`` the accelerometer, ``'kinematic'`` :func:`kinematic_lateral_acceleration`,
        ``'auto'`` the kinematic one when the velocity aid is the pose (module
        docstring), else the accelerometer.
    aid : {'wheels', 'pose'}
        The resolved velocity aid of the kinematic stage.
    ay_imu, ay_kin : float or ndarray
        [m/s²].
    """
    if source not in LATERAL_ACCELERATION_SOURCES:
        raise ValueError(
            f"lateral acceleration source must be one of {LATERAL_ACCELERATION_SOURCES}, "
            f"got {source!r}"
        )
    if source == "kinematic" or (source == "auto" and aid == "pose"):
        return ay_kin
    return ay_imu


def drive_lateral_acceleration(
    drive: Drive, kin: KinematicOutput, source: str, config: KinematicConfig = KinematicConfig()
) -> NDArray[np.float64]:
    """:func:`select_lateral_acceleration` over a whole drive, shape (T,) [m/s²].

    ``kin`` is :func:`estimate_kinematics` of ``drive`` with ``config``.
    """
    ay_kin = kinematic_lateral_acceleration(drive.t, kin.vx, kin.vy, drive.col("yaw_rate"))
    return np.asarray(select_lateral_acceleration(source, resolve_aid(drive, config),
                                                  drive.col("ay"), ay_kin), float)
