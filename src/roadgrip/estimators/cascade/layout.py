"""Layouts of the compiled cascade: filter memory, output row, constants, weights, state and inputs.

The filter state is a :class:`Filter` of arrays updated in place by the
compiled functions (:mod:`~roadgrip.estimators.cascade.kernel`); the
constants are a :class:`Params` and the unscented weights a :class:`Weights`.
One output row per sample has the layout :class:`Out`.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["Aux", "Filter", "Inputs", "Out", "Params", "Weights"]


class Aux(IntEnum):
    """Layout of the auxiliary filter memory (``Filter.aux``)."""

    AX_PREV = 0  # ax of the previous sample [m/s²] (trapezoid rule of stage 1)
    AY_PREV = 1  # ay of the previous sample [m/s²]
    YAW_RATE_PREV = 2  # yaw rate of the previous sample [rad/s]
    CONSIST_R = 3  # running mean square of the rear slip-angle consistency residual [rad²]
    CONSIST_F = 4  # the same, front [rad²]
    STEER_LP = 5  # low-passed steering angle [rad] (NaN before the first sample)
    CONSIST_W_R = 6  # weight of the evidence in CONSIST_R, 1 - exp(-time in the band / tau) [-]
    CONSIST_W_F = 7  # the same, front [-]
    POSE_VY_BIAS = 8  # running mean of the stage-2 vy minus the pose's vy [m/s], started from 0
    POSE_W = 9  # weight of the evidence in POSE_VY_BIAS, 1 - exp(-time with a pose / tau) [-]
    AY_LP = 10  # running mean of the bias-corrected ay [m/s²] (NaN before the first sample)
    AY_DEV = 11  # ay minus that running mean at the last sample [m/s²]
    SIZE = 12


class Out(IntEnum):
    """Layout of one output row of the compiled step."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    FXF = 3
    FYF = 4
    FYR = 5
    ALPHA_F = 6
    ALPHA_R = 7
    FZF = 8
    FZR = 9
    MU_F = 10
    MU_R = 11
    VAR_F = 12
    VAR_R = 13
    EXC_F = 14
    EXC_R = 15
    OBS_F = 16
    OBS_R = 17
    OBS_VAR_F = 18
    OBS_VAR_R = 19
    NIS2 = 20
    REPAIRS = 21
    VX_EKF = 22
    VY_EKF = 23
    PD_OK = 24
    FYF_VAR = 25
    FYR_VAR = 26
    ALPHA_F_VAR = 27
    ALPHA_R_VAR = 28
    R3_F = 29
    R3_R = 30
    SYS_F = 31
    SYS_R = 32
    FX_F = 33
    FX_R = 34
    SIZE = 35


class Params(NamedTuple):
    """Constants of the compiled step (SI units; variances of white noise per sample unless noted)."""

    mass: float  # [kg]
    iz: float  # yaw inertia [kg m²]
    lf: float  # CG to front axle [m]
    lr: float  # CG to rear axle [m]
    h: float  # CG height [m]
    kf: float  # normalised cornering stiffness C_f / Fz_f,static [1/rad]
    kr: float  # the same, rear
    var_acc: float  # accelerometer noise variance [m²/s⁴]
    var_gyro: float  # gyro noise variance [rad²/s²]
    var_speed: float  # speed-measurement noise variance [m²/s²]
    var_steer: float  # steering-angle noise variance [rad²]
    var_acc_model: float  # accelerometer model-error variance [m²/s⁴]
    q_force: float  # force-rate variance (m j)² [N²/s²]
    q_yaw: float  # yaw-acceleration variance [rad²/s⁴]
    q_mu: float  # friction random-walk variance per second [1/s]
    mu_var0: float  # prior friction variance, the cap of its growth [-]
    mu_min: float  # physical friction range [-]
    mu_max: float
    model_err: float  # brush-model error as a fraction of the normal load [-]
    exc_prec: float  # excitation threshold, precision per second [1/s]
    v_min: float  # no friction update below this speed [m/s]
    v_eps: float  # slip-angle speed regularisation [m/s]
    front_share: float  # share of steered wheels in the speed measurement [-]
    slip_bias: float  # slip-angle bias [rad]
    max_bias: float  # largest friction shift a slip-angle error may cause [-]
    cr: float  # rear cornering stiffness [N/rad]
    ay_straight: float  # straight-driving lateral acceleration threshold [m/s²]
    q_bias: float  # accelerometer-bias random-walk variance per second [m²/s⁵]
    steer_bias: float  # steering-angle bias [rad]
    vy_bias: float  # lateral-velocity bias [m/s]
    consist_tau: float  # time constant of the slip-angle consistency mean square [s]
    consist_prior: float  # slip-angle error variance assumed before the consistency evidence [rad²]
    consist_prior_w: float  # its weight, in units of the evidence weight (prior time / tau) [-]
    pose_check_tau: float  # time constant of the running mean of vy against the pose's [s]
    var_pose: float  # pose-velocity variance [m²/s²] times its correlation time [s]
    var_latency: float  # variance of the accelerometer's latency behind the gyro's [s²]
    slip_z: float  # slip-angle noise test, in standard deviations [-]
    steer_tau: float  # steering-actuator time constant [s] (0: measured angle)
    mu_prior: float  # prior friction mean [-], which the state returns to over distance
    mu_length: float  # friction correlation length [m] (inf: no return to the prior)
    traction_front: float  # share of a driving force on the front axle [-] (NaN: by axle load)
    speed_slip_brake: float  # wheel slip of the measured wheels per braking deceleration [s²/m]
    speed_slip_drive: float  # the same per driving acceleration (0 for undriven wheels) [s²/m]
    max_slip_ratio: float  # observations only up to this multiple of the sliding slip angle [-]
    peak_model_error: float  # relative error of the brush model's friction on another tire [-]


class Weights(NamedTuple):
    """Unscented weights and scales of stage 2 (6 states) and stage 3 (2 states)."""

    wm6: NDArray[np.float64]
    wc6: NDArray[np.float64]
    gamma6: float
    wm2: NDArray[np.float64]
    wc2: NDArray[np.float64]
    gamma2: float


class Filter(NamedTuple):
    """Means and covariances of the three stages and the auxiliary memory (arrays updated in place)."""

    xe: NDArray[np.float64]  # (4,) stage 1, VelocityState
    Pe: NDArray[np.float64]  # (4, 4)
    xu: NDArray[np.float64]  # (6,) stage 2, ForceState
    Pu: NDArray[np.float64]  # (6, 6)
    xm: NDArray[np.float64]  # (2,) stage 3, FrictionState
    Pm: NDArray[np.float64]  # (2, 2)
    aux: NDArray[np.float64]  # (6,) Aux


class Inputs(NamedTuple):
    """Per-sample inputs, each shape (n,) (SI; NaN pose velocity: none at that sample)."""

    t: NDArray[np.float64]
    ax: NDArray[np.float64]
    ay: NDArray[np.float64]
    yaw_rate: NDArray[np.float64]
    steer: NDArray[np.float64]
    speed: NDArray[np.float64]
    vx_pose: NDArray[np.float64]
    vy_pose: NDArray[np.float64]
