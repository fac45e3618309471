"""The saturation model's formulas compiled, one sample at a time.

Each formula of :mod:`roadgrip.estimators.classify.grip_model` (axle forces, the two
classes' predictions, the traction and braking slips, the demonstrated channel, the
channels) is one numba function of one sample; the array functions of ``grip_model`` loop
over it, so a batch and a single live row run the same arithmetic. The vehicle's and the
model's constants reach it as one record (:class:`GripKernelParams`).
"""

from __future__ import annotations

import functools
import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numba
import numpy as np

from roadgrip.constants import GRAVITY, GRIP_CLASS_SPLIT
from roadgrip.vehicle.params import VehicleParams

if TYPE_CHECKING:
    from roadgrip.estimators.classify.grip_model import GripModel

__all__ = ["BRAKING_ACCEL", "BRAKING_MIN_SPEED", "DEMONSTRATED_MARGIN", "LONG_LATERAL_GATE", "GripKernelParams",
           "grip_kernel_params"]

DEMONSTRATED_MARGIN = 2.0
"""Margin [accelerometer noise units] by which the lateral acceleration must exceed the split's
before it demonstrates high grip (:func:`~roadgrip.estimators.classify.grip_model.demonstrated_channel`)."""

BRAKING_ACCEL = 1.0
"""Deceleration [m/s²] above which a sample counts as braking for the longitudinal
channel: every wheel is braked and the axle slips are taken against the coasting speed."""

BRAKING_MIN_SPEED = 5.0
"""Speed [m/s] below which braking samples carry no class information: the coasting
speed's error is a growing share of a slowing car's speed, and a stopping car's
wheels lock or stop whatever the friction."""

LONG_LATERAL_GATE = 0.15
"""The longitudinal channel counts only while ``|ay| < LONG_LATERAL_GATE g``: in a bend
the driven tires' combined slip depends on the slip angles, which the kinematic stage
knows far less well than the wheel slip."""

_DRIVE_CODES = {"fwd": 0, "rwd": 1, "awd": 2}


class GripKernelParams(NamedTuple):
    """The vehicle's and the model's constants as the compiled functions read them
    (:func:`grip_kernel_params`; the fields of :class:`GripModel` and :class:`VehicleParams`
    of the same names, units there).

    ``drive`` is 0 front-, 1 rear-, 2 all-wheel drive; ``demonstrated`` is
    ``lateral_evidence == 'demonstrated'``.
    """

    lf: float
    lr: float
    mass: float
    cg_height: float
    drive: int
    c_long: float
    c_lat: float
    shape_c: float
    mu_high: float
    mu_low: float
    gain_x: float
    gain_y: float
    accel_noise: float
    model_error_x: float
    model_error_y: float
    slip_noise: float
    slip_angle_noise: float
    resistance_0: float
    resistance_2: float
    lateral_speed_noise: float
    speed_noise: float
    alpha_offset_f: float
    alpha_offset_r: float
    kappa_offset: float
    demonstrated: bool


@functools.lru_cache(maxsize=64)
def grip_kernel_params(params: VehicleParams | None, model: GripModel | None,
                       kappa_offset: float | None = None) -> GripKernelParams:
    """The compiled functions' record of ``params`` and ``model`` (``kappa_offset``, when
    given, in place of the model's). A function that reads only the vehicle's or only the
    model's constants takes ``None`` for the other: its fields are NaN (drive -1)."""
    nan = math.nan
    veh = ((nan, nan, nan, nan, -1) if params is None else
           (float(params.lf), float(params.lr), float(params.mass), float(params.cg_height),
            _DRIVE_CODES[params.drive]))
    if model is None:
        mdl: tuple[Any, ...] = (nan,) * 18 + (False,)
    else:
        mdl = (float(model.c_long), float(model.c_lat), float(model.shape_c), float(model.mu_high),
               float(model.mu_low), float(model.gain_x), float(model.gain_y), float(model.accel_noise),
               float(model.model_error_x), float(model.model_error_y), float(model.slip_noise),
               float(model.slip_angle_noise), float(model.resistance_0), float(model.resistance_2),
               float(model.lateral_speed_noise), float(model.speed_noise), float(model.alpha_offset_f),
               float(model.alpha_offset_r), model.lateral_evidence == "demonstrated")
    offset = (nan if model is None else float(model.kappa_offset)) if kappa_offset is None else float(kappa_offset)
    return GripKernelParams(*veh, *mdl[:18], offset, mdl[18])


# ---------------------------------------------------------------------------------------
# compiled per-sample functions: the one implementation of each formula, looped over the
# samples by the array functions below (a batch and a single live row alike)


@numba.njit(cache=True)
def _shape(x, c):  # pragma: no cover - compiled
    return math.sin(c * math.atan(x / c))


@numba.njit(cache=True)
def _axle_slip(kappa, valid, i, first):  # pragma: no cover - compiled
    """Mean slip of the measured wheels ``first, first + 1`` of sample ``i`` (0 where none)."""
    n = 0
    total = 0.0
    for j in range(first, first + 2):
        if valid[i, j]:
            n += 1
        total += kappa[i, j] * valid[i, j]
    return total / max(n, 1) if n > 0 else 0.0


