"""Evidence of the slip-acceleration maps (paper 002, eq. 9-15) and the input prefilter.

Reference accelerations of the mid-friction tire, the reliability weights with
their exclusions and the per-sample probabilities of high / low / old friction
(see :mod:`roadgrip.estimators.classify.slipmap`), vectorised over samples.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.classify.brls_config import SATURATION_PHI_HALF
from roadgrip.estimators.classify.common import DEFAULT_FRICTION
from roadgrip.estimators.classify.grip_model import (
    BRAKING_ACCEL,
    GripModel,
    braking_samples,
    channels,
    default_grip_model,
)
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.inference.kinematic import KinematicOutput
from roadgrip.signals import driven_wheels
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BRAKING_MEMORY_MAX",
    "BRAKING_ONSET_S",
    "BRAKING_ONSET_TAU",
    "PREFILTER_SIZE",
    "Braking",
    "SlipMapEvidence",
    "evidence",
    "evidence_from_kinematics",
    "grip_of",
    "prefilter",
    "saturation_evidence",
]

# columns of the prefiltered signals
PF_KAPPA = slice(0, 4)
PF_ALPHA_F, PF_ALPHA_R, PF_AX, PF_AY, PF_BRAKING, PF_HARD = 4, 5, 6, 7, 8, 9
PREFILTER_SIZE = 10
"""Prefiltered signals: ``kappa_fl..rr, alpha_f, alpha_r, ax, ay``, the braking
indicator ``ax < 0`` (its low-passed value says how recently the car braked) and the
hard-braking indicator ``ax < -BRAKING_ACCEL`` (low-passed over
:data:`BRAKING_ONSET_TAU`: how long the car has been braking)."""

BRAKING_MEMORY_MAX = 0.05
"""The longitudinal saturation channel waits after braking until the low-passed braking
indicator falls below this (about three prefilter time constants): the slips and the
accelerometer (pitch rebound) settle for about a second after a stop."""

BRAKING_ONSET_TAU = 1.0
"""Time constant [s] of the low-passed hard-braking indicator (:class:`Braking`)."""

BRAKING_ONSET_S = 0.8
"""A braking sample carries evidence to the slip map only in about the first 0.8 s of a
stop (the hard-braking indicator, low-passed over :data:`BRAKING_ONSET_TAU`, below
``1 - exp(-BRAKING_ONSET_S / BRAKING_ONSET_TAU)``). The braking slips are taken against
a speed that coasts on the accelerometer once no wheel rolls freely; its error is a
bias that grows through the stop while the speed falls (multi-body van, 0.5 g stops
from 21 m/s: 0.01-0.03 m/s at the onset, 0.03-0.05 m/s after 0.8 s, 0.05-0.07 m/s after
3 s; the slip error ``dv / v`` grows five- to tenfold). A per-sample vote takes the
direction of each sample whatever its class separation, so the late part of a stop,
where that bias exceeds the class separation, would vote 'high' on gravel."""


class Braking(NamedTuple):
    """Low-passed braking indicators of :func:`prefilter` (arrays, shape (T,), in [0, 1]).

    Attributes
    ----------
    memory : ``ax < 0`` over the prefilter's time constant (how recently the car braked)
    hard : ``ax < -BRAKING_ACCEL`` over :data:`BRAKING_ONSET_TAU` (how long it has braked)
    """

    memory: NDArray[np.float64]
    hard: NDArray[np.float64]

    def onset(self) -> NDArray[np.bool_]:
        """Samples in about the first :data:`BRAKING_ONSET_S` of hard braking."""
        return self.hard < 1.0 - np.exp(-BRAKING_ONSET_S / BRAKING_ONSET_TAU)


class SlipMapEvidence(NamedTuple):
    """Per-sample evidence (arrays, shape (T,)).

    Attributes
    ----------
    ax_ref, ay_ref : reference accelerations [m/s²]
    w_x, w_y : reliability weights after exclusions (eq. 9)
    p_high, p_low, p_old : eq. 10-15 (channel means)
    kappa : slip used on the longitudinal map [-]
    """

    ax_ref: NDArray[np.float64]
    ay_ref: NDArray[np.float64]
    w_x: NDArray[np.float64]
    w_y: NDArray[np.float64]
    p_high: NDArray[np.float64]
    p_low: NDArray[np.float64]
    p_old: NDArray[np.float64]
    kappa: NDArray[np.float64]


def evidence(
    kappa: NDArray, alpha_f: NDArray, alpha_r: NDArray, ax: NDArray, ay: NDArray,
    steer: NDArray, wheels_valid: NDArray, params: VehicleParams, config: SlipMapConfig,
    vx: NDArray | None = None,
) -> SlipMapEvidence:
    """Reference accelerations, weights and probabilities (eq. 9-15), vectorised.

    Parameters
    ----------
    kappa : ndarray, shape (T, 4)
        Wheel slips ``fl, fr, rl, rr`` [-].
    alpha_f, alpha_r, steer : ndarray, shape (T,)
        Axle slip angles and road-wheel angle [rad].
    ax, ay : ndarray, shape (T,)
        Accelerations [m/s²].
    wheels_valid : ndarray of bool, shape (T, 4)
        Which wheel speeds are measured.
    params : VehicleParams
    config : SlipMapConfig
    vx : ndarray, shape (T,), optional
        Speed [m/s]; samples slower than ``config.min_speed`` get zero weights.
    """
    kappa = np.asarray(kappa, float)
    valid = np.asarray(wheels_valid, bool)
    ax = np.asarray(ax, float)
    ay = np.asarray(ay, float)
    L = params.lf + params.lr
    driven = driven_wheels(params.drive) & valid
    allw = valid
    n_dr = driven.sum(-1)
    n_all = allw.sum(-1)
    k_dr = np.where(n_dr > 0, (kappa * driven).sum(-1) / np.maximum(n_dr, 1), 0.0)
    k_all = np.where(n_all > 0, (kappa * allw).sum(-1) / np.maximum(n_all, 1), 0.0)
    accel = ax >= 0.0
    k_eff = np.where(accel, k_dr, k_all)
    transfer = params.cg_height * ax / (GRAVITY * L)
    if params.drive == "fwd":
        share_dr = params.lr / L - transfer
    elif params.drive == "rwd":
        share_dr = params.lf / L + transfer
    else:
        share_dr = np.ones_like(ax)
    share = np.where(accel, np.clip(share_dr, 0.05, 1.0), 1.0)
    ax_ref = GRAVITY * share * config.long_curve.mu(k_eff)
    ay_ref = GRAVITY * (params.lr / L * config.lat_curve.mu(alpha_f) * np.cos(steer)
                        + params.lf / L * config.lat_curve.mu(alpha_r))
    phi_lat = np.asarray(alpha_f) * np.cos(steer) + np.asarray(alpha_r)
    wx = 1.0 - np.exp(-((ax - ax_ref) ** 2) / config.sigma_x**2)
    wy = 1.0 - np.exp(-((ay - ay_ref) ** 2) / config.sigma_y**2)
    # exclusions: low-slip-low-acceleration box, disagreeing quadrants, no slip information
    box_x = (np.abs(k_eff) < config.slip_min_long) & (np.abs(ax) < config.accel_min)
    box_y = (np.abs(phi_lat) < 2.0 * config.slip_min_lat) & (np.abs(ay) < config.accel_min)
    quad_x = k_eff * ax < 0.0
    quad_y = phi_lat * ay < 0.0
    no_x = np.where(accel, n_dr == 0, n_all == 0)
    slow = np.zeros(ax.shape, bool) if vx is None else np.abs(np.asarray(vx, float)) < config.min_speed
    wx = np.where(box_x | quad_x | no_x | slow, 0.0, wx)
    wy = np.where(box_y | quad_y | slow, 0.0, wy)
    above_x = np.abs(ax) > np.abs(ax_ref)
    above_y = np.abs(ay) > np.abs(ay_ref)
    p_high = 0.5 * (np.where(above_x, wx, 0.0) + np.where(above_y, wy, 0.0))
    p_low = 0.5 * (np.where(above_x, 0.0, wx) + np.where(above_y, 0.0, wy))
    p_old = 0.5 * ((1.0 - wx) + (1.0 - wy))
    return SlipMapEvidence(ax_ref, ay_ref, wx, wy, p_high, p_low, p_old, k_eff)


@numba.njit(cache=True)
def _prefilter_kernel(x, t, tau, dt0, state):  # pragma: no cover - compiled
    """First-order low-pass of the columns of ``x`` (T, m) with time constants ``tau``
    (m,) [s] (0: none), in place on ``state`` (m,)."""
    n, m = x.shape
    out = np.empty((n, m))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        for j in range(m):
            k = 1.0 if tau[j] <= 0.0 else 1.0 - np.exp(-dt / tau[j])
            state[j] += k * (x[i, j] - state[j])
            out[i, j] = state[j]
    return out


def _pack(kin: KinematicOutput, ax, ay) -> NDArray[np.float64]:
    """Prefilter inputs as columns ``kappa_fl..rr, alpha_f, alpha_r, ax, ay, ax < 0,
    ax < -BRAKING_ACCEL``, shape (T, PREFILTER_SIZE)."""
    ax = np.asarray(ax, float).reshape(-1)
    x = np.empty((ax.shape[0], PREFILTER_SIZE))
    x[:, PF_KAPPA] = np.reshape(kin.kappa, (-1, 4))
    x[:, PF_ALPHA_F] = kin.alpha_f
    x[:, PF_ALPHA_R] = kin.alpha_r
    x[:, PF_AX] = ax
    x[:, PF_AY] = ay
    x[:, PF_BRAKING] = ax < 0.0
    x[:, PF_HARD] = ax < -BRAKING_ACCEL
    return x


def _unpack(kin: KinematicOutput, y: NDArray) -> tuple[KinematicOutput, NDArray, NDArray, Braking]:
    kin_f = kin._replace(kappa=y[:, PF_KAPPA], alpha_f=y[:, PF_ALPHA_F], alpha_r=y[:, PF_ALPHA_R])
    return kin_f, y[:, PF_AX], y[:, PF_AY], Braking(y[:, PF_BRAKING], y[:, PF_HARD])


def saturation_evidence(
    kin: KinematicOutput, ax, ay, steer, params: VehicleParams, config: SlipMapConfig,
    grip: GripModel, braking: Braking | None = None,
) -> SlipMapEvidence:
    """Eq. 9-15 on the saturation model (``config.model == 'saturation'``), vectorised.

    Per channel, in noise units (:func:`roadgrip.estimators.classify.grip_model.channels`:
    ``phi`` the separation of the class predictions, ``y`` the measurement's
    distance from the low class's): the reference is halfway, ``d = (y - phi / 2) sign(phi)``
    the measurement's distance above it. The weight measures what the sample
    can tell, not how far it falls from the reference (eq. 9 would weigh
    noise and model error where the classes predict the same):
    ``W = 1 - 2^-(phi / phi_half)^2`` with ``phi_half`` =
    :data:`~roadgrip.estimators.classify.brls_config.SATURATION_PHI_HALF`. The
    direction is soft, ``p^H = W Phi(d / sigma)``, ``p^L = W - p^H`` (``Phi`` the
    normal distribution function, ``sigma`` = ``sigma_x`` / ``sigma_y`` in noise
    units; the paper's hard split is the limit ``sigma -> 0``). The lateral
    channel counts only with ``config.lateral`` (the longitudinal one with
    ``config.longitudinal``); the longitudinal one only where
    the low-passed braking indicator ``braking.memory`` (from :func:`prefilter`) is below
    :data:`BRAKING_MEMORY_MAX`, and, with a fitted model (``config.grip``), on the
    braking samples (:func:`~roadgrip.estimators.classify.grip_model.braking_samples`)
    at the onset of a stop (:meth:`Braking.onset`, :data:`BRAKING_ONSET_S`), where the
    coasting speed's bias is still small against the class separation. Later in a stop
    a per-sample vote would take the direction of that bias.
    """
    ch, cp = channels(kin, ax, ay, steer, params, grip, config.min_speed, braking=False)
    if braking is not None:
        settled = np.atleast_1d(braking.memory) < BRAKING_MEMORY_MAX
        ch = ch._replace(phi_long=np.where(settled, ch.phi_long, 0.0),
                         y_long=np.where(settled, ch.y_long, 0.0))
        # only a fitted model: the vehicle's default takes the slip stiffness from the
        # cornering stiffness (as the bRLS, grip_model.channels)
        fitted = config.grip is not None and config.grip.braking_evidence
        onset = braking_samples(kin, ax) & np.atleast_1d(braking.onset()) if fitted else None
        if onset is not None and onset.any():
            chb, _ = channels(kin, ax, ay, steer, params, grip, config.min_speed, braking=True)
            ch = ch._replace(phi_long=np.where(onset, chb.phi_long, ch.phi_long),
                             y_long=np.where(onset, chb.y_long, ch.y_long))
    wx, wy, p_high, p_low, p_old = _saturation_probabilities(
        np.ascontiguousarray(ch.phi_long), np.ascontiguousarray(ch.y_long), ch.phi_lat, ch.y_lat,
        float(config.sigma_x), float(config.sigma_y), bool(config.longitudinal), bool(config.lateral))
    kf = np.asarray(kin.kappa, float).reshape(-1, 4).sum(-1) / 4.0
    return SlipMapEvidence(0.5 * (cp.ax_high + cp.ax_low), 0.5 * (cp.ay_high + cp.ay_low),
                           wx, wy, p_high, p_low, p_old, kf)


@numba.njit(cache=True)
def _position_evidence(phi, y, sigma):  # pragma: no cover - compiled
    """Weight ``W`` and soft direction ``Phi(d / sigma)`` of one channel of one sample
    (:func:`saturation_evidence`)."""
    d = (y - 0.5 * phi) * np.sign(phi)
    w = 1.0 - math.exp(-math.log(2.0) * (phi / SATURATION_PHI_HALF) ** 2)
    return w, 0.5 * (1.0 + math.erf(d / (math.sqrt(2.0) * sigma)))


@numba.njit(cache=True)
def _saturation_probabilities(phi_x, y_x, phi_y, y_y, sigma_x, sigma_y, longitudinal, lateral):  # pragma: no cover
    """``w_x, w_y, p_high, p_low, p_old`` of :func:`saturation_evidence`, shapes (T,)."""
    n = phi_x.shape[0]
    wx, wy = np.empty(n), np.empty(n)
    p_high, p_low, p_old = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        w_x, px = _position_evidence(phi_x[i], y_x[i], sigma_x)
        w_y, py = _position_evidence(phi_y[i], y_y[i], sigma_y)
        if not lateral:
            w_y = 0.0
        if not longitudinal:
            w_x = 0.0
        wx[i], wy[i] = w_x, w_y
        p_high[i] = 0.5 * (w_x * px + w_y * py)
        p_low[i] = 0.5 * (w_x * (1.0 - px) + w_y * (1.0 - py))
        p_old[i] = 0.5 * ((1.0 - w_x) + (1.0 - w_y))
    return wx, wy, p_high, p_low, p_old


def grip_of(config: SlipMapConfig, params: VehicleParams, friction: dict[str, float]) -> GripModel:
    """The saturation model of ``config``, or the vehicle's default one at the class ``friction``."""
    if config.grip is not None:
        return config.grip
    return default_grip_model(params, friction["high"], friction["low"])


def evidence_from_kinematics(
    kin: KinematicOutput, ax, ay, steer, params: VehicleParams, config: SlipMapConfig,
    braking: Braking | None = None,
) -> SlipMapEvidence:
    """:func:`evidence` (or :func:`saturation_evidence`, with the prefilter's ``braking``)
    of the kinematic stage's output (one sample or arrays)."""
    if config.model == "saturation":
        return saturation_evidence(kin, ax, ay, steer, params, config,
                                   grip_of(config, params, DEFAULT_FRICTION), braking)
    return evidence(np.atleast_2d(kin.kappa), np.atleast_1d(kin.alpha_f), np.atleast_1d(kin.alpha_r),
                    np.atleast_1d(ax), np.atleast_1d(ay), np.atleast_1d(steer),
                    np.atleast_2d(kin.wheels_valid), params, config, np.atleast_1d(kin.vx))


def prefilter(
    kin: KinematicOutput, ax, ay, t: NDArray, tau: float, dt0: float, state: NDArray[np.float64]
) -> tuple[KinematicOutput, NDArray, NDArray, NDArray, NDArray[np.float64]]:
    """First-order low-pass of the slips and accelerations (``tau`` [s], 0 = none).

    Parameters
    ----------
    kin : KinematicOutput
        One sample (``kappa`` shape (4,)) or arrays (``kappa`` shape (T, 4)).
    ax, ay : float or ndarray, shape (T,)
        Accelerations [m/s²].
    t : ndarray, shape (T,)
        Sample times [s].
    tau : float
        Time constant [s] of the slips and accelerations (the braking indicators have
        their own).
    dt0 : float
        Step before the first sample [s].
    state : ndarray, shape (PREFILTER_SIZE,)
        Filter state before the first sample (not modified).

    Returns
    -------
    kin, ax, ay
        Filtered, arrays with leading axis time.
    braking : Braking
        The low-passed braking indicators.
    state : ndarray, shape (PREFILTER_SIZE,)
        Filter state after the last sample.
    """
    st = np.array(state, dtype=float)
    taus = np.full(PREFILTER_SIZE, float(tau))
    taus[PF_HARD] = BRAKING_ONSET_TAU
    y = _prefilter_kernel(_pack(kin, ax, ay), np.ascontiguousarray(t, dtype=float), taus, float(dt0), st)
    kin_f, ax_f, ay_f, braking = _unpack(kin, y)
    return kin_f, ax_f, ay_f, braking, st
