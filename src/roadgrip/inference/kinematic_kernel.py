"""Compiled update of the kinematic estimator (:mod:`roadgrip.inference.kinematic`).

:func:`kinematic_update` is the one per-sample update, used by the online step
and by the batch loop :func:`kinematic_batch` (from a given state, returning the
state after the last sample, so that a drive can be run in consecutive blocks), so
a batch run equals stepping exactly. Its arguments are three records: the state :class:`KinematicState`,
the sample :class:`KinematicInput` and the parameters :class:`KinematicParams`.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = [
    "AID_CODES",
    "KinematicInput",
    "KinematicParams",
    "KinematicSeries",
    "KinematicState",
    "kinematic_batch",
    "kinematic_update",
]

AID_CODES = {"wheels": 0, "pose": 1}
"""Code of each velocity aid in :class:`KinematicParams`."""


class KinematicState(NamedTuple):
    """Estimator state. ``vx``, ``vy`` [m/s] at the CG; the previous sample's time and pose."""

    vx: float
    vy: float
    t: float
    x: float
    y: float
    psi: float
    started: bool


class KinematicInput(NamedTuple):
    """One sample. Absent signals are NaN (wheel speeds, pose, ``vx`` column).

    Attributes
    ----------
    t : float [s]
    ax, ay : float [m/s²]
    yaw_rate : float [rad/s]
    steer : float [rad]
    omega : ndarray, shape (4,)
        Wheel speeds ``fl, fr, rl, rr`` [rad/s], NaN where not measured.
    x, y, psi : float
        Map pose [m, m, rad], NaN where absent.
    vx_meas : float
        A measured ground speed [m/s], NaN where absent (used only without wheels and pose).
    """

    t: float
    ax: float
    ay: float
    yaw_rate: float
    steer: float
    omega: NDArray[np.float64]
    x: float
    y: float
    psi: float
    vx_meas: float


class KinematicSeries(NamedTuple):
    """The inputs of a whole drive (fields of :class:`KinematicInput` as arrays, leading axis time)."""

    t: NDArray[np.float64]
    ax: NDArray[np.float64]
    ay: NDArray[np.float64]
    yaw_rate: NDArray[np.float64]
    steer: NDArray[np.float64]
    omega: NDArray[np.float64]
    x: NDArray[np.float64]
    y: NDArray[np.float64]
    psi: NDArray[np.float64]
    vx_meas: NDArray[np.float64]


class KinematicParams(NamedTuple):
    """Vehicle constants and tuning of the update (SI).

    Attributes
    ----------
    aid : int
        Velocity aid, :data:`AID_CODES`.
    driven : ndarray of int, shape (4,)
        1 for a driven wheel ``fl, fr, rl, rr``.
    wheel_radius, lf, lr, half_track : float
        [m].
    tau_vx, tau_pose, tau_beta, a_linear, accel_threshold, gate_abs, gate_rel, v_min : float
        :class:`~roadgrip.inference.kinematic.KinematicConfig` fields.
    tilt_x, tilt_y : float
        The accelerometer's over-reading of ``ax``, ``ay`` from the body's pitch and
        roll, divided out before integration [-] (:func:`roadgrip.signals.tilt_gains`).
    """

    aid: int
    driven: NDArray[np.int64]
    wheel_radius: float
    lf: float
    lr: float
    half_track: float
    tau_vx: float
    tau_pose: float
    tau_beta: float
    a_linear: float
    accel_threshold: float
    gate_abs: float
    gate_rel: float
    v_min: float
    tilt_x: float
    tilt_y: float


@numba.njit(cache=True)
def _wheel_vx(omega, steer, r, vy, R, lf, half_track):  # pragma: no cover - compiled
    """CG-equivalent speeds of the four wheels (NaN where absent)."""
    out = np.empty(4)
    c = np.cos(steer)
    s = np.sin(steer)
    lat_f = (vy + lf * r) * s
    for i in range(4):
        v = R * omega[i]
        side = half_track * r if (i % 2 == 0) else -half_track * r  # left: vx - r w/2
        if i < 2:
            out[i] = (v - lat_f) / max(c, 0.2) + side
        else:
            out[i] = v + side
    return out