@numba.njit(cache=True)
def _axle_force(k, a, fz, mu, p):  # pragma: no cover - compiled
    """``(Fx, Fy)`` [N] of an axle at slip ``k``, slip angle ``a`` [rad] and load ``fz`` [N]."""
    sx = p.c_long * k
    sy = p.c_lat * math.tan(min(max(a, -1.4), 1.4))
    s = math.hypot(sx, sy)
    ratio = mu * _shape(s / mu, p.shape_c) / max(s, 1e-12) if s > 1e-12 else 1.0
    return fz * ratio * sx, fz * ratio * sy


@numba.njit(cache=True)
def _predict(kf, kr, af, ar, steer, ax_meas, vx, mu, p):  # pragma: no cover - compiled
    """``(ax, ay)`` of one sample at peak friction ``mu`` (:func:`predict_accelerations`)."""
    L = p.lf + p.lr
    m = p.mass
    h_ax = p.cg_height * ax_meas / p.gain_x
    fz_f = max(m * (GRAVITY * p.lr - h_ax) / L, 0.05 * m * GRAVITY)
    fz_r = max(m * (GRAVITY * p.lf + h_ax) / L, 0.05 * m * GRAVITY)
    fxf, fyf = _axle_force(kf, af, fz_f, mu, p)
    fxr, fyr = _axle_force(kr, ar, fz_r, mu, p)
    c, sn = math.cos(steer), math.sin(steer)
    ax = (fxf * c - fyf * sn + fxr) / m - p.resistance_0 - p.resistance_2 * (vx * vx)
    ay = (fxf * sn + fyf * c + fyr) / m
    return p.gain_x * ax, p.gain_y * ay


@numba.njit(cache=True)
def _class_predictions(kf, kr, af, ar, steer, ax_meas, vx, p):  # pragma: no cover - compiled
    """``(ax_high, ax_low, ay_high, ay_low, sigma_x, sigma_y)`` of one sample."""
    axh, ayh = _predict(kf, kr, af, ar, steer, ax_meas, vx, p.mu_high, p)
    axl, ayl = _predict(kf, kr, af, ar, steer, ax_meas, vx, p.mu_low, p)
    slip_x = p.c_long * GRAVITY * p.slip_noise
    v = max(abs(vx), 0.1)
    slip_y = p.c_lat * GRAVITY * (p.slip_angle_noise + p.lateral_speed_noise / v)
    sx = math.sqrt(p.accel_noise**2 + slip_x**2 + (p.model_error_x * 0.5 * (abs(axh) + abs(axl))) ** 2)
    sy = math.sqrt(p.accel_noise**2 + slip_y**2 + (p.model_error_y * 0.5 * (abs(ayh) + abs(ayl))) ** 2)
    return axh, axl, ayh, ayl, sx, sy


@numba.njit(cache=True)
def _rolling_over_speed(k):  # pragma: no cover - compiled
    """``R omega / vx`` of a wheel from its slip (eq. 2: ``1 / (1 - kappa)`` driving, ``1 + kappa`` braking)."""
    k = min(max(k, -0.9), 0.9)
    return 1.0 / (1.0 - k) if k >= 0.0 else 1.0 + k


@numba.njit(cache=True)
def _traction(kappa, valid, i, ax, p):  # pragma: no cover - compiled
    """``(kappa_f, kappa_r, traction)`` of sample ``i`` (:func:`traction_slips`)."""
    kf = _axle_slip(kappa, valid, i, 0)
    kr = _axle_slip(kappa, valid, i, 2)
    if p.drive == 2:
        return kf, kr, False
    front_driven = p.drive == 0
    k_dr, k_un = (kf, kr) if front_driven else (kr, kf)
    v_front = valid[i, 0] or valid[i, 1]
    v_rear = valid[i, 2] or valid[i, 3]
    v_dr, v_un = (v_front, v_rear) if front_driven else (v_rear, v_front)
    if v_dr and v_un:
        k_dr = 1.0 - _rolling_over_speed(k_un) / _rolling_over_speed(k_dr) - p.kappa_offset
        k_un = 0.0
    on = v_dr and ax > 0.0 and k_dr >= 0.0
    return (k_dr, k_un, on) if front_driven else (k_un, k_dr, on)


@numba.njit(cache=True)
def _braking(valid, i, ax, vx):  # pragma: no cover - compiled
    """Sample ``i`` is a braking sample (:func:`braking_samples`)."""
    both = (valid[i, 0] or valid[i, 1]) and (valid[i, 2] or valid[i, 3])
    return ax < -BRAKING_ACCEL and abs(vx) >= BRAKING_MIN_SPEED and both


