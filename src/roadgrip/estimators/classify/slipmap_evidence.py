"""Evidence of the slip-acceleration maps (paper 002, eq. 9-15) and the input prefilter.

Reference accelerations of the mid-friction tire, the reliability weights with
their exclusions and the per-sample probabilities of high / low / old friction
(see :mod:`roadgrip.estimators.classify.slipmap`), vectorised over samples.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.inference.kinematic import KinematicOutput
from roadgrip.signals import driven_wheels
from roadgrip.vehicle.params import VehicleParams

__all__ = ["PREFILTER_SIZE", "SlipMapEvidence", "evidence", "evidence_from_kinematics", "prefilter"]

# columns of the prefiltered signals
PF_KAPPA = slice(0, 4)
PF_ALPHA_F, PF_ALPHA_R, PF_AX, PF_AY = 4, 5, 6, 7
PREFILTER_SIZE = 8
"""Prefiltered signals: ``kappa_fl..rr, alpha_f, alpha_r, ax, ay``."""


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
    """First-order low-pass of the columns of ``x`` (T, m), in place on ``state`` (m,)."""
    n, m = x.shape
    out = np.empty((n, m))
    for i in range(n):
        dt = dt0 if i == 0 else t[i] - t[i - 1]
        k = 1.0 if tau <= 0.0 else 1.0 - np.exp(-dt / tau)
        for j in range(m):
            state[j] += k * (x[i, j] - state[j])
            out[i, j] = state[j]
    return out


def _pack(kin: KinematicOutput, ax, ay) -> NDArray[np.float64]:
    """Prefilter inputs as columns ``kappa_fl..rr, alpha_f, alpha_r, ax, ay``, shape (T, 8)."""
    return np.ascontiguousarray(np.column_stack([
        np.atleast_2d(kin.kappa), np.atleast_1d(kin.alpha_f), np.atleast_1d(kin.alpha_r),
        np.atleast_1d(ax), np.atleast_1d(ay),
    ]), dtype=float)


def _unpack(kin: KinematicOutput, y: NDArray) -> tuple[KinematicOutput, NDArray, NDArray]:
    kin_f = kin._replace(kappa=y[:, PF_KAPPA], alpha_f=y[:, PF_ALPHA_F], alpha_r=y[:, PF_ALPHA_R])
    return kin_f, y[:, PF_AX], y[:, PF_AY]


def evidence_from_kinematics(
    kin: KinematicOutput, ax, ay, steer, params: VehicleParams, config: SlipMapConfig
) -> SlipMapEvidence:
    """:func:`evidence` of the kinematic stage's output (one sample or arrays)."""
    return evidence(np.atleast_2d(kin.kappa), np.atleast_1d(kin.alpha_f), np.atleast_1d(kin.alpha_r),
                    np.atleast_1d(ax), np.atleast_1d(ay), np.atleast_1d(steer),
                    np.atleast_2d(kin.wheels_valid), params, config, np.atleast_1d(kin.vx))


def prefilter(
    kin: KinematicOutput, ax, ay, t: NDArray, tau: float, dt0: float, state: NDArray[np.float64]
) -> tuple[KinematicOutput, NDArray, NDArray, NDArray[np.float64]]:
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
        Time constant [s].
    dt0 : float
        Step before the first sample [s].
    state : ndarray, shape (PREFILTER_SIZE,)
        Filter state before the first sample (not modified).

    Returns
    -------
    kin, ax, ay
        Filtered, arrays with leading axis time.
    state : ndarray, shape (PREFILTER_SIZE,)
        Filter state after the last sample.
    """
    st = np.array(state, dtype=float)
    y = _prefilter_kernel(_pack(kin, ax, ay), np.ascontiguousarray(t, dtype=float), float(tau),
                          float(dt0), st)
    kin_f, ax_f, ay_f = _unpack(kin, y)
    return kin_f, ax_f, ay_f, st