@numba.njit(cache=True)
def kinematic_update(st, s, p):  # pragma: no cover - compiled
    """One estimator update from state ``st``, sample ``s`` and parameters ``p``; returns the new (vx, vy)."""
    vx, vy, t_prev, x_prev, y_prev, psi_prev, started = st.vx, st.vy, st.t, st.x, st.y, st.psi, st.started
    t, r, steer, omega = s.t, s.yaw_rate, s.steer, s.omega
    ax, ay = s.ax / p.tilt_x, s.ay / p.tilt_y
    x, y, psi, vx_meas = s.x, s.y, s.psi, s.vx_meas
    aid, driven, R, lf, lr, half_track = p.aid, p.driven, p.wheel_radius, p.lf, p.lr, p.half_track
    tau_vx, tau_pose, tau_beta, a_lin = p.tau_vx, p.tau_pose, p.tau_beta, p.a_linear
    a_thr, gate_abs, gate_rel, v_min = p.accel_threshold, p.gate_abs, p.gate_rel, p.v_min
    wv = _wheel_vx(omega, steer, r, vy, R, lf, half_track)
    n_ok = 0
    for i in range(4):
        if wv[i] == wv[i]:
            n_ok += 1
    have_pose = (x == x) and (y == y) and (psi == psi)
    if not started:
        v0 = np.nan
        if n_ok > 0:
            acc = 0.0
            for i in range(4):
                if wv[i] == wv[i]:
                    acc += wv[i]
            v0 = acc / n_ok
        elif vx_meas == vx_meas:
            v0 = vx_meas
        if v0 != v0:
            v0 = 0.0
        return v0, 0.0
    dt = t - t_prev
    # prediction: kinematic integration
    vx_p = vx + dt * (ax + r * vy)
    vy_p = vy + dt * (ay - r * vx)
    use_pose = aid == 1 and have_pose and (x_prev == x_prev)
    if use_pose:
        dx = (x - x_prev) / dt
        dy = (y - y_prev) / dt
        pm = 0.5 * (psi + psi_prev)
        vxm = np.cos(pm) * dx + np.sin(pm) * dy
        vym = -np.sin(pm) * dx + np.cos(pm) * dy
        k = min(dt / tau_pose, 1.0)
        return vx_p + k * (vxm - vx_p), vy_p + k * (vym - vy_p)
    # speed from wheels, robust to spin (traction) and slip (braking)
    vsel = np.nan
    if n_ok > 0:
        if ax > a_thr:
            acc = 0.0
            m = 0
            lo = np.inf
            for i in range(4):
                if wv[i] == wv[i]:
                    lo = min(lo, wv[i])
                    if driven[i] == 0:
                        acc += wv[i]
                        m += 1
            vsel = acc / m if m > 0 else lo
        elif ax < -a_thr:
            # braking: every wheel slips, so the wheels cannot correct the speed;
            # coast on the accelerometer (unless no wheel is braked, never the case here)
            vsel = np.nan
        else:
            acc = 0.0
            for i in range(4):
                if wv[i] == wv[i]:
                    acc += wv[i]
            vsel = acc / n_ok
    elif vx_meas == vx_meas:
        vsel = vx_meas
    vx_n = vx_p
    if vsel == vsel and abs(vsel - vx_p) <= gate_abs + gate_rel * abs(vx_p):
        vx_n = vx_p + min(dt / tau_vx, 1.0) * (vsel - vx_p)
    # sideslip drift correction towards zero rear slip in quasi-linear driving
    if abs(vx_n) < v_min:
        vy_n = vy_p + min(dt / tau_pose, 1.0) * (0.0 - vy_p)
    else:
        w = np.exp(-((ay / a_lin) ** 2))
        vy_n = vy_p + min(w * dt / tau_beta, 1.0) * (lr * r - vy_p)
    return vx_n, vy_n


@numba.njit(cache=True)
def kinematic_batch(u, p, st):  # pragma: no cover - compiled
    """:func:`kinematic_update` over a :class:`KinematicSeries` from the state ``st``.

    Returns ``(vx, vy, state)``: the velocities [m/s], shape (T,) each, and the
    :class:`KinematicState` after the last sample. A drive given in consecutive
    blocks, each started from the state the block before ended in, gives the
    velocities of the whole drive in one block.
    """
    n = u.t.shape[0]
    vx_o = np.empty(n)
    vy_o = np.empty(n)
    for i in range(n):
        s = KinematicInput(u.t[i], u.ax[i], u.ay[i], u.yaw_rate[i], u.steer[i], u.omega[i],
                           u.x[i], u.y[i], u.psi[i], u.vx_meas[i])
        vx, vy = kinematic_update(st, s, p)
        st = KinematicState(vx, vy, u.t[i], u.x[i], u.y[i], u.psi[i], True)
        vx_o[i] = vx
        vy_o[i] = vy
    return vx_o, vy_o, st
