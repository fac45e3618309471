r"""Saturation model of the classifiers: the accelerations each friction class predicts.

A tire's force at small slip does not tell one surface from another: the
cornering and slip stiffness barely change with the friction (not at all in the
multi-body engine, little on real tires), so the paper's equivalent-stiffness
regressors (eq. 4) and mid-friction curves with a scaled stiffness separate
surfaces only by what the stiffness happens to differ. What does separate them
is **saturation**: at a slip where a high-grip tire is still nearly linear, a
low-grip tire has fallen well behind its linear force. This module predicts the
CG accelerations from the measured slips for a given peak friction ``mu``:

* dynamic axle loads with longitudinal load transfer
  ``Fz_f = m (g lr - h ax) / L``, ``Fz_r = m (g lf + h ax) / L``;
* per axle the isotropic combined slip ``s = (c_x kappa, c_y tan(alpha))``
  (normalised stiffnesses ``c_x``, ``c_y`` [1/unit slip]; ``kappa`` the mean of
  the axle's measured wheels, 0 where none is measured) and the resultant friction
  ``mu f(|s| / mu)`` along ``s`` with the Magic-Formula shape
  ``f(x) = sin(C atan(x / C))`` (slope 1 at 0, peak 1), so the stiffness does
  not depend on ``mu``;
* ``ax = (Fxf cos(delta) - Fyf sin(delta) + Fxr) / m``,
  ``ay = (Fxf sin(delta) + Fyf cos(delta) + Fyr) / m``, scaled by the
  accelerometer gains ``gain_x``, ``gain_y`` (the body's pitch and roll leak
  gravity into the specific force: 6 % and 15 % on the multi-body sedan).

:func:`class_predictions` gives each channel's prediction for the high and the
low class and the noise ``sigma = sqrt(sigma_a^2 + (eps a_mid)^2)`` with a
relative model error ``eps``. Where the two predictions coincide (linear
range) a sample carries no class information, whatever the acceleration.

Without a calibration the stiffness comes from the vehicle's parameters
(cornering stiffness over the static axle load; the same value longitudinally,
as the isotropic brush model has it), the gains are 1 and the model error is
large (:data:`UNCALIBRATED_MODEL_ERROR`), so that only clear saturation or its
clear absence counts.

Each formula is one compiled per-sample function (``_predict``, ``_class_predictions``,
``_traction``, ...) that the array functions loop over, so that a whole drive and a
single live row run the same arithmetic at a row's cost of microseconds; the vehicle's
and the model's constants reach them as one :class:`GripKernelParams` record.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.classify.grip_kernels import (
    BRAKING_ACCEL,
    BRAKING_MIN_SPEED,
    DEMONSTRATED_MARGIN,
    LONG_LATERAL_GATE,
    GripKernelParams,
    _axle_slips_array,
    _braking_array,
    _channels_array,
    _class_predictions_array,
    _demonstrated_array,
    _predict_array,
    _shape_array,
    _traction_array,
    grip_kernel_params,
)
from roadgrip.estimators.classify.latency import LATENCY_MAX_S
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "ALPHA_OFFSET_MAX",
    "BRAKING_ACCEL",
    "BRAKING_MIN_SPEED",
    "DEMONSTRATED_MARGIN",
    "KAPPA_OFFSET_MAX",
    "LATERAL_EVIDENCE",
    "LONG_LATERAL_GATE",
    "UNCALIBRATED_MODEL_ERROR",
    "Channels",
    "ClassPredictions",
    "GripKernelParams",
    "GripModel",
    "axle_slips",
    "braking_samples",
    "channels",
    "class_predictions",
    "default_grip_model",
    "demonstrated_channel",
    "grip_kernel_params",
    "predict_accelerations",
    "shape",
    "traction_slips",
]

UNCALIBRATED_MODEL_ERROR = 0.25
"""Relative model error of the uncalibrated model (stiffness from the vehicle's
parameters, unknown accelerometer gains from pitch and roll) [-]."""

KAPPA_OFFSET_MAX = 0.05
"""Largest zero error of the driven axle's slip a model accepts [-] (5 % between the axles'
wheel speeds: beyond it a wheel-speed signal is broken, not offset)."""

LATERAL_EVIDENCE = ("slips", "demonstrated")
"""What the lateral channel regresses: the measured lateral acceleration between the two
classes' predictions from the slip angles, or against the most a low-grip road can
deliver (:func:`demonstrated_channel`), for a car whose slip angles are not known well."""

ALPHA_OFFSET_MAX = 0.1
"""Largest slip-angle zero error a model accepts [rad] (about 6 degrees: beyond it the
kinematic stage or the steering signal is broken, not offset)."""


@dataclass(frozen=True)
class GripModel:
    """Parameters of the saturation model.

    Attributes
    ----------
    c_long, c_lat : float
        Normalised slip and cornering stiffness ``C / Fz`` [1/unit slip, 1/rad].
    shape_c : float
        Magic-Formula shape factor of ``f`` (> 1).
    mu_high, mu_low : float
        Peak friction of the two classes [-].
    gain_x, gain_y : float
        Measured over modelled acceleration (accelerometer tilt) [-].
    accel_noise : float
        Acceleration noise [m/s²].
    slip_noise, slip_angle_noise : float
        Errors of the estimated slip [-] and slip angles [rad] (the multi-body
        drives' kinematic stage: 0.0006 in traction; 0.011 rad in cornering,
        where the accelerometer's roll leak drifts the sideslip).
    resistance_0, resistance_2 : float
        Road load as a deceleration ``r0 + r2 vx^2`` [m/s², 1/m] (rolling
        resistance and drag, which the driven tires overcome before they
        accelerate the car; 0 without a calibration).
    lateral_speed_noise : float
        Error of the estimated lateral velocity [m/s]: it adds
        ``lateral_speed_noise / |vx|`` to the slip-angle error, which grows as
        the car slows.
    speed_noise : float
        Error of the speed while braking [m/s], when no wheel rolls freely and the
        kinematic stage coasts on the levelled accelerometer: it adds
        ``speed_noise / |vx|`` to the braking slip's error (0.05-0.09 m/s rms
        over the multi-body drives' stops).
    model_error_x, model_error_y : float
        Relative model error ``eps`` of the longitudinal / lateral channel [-].
    lateral_evidence : {'slips', 'demonstrated'}
        The lateral channel's regression (:data:`LATERAL_EVIDENCE`).
    kappa_offset : float
        Zero error of the driven axle's slip against the free-rolling wheels [-], which
        :func:`traction_slips` subtracts: wheel-speed scale errors between the axles (tire
        radii, encoder scales) shift it by a constant that the model would read as
        saturation (0 without a calibration;
        :func:`roadgrip.estimators.classify.fit.fit_slip_offset`).
    braking_evidence : bool
        Whether the longitudinal channel takes braking samples (a calibrated model's;
        off where a one-class calibration finds them contradicting its label, as wheel
        radius and speed errors bias the braking slips).
    wheel_latency_s : float
        Latency of the wheel speeds behind the accelerometer [s], which the classifiers'
        front end aligns (0 without a calibration, and on an all-wheel-drive car;
        :func:`roadgrip.estimators.classify.latency.fit_wheel_latency`).
    alpha_offset_f, alpha_offset_r : float
        Zero errors of the kinematic stage's front and rear slip angles [rad], which
        :func:`channels` subtracts: a steering-angle offset, a yaw misalignment of the
        pose or a bias of the lateral velocity shift the slip angles by a constant that
        a tire model would read as a change of stiffness, and, on a turn in one
        direction, as a change of grip (0 without a calibration;
        :func:`roadgrip.estimators.classify.fit.fit_slip_angle_offsets`).
    """

    c_long: float
    c_lat: float
    mu_high: float
    mu_low: float
    shape_c: float = 1.4
    gain_x: float = 1.0
    gain_y: float = 1.0
    accel_noise: float = 0.3
    model_error_x: float = UNCALIBRATED_MODEL_ERROR
    model_error_y: float = UNCALIBRATED_MODEL_ERROR
    slip_noise: float = 0.002
    slip_angle_noise: float = 0.01
    resistance_0: float = 0.0
    resistance_2: float = 0.0
    lateral_speed_noise: float = 0.02
    speed_noise: float = 0.1
    alpha_offset_f: float = 0.0
    alpha_offset_r: float = 0.0
    lateral_evidence: str = "slips"
    braking_evidence: bool = True
    kappa_offset: float = 0.0
    wheel_latency_s: float = 0.0

    def __post_init__(self) -> None:
        if self.lateral_evidence not in LATERAL_EVIDENCE:
            raise ValueError(f"grip model lateral_evidence must be one of {LATERAL_EVIDENCE}, "
                             f"got {self.lateral_evidence!r}")
        for name in ("c_long", "c_lat", "gain_x", "gain_y", "accel_noise"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"grip model {name} must be positive, got {v!r}")
        if not 1.0 < self.shape_c < 2.0:
            raise ValueError(f"grip model shape_c must lie in (1, 2), got {self.shape_c!r}")
        if not 0.0 < self.mu_low < self.mu_high:
            raise ValueError(f"grip model needs 0 < mu_low < mu_high, got {self.mu_low}, {self.mu_high}")
        for name in ("slip_noise", "slip_angle_noise", "lateral_speed_noise", "speed_noise"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"grip model {name} must be >= 0, got {getattr(self, name)!r}")
        for name in ("model_error_x", "model_error_y"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise ValueError(f"grip model {name} must be >= 0, got {getattr(self, name)!r}")
        if not (math.isfinite(self.kappa_offset) and abs(self.kappa_offset) <= KAPPA_OFFSET_MAX):
            raise ValueError(f"grip model kappa_offset must be finite and within +-{KAPPA_OFFSET_MAX}, "
                             f"got {self.kappa_offset!r}")
        if not (math.isfinite(self.wheel_latency_s) and abs(self.wheel_latency_s) <= LATENCY_MAX_S):
            raise ValueError(f"grip model wheel_latency_s must be finite and within +-{LATENCY_MAX_S} s, "
                             f"got {self.wheel_latency_s!r}")
        for name in ("alpha_offset_f", "alpha_offset_r"):
            v = getattr(self, name)
            if not (math.isfinite(v) and abs(v) <= ALPHA_OFFSET_MAX):
                raise ValueError(f"grip model {name} must be finite and within +-{ALPHA_OFFSET_MAX} rad, "
                                 f"got {v!r}")

    def to_dict(self) -> dict[str, Any]:
        return {k: (v if isinstance(v, (str, bool)) else float(v)) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> GripModel:
        unknown = set(d) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown grip model setting(s) {sorted(unknown)}")
        kinds = {"lateral_evidence": str, "braking_evidence": bool}
        return cls(**{k: kinds.get(k, float)(v) for k, v in d.items()})


@functools.lru_cache(maxsize=64)
def default_grip_model(params: VehicleParams, mu_high: float, mu_low: float) -> GripModel:
    """The uncalibrated model of a vehicle: stiffness from its parameters, unit gains.

    ``c_lat`` is the mean over the axles of the cornering stiffness over the
    static axle load; ``c_long = c_lat``. (Cached: the online step asks for it at every
    sample.)
    """
    L = params.lf + params.lr
    fz_f = params.mass * GRAVITY * params.lr / L
    fz_r = params.mass * GRAVITY * params.lf / L
    c = 0.5 * (params.cornering_stiffness_front / fz_f + params.cornering_stiffness_rear / fz_r)
    return GripModel(c_long=c, c_lat=c, mu_high=mu_high, mu_low=mu_low)


# ---------------------------------------------------------------------------------------
# array functions


def _column(x: Any, n: int | None = None) -> NDArray[np.float64]:
    """``x`` as a contiguous float array of shape (T,) (a scalar repeated ``n`` times)."""
    a = np.ascontiguousarray(x, dtype=float)
    if a.ndim == 0:
        return np.full(1 if n is None else n, float(a))
    return a.reshape(-1)


def _wheels(kappa: Any, wheels_valid: Any) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Wheel slips and their validity as contiguous arrays of shape (T, 4)."""
    k = np.ascontiguousarray(kappa, dtype=float).reshape(-1, 4)
    v = np.ascontiguousarray(wheels_valid, dtype=np.bool_).reshape(-1, 4)
    return k, v


def shape(x: NDArray, c: float) -> NDArray:
    """Normalised saturation ``f(x) = sin(c atan(x / c))`` for ``x >= 0`` (slope 1 at 0, peak 1).

    ``x`` of any shape; the result has its shape.
    """
    a = np.asarray(x, float)
    return _shape_array(np.ascontiguousarray(a.reshape(-1)), float(c)).reshape(a.shape)


def axle_slips(kappa: NDArray, wheels_valid: NDArray) -> tuple[NDArray, NDArray]:
    """Mean slip of the measured wheels of each axle (0 where none), shapes (T,).

    Parameters
    ----------
    kappa : ndarray, shape (T, 4)
        Wheel slips ``fl, fr, rl, rr`` [-].
    wheels_valid : ndarray of bool, shape (T, 4)
    """
    return _axle_slips_array(*_wheels(kappa, wheels_valid))


def predict_accelerations(
    kappa_f: NDArray, kappa_r: NDArray, alpha_f: NDArray, alpha_r: NDArray, steer: NDArray,
    ax_meas: NDArray, params: VehicleParams, model: GripModel, mu: float, vx: NDArray | float = 0.0,
) -> tuple[NDArray, NDArray]:
    """Measured-frame CG accelerations ``(ax, ay)`` [m/s²] the slips give at peak friction ``mu``.

    All inputs have shape (T,): axle slips [-], slip angles and road-wheel angle
    [rad], the measured ``ax`` [m/s²] for the load transfer and the speed ``vx``
    [m/s] for the road load (a float: the same at every sample).
    """
    kf = _column(kappa_f)
    n = kf.shape[0]
    return _predict_array(kf, _column(kappa_r, n), _column(alpha_f, n), _column(alpha_r, n), _column(steer, n),
                          _column(ax_meas, n), _column(vx, n), float(mu), grip_kernel_params(params, model))


class ClassPredictions(NamedTuple):
    """Each channel's acceleration under the two classes and its noise (arrays, shape (T,)) [m/s²]."""

    ax_high: NDArray[np.float64]
    ax_low: NDArray[np.float64]
    ay_high: NDArray[np.float64]
    ay_low: NDArray[np.float64]
    sigma_x: NDArray[np.float64]
    sigma_y: NDArray[np.float64]


def class_predictions(
    kappa_f: NDArray, kappa_r: NDArray, alpha_f: NDArray, alpha_r: NDArray, steer: NDArray,
    ax_meas: NDArray, params: VehicleParams, model: GripModel, vx: NDArray | float = 0.0,
) -> ClassPredictions:
    """:func:`predict_accelerations` for ``mu_high`` and ``mu_low`` with the channel noise.

    All inputs have shape (T,). The noise adds to ``accel_noise`` the model error
    (``model_error_x`` / ``model_error_y`` times the mean prediction) and the slip errors
    (``slip_noise``, ``slip_angle_noise``) through the linear tire,
    ``c g sigma_slip``.
    """
    kf = _column(kappa_f)
    n = kf.shape[0]
    out = _class_predictions_array(kf, _column(kappa_r, n), _column(alpha_f, n), _column(alpha_r, n),
                                   _column(steer, n), _column(ax_meas, n), _column(vx, n),
                                   grip_kernel_params(params, model))
    return ClassPredictions(*out)


class Channels(NamedTuple):
    """Whitened class-position regression of each channel (arrays, shape (T,)).

    ``y = theta phi`` with ``phi = (a_high - a_low) / sigma`` and
    ``y = (a - a_low) / sigma``: ``theta = 1`` on the high class's curve, 0 on the
    low class's, and ``|phi|`` (in noise units) says how much a sample can tell.
    """

    phi_long: NDArray[np.float64]
    y_long: NDArray[np.float64]
    phi_lat: NDArray[np.float64]
    y_lat: NDArray[np.float64]


def traction_slips(
    kappa: NDArray, wheels_valid: NDArray, ax: NDArray, params: VehicleParams, offset: float = 0.0,
) -> tuple[NDArray, NDArray, NDArray[np.bool_]]:
    """Axle slips for the model and the samples where the driven axle's slip is known.

    In traction (``ax > 0``) the undriven axle rolls freely: where both axles'
    wheel speeds are measured, the driven axle's slip is taken against the
    undriven wheels, ``1 - omega_undriven / omega_driven - offset`` (``offset`` the
    zero error of that ratio, ``GripModel.kappa_offset``; the undriven axle's slip set
    to 0), which no error of the speed estimate can bias; elsewhere
    the kinematic stage's slips are kept. An all-wheel-drive car has no
    free-rolling wheel, so none of its samples is traction here. Braking, where
    every wheel slips against a speed that coasts on the accelerometer, is
    :func:`braking_samples`' part.

    Parameters
    ----------
    kappa : ndarray, shape (T, 4)
        Wheel slips ``fl, fr, rl, rr`` [-].
    wheels_valid : ndarray of bool, shape (T, 4)
    ax : ndarray, shape (T,)
        Measured longitudinal acceleration [m/s²].
    params : VehicleParams
    offset : float
        Zero error of the driven axle's slip [-].

    Returns
    -------
    kappa_f, kappa_r : ndarray, shape (T,)
    traction : ndarray of bool, shape (T,)
    """
    k, v = _wheels(kappa, wheels_valid)
    p = grip_kernel_params(params, None, float(offset))
    return _traction_array(k, v, _column(ax, k.shape[0]), p)


def braking_samples(kin: Any, ax: NDArray) -> NDArray[np.bool_]:
    """Samples whose braking slips carry class information, shape (T,).

    Decelerating by more than :data:`BRAKING_ACCEL` at :data:`BRAKING_MIN_SPEED`
    or faster, with a measured wheel on each axle (``kin`` a
    :class:`~roadgrip.inference.kinematic.KinematicOutput`: its ``vx`` [m/s] and
    ``wheels_valid``).
    """
    v = np.ascontiguousarray(kin.wheels_valid, dtype=np.bool_).reshape(-1, 4)
    a = _column(ax, v.shape[0])
    return _braking_array(v, a, _column(kin.vx, a.shape[0]))


def demonstrated_channel(ay: NDArray, model: GripModel) -> tuple[NDArray, NDArray]:
    """Lateral class position from the acceleration alone: ``(phi, y)``, shapes (T,).

    A road of the low class (peak friction below
    :data:`~roadgrip.constants.GRIP_CLASS_SPLIT`) cannot carry a lateral acceleration
    above ``a_split = split g``, whatever the slip angles; the high class carries up to
    ``mu_high g``. So the low class's prediction is the measured ``|a_y|`` held below
    ``a_low = a_split max(gain_y, 1) + m sigma_a`` (``m`` = :data:`DEMONSTRATED_MARGIN`, the
    accelerometer noise ``sigma_a`` = ``accel_noise``; a gain below 1 is not trusted to
    scale the split down), the high class's ``|a_y|`` held below ``mu_high g max(gain_y, 1)``
    (at least ``a_low + sigma_a``), whitened by ``sigma_a``: ``phi = (a_high - a_low) /
    sigma_a``, ``y = (|a_y| - a_low) / sigma_a``. Below ``a_low`` the sample tells nothing
    (``phi = 0``); above it the position is 1 or more: this channel demonstrates high
    grip, it never shows low grip (the honesty rule's demonstrated floor,
    :mod:`roadgrip.evaluate.honesty`; aerodynamic downforce counts as friction here
    as it does there).

    Parameters
    ----------
    ay : ndarray, shape (T,)
        Measured lateral acceleration [m/s²].
    model : GripModel
    """
    return _demonstrated_array(_column(ay), grip_kernel_params(None, model))


def channels(
    kin: Any, ax: NDArray, ay: NDArray, steer: NDArray, params: VehicleParams, model: GripModel,
    min_speed: float = 0.5, braking: bool = True,
) -> tuple[Channels, ClassPredictions]:
    """The whitened regressions of both channels from the kinematic stage's output.

    Samples slower than ``min_speed`` [m/s], and longitudinal samples outside
    :func:`traction_slips`' traction and :func:`braking_samples`' braking or with
    ``|ay| >=`` :data:`LONG_LATERAL_GATE` g, get ``phi = y = 0`` (no information).
    Braking samples (``braking=True``) take both axles' slips against the coasting
    speed, whose error (``speed_noise``) adds to their noise. That error is a bias
    that grows through a stop (the estimated speed runs 0.02-0.07 m/s low late in a
    multi-body stop, so the measured deceleration then exceeds both classes'
    predictions): a consumer that weighs each sample by its class separation, as the
    bRLS does, discounts it, whereas a per-sample vote does not. The longitudinal predictions leave the
    slip angles out (straight-line traction).

    Parameters
    ----------
    kin : KinematicOutput
        One sample (``kappa`` shape (4,)) or T of them (``kappa`` shape (T, 4), the rest (T,)).
    ax, ay, steer : float or ndarray, shape (T,)
        Measured accelerations [m/s²] and road-wheel angle [rad].
    params : VehicleParams
    model : GripModel
    min_speed : float
        [m/s].
    braking : bool
        Take braking samples on the longitudinal channel.

    Returns
    -------
    Channels, ClassPredictions
        Arrays of shape (T,).
    """
    k, v = _wheels(kin.kappa, kin.wheels_valid)
    n = k.shape[0]
    ch, cp = _channels_array(k, v, _column(kin.alpha_f, n), _column(kin.alpha_r, n), _column(kin.vx, n),
                             _column(ax, n), _column(ay, n), _column(steer, n),
                             grip_kernel_params(params, model), float(min_speed), bool(braking))
    return Channels(*ch), ClassPredictions(*cp)