@numba.njit(cache=True)
def _demonstrated(ay, p):  # pragma: no cover - compiled
    """``(phi, y)`` of one sample (:func:`demonstrated_channel`)."""
    a = abs(ay)
    sigma = p.accel_noise
    gain = max(p.gain_y, 1.0)
    a_low = GRIP_CLASS_SPLIT * GRAVITY * gain + DEMONSTRATED_MARGIN * sigma
    a_high_max = max(p.mu_high * GRAVITY * gain, a_low + sigma)
    return (min(max(a, a_low), a_high_max) - a_low) / sigma, max(a - a_low, 0.0) / sigma


@numba.njit(cache=True)
def _shape_array(x, c):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _shape(x[i], c)
    return out


@numba.njit(cache=True)
def _axle_slips_array(kappa, valid):  # pragma: no cover - compiled
    n = kappa.shape[0]
    kf, kr = np.empty(n), np.empty(n)
    for i in range(n):
        kf[i] = _axle_slip(kappa, valid, i, 0)
        kr[i] = _axle_slip(kappa, valid, i, 2)
    return kf, kr


@numba.njit(cache=True)
def _predict_array(kf, kr, af, ar, steer, ax_meas, vx, mu, p):  # pragma: no cover - compiled
    n = kf.shape[0]
    ax, ay = np.empty(n), np.empty(n)
    for i in range(n):
        ax[i], ay[i] = _predict(kf[i], kr[i], af[i], ar[i], steer[i], ax_meas[i], vx[i], mu, p)
    return ax, ay


@numba.njit(cache=True)
def _class_predictions_array(kf, kr, af, ar, steer, ax_meas, vx, p):  # pragma: no cover - compiled
    out = np.empty((6, kf.shape[0]))
    for i in range(kf.shape[0]):
        out[0, i], out[1, i], out[2, i], out[3, i], out[4, i], out[5, i] = _class_predictions(
            kf[i], kr[i], af[i], ar[i], steer[i], ax_meas[i], vx[i], p)
    return out


@numba.njit(cache=True)
def _traction_array(kappa, valid, ax, p):  # pragma: no cover - compiled
    n = kappa.shape[0]
    kf, kr, on = np.empty(n), np.empty(n), np.empty(n, np.bool_)
    for i in range(n):
        kf[i], kr[i], on[i] = _traction(kappa, valid, i, ax[i], p)
    return kf, kr, on


@numba.njit(cache=True)
def _braking_array(valid, ax, vx):  # pragma: no cover - compiled
    out = np.empty(ax.shape[0], np.bool_)
    for i in range(ax.shape[0]):
        out[i] = _braking(valid, i, ax[i], vx[i])
    return out


@numba.njit(cache=True)
def _demonstrated_array(ay, p):  # pragma: no cover - compiled
    phi, y = np.empty(ay.shape[0]), np.empty(ay.shape[0])
    for i in range(ay.shape[0]):
        phi[i], y[i] = _demonstrated(ay[i], p)
    return phi, y


@numba.njit(cache=True)
def _channels_array(kappa, valid, alpha_f, alpha_r, vx, ax, ay, steer, p, min_speed, braking):  # pragma: no cover
    """Rows ``phi_long, y_long, phi_lat, y_lat`` and rows ``ax_high, ax_low, ay_high, ay_low,
    sigma_x, sigma_y`` of :func:`channels`, shapes (4, T) and (6, T)."""
    n = kappa.shape[0]
    ch = np.empty((4, n))
    cp = np.empty((6, n))
    for i in range(n):
        kf, kr, on_x = _traction(kappa, valid, i, ax[i], p)
        brake = braking and _braking(valid, i, ax[i], vx[i])
        if brake:  # both axles' own slips, not the driven one's against the free wheels
            kf = _axle_slip(kappa, valid, i, 0)
            kr = _axle_slip(kappa, valid, i, 2)
        af = alpha_f[i] - p.alpha_offset_f
        ar = alpha_r[i] - p.alpha_offset_r
        _, _, ayh, ayl, _, sy = _class_predictions(kf, kr, af, ar, steer[i], ax[i], vx[i], p)
        # the longitudinal channel in straight-line traction or braking, without the slip angles
        axh, axl, _, _, sx, _ = _class_predictions(kf, kr, 0.0, 0.0, steer[i], ax[i], vx[i], p)
        if brake:
            sx = math.hypot(sx, p.c_long * GRAVITY * p.speed_noise / max(abs(vx[i]), 0.1))
        moving = abs(vx[i]) >= min_speed
        if moving and (on_x or brake) and abs(ay[i]) < LONG_LATERAL_GATE * GRAVITY:
            ch[0, i] = (axh - axl) / sx
            ch[1, i] = (ax[i] - axl) / sx
        else:
            ch[0, i] = 0.0
            ch[1, i] = 0.0
        if not moving:
            ch[2, i] = 0.0
            ch[3, i] = 0.0
        elif p.demonstrated:
            ch[2, i], ch[3, i] = _demonstrated(ay[i], p)
        else:
            ch[2, i] = (ayh - ayl) / sy
            ch[3, i] = (ay[i] - ayl) / sy
        cp[0, i], cp[1, i], cp[2, i], cp[3, i], cp[4, i], cp[5, i] = axh, axl, ayh, ayl, sx, sy
    return ch, cp
