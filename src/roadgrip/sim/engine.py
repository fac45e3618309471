r"""Compiled fixed-step RK4 integrators of the lateral and planar single-track models.

The derivative functions here are scalar numba ports of the numpy reference
models :func:`roadgrip.vehicle.lateral.lateral_derivatives` and
:func:`roadgrip.vehicle.planar.planar_derivatives`; the tests check that both
agree. The state of the integrators is the model state followed by the pose:

==============  ===========================================================
integrator      state vector (``SimState`` layouts below)
==============  ===========================================================
lateral         ``[vy, yaw_rate, x, y, psi]``
planar          ``[vx, vy, yaw_rate, omega_f, omega_r, x, y, psi]``
==============  ===========================================================

Inputs and control
------------------
*Lateral.* ``vx`` and the driver's feed-forward steering are given on a
half-step grid (``2 n + 1`` samples), so RK4 sees the inputs at its stage
times and keeps its fourth order. The driver adds a continuous yaw-rate
feedback ``k_r (r_ref - r)`` evaluated at every stage.

*Planar.* A discrete driver runs at the internal rate at the start of every
step and holds its outputs over the step: steering from the feed-forward plus
yaw-rate feedback, or pure pursuit of a closed path; a PI speed controller
turns the speed error into a wheel torque, split between the axles by the
drive layout (drive) or the brake balance (brake).

Stiff wheel dynamics
--------------------
The wheel spin mode has eigenvalue of order ``R² Fz k_x / (I_w v)``
(``k_x`` the longitudinal slip stiffness per unit load), which grows without
bound as the speed falls. Each internal step of length ``dt`` is therefore
split into ``n_sub = ceil(dt lambda_max / 2)`` equal RK4 sub-steps, where
``lambda_max`` bounds the wheel, brake and body eigenvalues at the current
speed (RK4 is stable for real eigenvalues up to ``|lambda dt| < 2.78``). At
road speeds ``n_sub = 1``; near standstill the sub-steps keep every state
finite. The step count depends only on the state, so runs are deterministic.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = [
    "LateralSimState",
    "PlanarSimState",
    "integrate_lateral",
    "integrate_planar",
    "lateral_rhs",
    "nearest_on_path",
    "planar_rhs",
    "surface_index",
    "tire_mu",
]


class LateralSimState:
    """Index layout of the lateral integrator state."""

    VY = 0
    YAW_RATE = 1
    X = 2
    Y = 3
    PSI = 4
    SIZE = 5


class PlanarSimState:
    """Index layout of the planar integrator state (first five as ``PlanarState``)."""

    VX = 0
    VY = 1
    YAW_RATE = 2
    OMEGA_F = 3
    OMEGA_R = 4
    X = 5
    Y = 6
    PSI = 7
    SIZE = 8


# Layout of the planar parameter vector passed to the kernels.
P_MASS, P_IZ, P_LF, P_LR, P_H, P_R, P_IW, P_VEPS, P_G, P_WEPS, P_MAXSTEER = range(11)
P_SIZE = 11


@njit(cache=True)
def tire_mu(row, s):
    """Normalised force of one encoded curve (``friction.encode_tire``) at slip ``s``."""
    if row[0] == 0.0:
        B = row[1]
        C = row[2]
        D = row[3]
        E = row[4]
        bs = B * s
        return D * math.sin(C * math.atan(bs - E * (bs - math.atan(bs))))
    mu = row[1]
    k = row[2]
    z = math.tan(min(max(s, -1.5), 1.5))
    az = abs(z)
    if az < 3.0 * mu / k:
        return k * z - k * k * az * z / (3.0 * mu) + k * k * k * z * z * z / (27.0 * mu * mu)
    return mu if z > 0 else -mu


@njit(cache=True)
def surface_index(mode, t, x, y, times, time_idx, rects, rect_idx, n_rects, base):
    """Surface index of a friction field (``friction.FrictionField.encode``)."""
    if mode == 0:
        return base
    if mode == 1:
        i = 0
        for j in range(times.shape[0]):
            if times[j] <= t:
                i = j
        return time_idx[i]
    idx = base
    for j in range(n_rects):
        if rects[j, 0] <= x < rects[j, 1] and rects[j, 2] <= y < rects[j, 3]:
            idx = rect_idx[j]
    return idx


@njit(cache=True)
def _reg(v, v_eps):
    s = 1.0 if v >= 0.0 else -1.0
    return s * math.sqrt(v * v + v_eps * v_eps)


# ---------------------------------------------------------------------------------------
# lateral model (paper 000, eq. 1-2)
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def lateral_rhs(s, vx, steer, rows, p, out):
    """``d/dt [vy, r, x, y, psi]``; ``p = [m, Iz, lf, lr, Fzf, Fzr, v_eps]``."""
    vy = s[0]
    r = s[1]
    psi = s[4]
    u = _reg(vx, p[6])
    af = steer - math.atan((vy + p[2] * r) / u)
    ar = -math.atan((vy - p[3] * r) / u)
    fyf = p[4] * tire_mu(rows[0], af) * math.cos(steer)
    fyr = p[5] * tire_mu(rows[1], ar)
    out[0] = -vx * r + (fyf + fyr) / p[0]
    out[1] = (p[2] * fyf - p[3] * fyr) / p[1]
    out[2] = vx * math.cos(psi) - vy * math.sin(psi)
    out[3] = vx * math.sin(psi) + vy * math.cos(psi)
    out[4] = r


@njit(cache=True)
def _clip(v, lim):
    return min(max(v, -lim), lim)


@njit(cache=True)
def _driver(steer_ff, r_ref, vx, x, k_r, k_b, max_steer):
    """Feed-forward + yaw-rate feedback + counter-steer on the sideslip, clipped."""
    return _clip(steer_ff + k_r * (r_ref - x[1]) + k_b * x[0] / max(abs(vx), 0.1), max_steer)


@njit(cache=True)
def integrate_lateral(
    x0, dt, n_steps, vx_h, steer_h, rref_h, k_r, k_b, max_steer, table, p,
    mode, times, time_idx, rects, rect_idx, n_rects, base,
):
    """RK4 of the lateral model with a yaw-rate feedback driver.

    Parameters
    ----------
    x0 : ndarray, shape (5,)
    dt : float
        Step [s].
    n_steps : int
    vx_h, steer_h, rref_h : ndarray, shape (2 n_steps + 1,)
        Speed [m/s], feed-forward steering [rad] and yaw-rate reference [rad/s]
        at times ``k dt / 2``.
    k_r : float
        Yaw-rate feedback gain [rad s / rad].
    k_b : float
        Counter-steer gain on the body sideslip ``vy / vx`` [rad / rad].
    max_steer : float
        Steering limit [rad].
    table : ndarray, shape (n_surfaces, 4, 5)
        Encoded curves (``friction.tire_table``).
    p : ndarray
        ``[m, Iz, lf, lr, Fzf, Fzr, v_eps]``.
    mode, times, time_idx, rects, rect_idx, n_rects, base
        Friction field encoding.

    Returns
    -------
    states : ndarray, shape (n_steps + 1, 5)
    steer : ndarray, shape (n_steps + 1,)
        Steering applied at the start of each step [rad].
    surf : ndarray, shape (n_steps + 1,)
        Surface index at the start of each step.
    """
    n = x0.shape[0]
    states = np.empty((n_steps + 1, n))
    steer = np.empty(n_steps + 1)
    surf = np.empty(n_steps + 1, dtype=np.int64)
    x = x0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    for k in range(n_steps + 1):
        t = k * dt
        si = surface_index(mode, t, x[2], x[3], times, time_idx, rects, rect_idx, n_rects, base)
        rows = table[si]
        states[k] = x
        surf[k] = si
        d1 = _driver(steer_h[2 * k], rref_h[2 * k], vx_h[2 * k], x, k_r, k_b, max_steer)
        steer[k] = d1
        if k == n_steps:
            break
        lateral_rhs(x, vx_h[2 * k], d1, rows, p, k1)
        for i in range(n):
            tmp[i] = x[i] + 0.5 * dt * k1[i]
        d2 = _driver(steer_h[2 * k + 1], rref_h[2 * k + 1], vx_h[2 * k + 1], tmp, k_r, k_b, max_steer)
        lateral_rhs(tmp, vx_h[2 * k + 1], d2, rows, p, k2)
        for i in range(n):
            tmp[i] = x[i] + 0.5 * dt * k2[i]
        d3 = _driver(steer_h[2 * k + 1], rref_h[2 * k + 1], vx_h[2 * k + 1], tmp, k_r, k_b, max_steer)
        lateral_rhs(tmp, vx_h[2 * k + 1], d3, rows, p, k3)
        for i in range(n):
            tmp[i] = x[i] + dt * k3[i]
        d4 = _driver(steer_h[2 * k + 2], rref_h[2 * k + 2], vx_h[2 * k + 2], tmp, k_r, k_b, max_steer)
        lateral_rhs(tmp, vx_h[2 * k + 2], d4, rows, p, k4)
        for i in range(n):
            x[i] = x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return states, steer, surf


# ---------------------------------------------------------------------------------------
# planar model
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def _long_slip(omega, vxw, R, v_eps):
    rw = R * omega
    m = max(abs(vxw), abs(rw))
    return (rw - vxw) / math.sqrt(m * m + v_eps * v_eps)


@njit(cache=True)
def planar_rhs(s, steer, tdf, tdr, tbf, tbr, rows, peaks, p, out):
    """``d/dt`` of the planar state plus pose; see ``vehicle.planar`` for the equations.

    ``rows``: encoded curves of the current surface, shape (4, 5); ``peaks``: their
    peaks, shape (4,); ``p``: parameter vector (``P_*`` layout).
    """
    m = p[P_MASS]
    lf = p[P_LF]
    lr = p[P_LR]
    h = p[P_H]
    R = p[P_R]
    g = p[P_G]
    veps = p[P_VEPS]
    vx = s[0]
    vy = s[1]
    r = s[2]
    wf = s[3]
    wr = s[4]
    psi = s[7]
    u = _reg(vx, veps)
    af = steer - math.atan((vy + lf * r) / u)
    ar = -math.atan((vy - lr * r) / u)
    c = math.cos(steer)
    sn = math.sin(steer)
    vxf = vx * c + (vy + lf * r) * sn
    kf = _long_slip(wf, vxf, R, veps)
    kr = _long_slip(wr, vx, R, veps)
    myf = tire_mu(rows[0], af)
    myr = tire_mu(rows[1], ar)
    mxf = tire_mu(rows[2], kf)
    mxr = tire_mu(rows[3], kr)
    rho = math.sqrt((mxf / peaks[2]) ** 2 + (myf / peaks[0]) ** 2)
    if rho > 1.0:
        mxf /= rho
        myf /= rho
    rho = math.sqrt((mxr / peaks[3]) ** 2 + (myr / peaks[1]) ** 2)
    if rho > 1.0:
        mxr /= rho
        myr /= rho
    wb = lf + lr
    gxf = mxf * c - myf * sn
    gxr = mxr
    ax = g * (lr * gxf + lf * gxr) / max(wb + h * (gxf - gxr), 0.1 * wb)
    fzf = max(m * (g * lr - ax * h) / wb, 0.0)
    fzr = max(m * (g * lf + ax * h) / wb, 0.0)
    ax = (fzf * gxf + fzr * gxr) / m
    gyf = mxf * sn + myf * c
    ay = (fzf * gyf + fzr * myr) / m
    out[0] = ax + r * vy
    out[1] = ay - r * vx
    out[2] = (lf * fzf * gyf - lr * fzr * myr) / p[P_IZ]
    weps = p[P_WEPS]
    out[3] = (tdf - tbf * math.tanh(wf / weps) - R * fzf * mxf) / p[P_IW]
    out[4] = (tdr - tbr * math.tanh(wr / weps) - R * fzr * mxr) / p[P_IW]
    out[5] = vx * math.cos(psi) - vy * math.sin(psi)
    out[6] = vx * math.sin(psi) + vy * math.cos(psi)
    out[7] = r


@njit(cache=True)
def _rk4_planar(x, h, steer, tdf, tdr, tbf, tbr, rows, peaks, p, k1, k2, k3, k4, tmp):
    n = x.shape[0]
    planar_rhs(x, steer, tdf, tdr, tbf, tbr, rows, peaks, p, k1)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    planar_rhs(tmp, steer, tdf, tdr, tbf, tbr, rows, peaks, p, k2)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    planar_rhs(tmp, steer, tdf, tdr, tbf, tbr, rows, peaks, p, k3)
    for i in range(n):
        tmp[i] = x[i] + h * k3[i]
    planar_rhs(tmp, steer, tdf, tdr, tbf, tbr, rows, peaks, p, k4)
    for i in range(n):
        x[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def nearest_on_path(px, py, x, y, start, back, ahead, closed):
    """Index of the path point nearest ``(x, y)`` among ``start - back .. start + ahead - 1``.

    A closed path wraps around; an open one is searched within its ends.
    """
    n = px.shape[0]
    best = start
    bd = 1e300
    for j in range(-back, ahead):
        i = start + j
        if closed:
            i = i % n
        elif i < 0 or i >= n:
            continue
        d = (px[i] - x) ** 2 + (py[i] - y) ** 2
        if d < bd:
            bd = d
            best = i
    return best


@njit(cache=True)
def integrate_planar(
    x0, dt, n_steps, p, table, peaks, lam_wheel, lam_body,
    steer_mode, steer_ff, rref, k_r,
    path_x, path_y, path_v, lookahead0, lookahead_gain, speed_preview,
    v_ref, a_ref, kp, ki, drive_front, brake_front, max_drive, max_brake,
    mode, times, time_idx, rects, rect_idx, n_rects, base,
):
    """RK4 of the planar model with its driver (module docstring).

    Parameters
    ----------
    x0 : ndarray, shape (8,)
    dt : float
        Internal step [s].
    n_steps : int
    p : ndarray, shape (P_SIZE,)
    table, peaks : ndarray
        Encoded curves, shapes (n_surfaces, 4, 5) and (n_surfaces, 4).
    lam_wheel : float
        Wheel-mode stiffness ``R² m g k_x,max / I_w`` [m/s²]: the wheel eigenvalue
        bound [1/s] is ``lam_wheel / sqrt(vx² + v_eps²)``.
    lam_body : float
        Body-mode stiffness [m/s²], divided by the speed likewise.
    steer_mode : int
        0: ``steer_ff + k_r (rref - r)``; 1: pure pursuit of the path.
    steer_ff, rref, v_ref, a_ref : ndarray, shape (n_steps + 1,)
        Driver references at the step times (open-loop mode; ``v_ref`` and
        ``a_ref`` are also used in path mode when ``path_v`` is empty).
    path_x, path_y, path_v : ndarray, shape (n_path,)
        Closed path [m] and its speed profile [m/s].
    lookahead0, lookahead_gain : float
        Pure-pursuit look-ahead ``L = lookahead0 + lookahead_gain vx`` [m, s].
    speed_preview : float
        The path speed is read this far ahead [s] (so the car brakes before corners).
    kp, ki : float
        PI speed gains [1/s, 1/s²].
    drive_front, brake_front : float
        Front share of the drive and brake torque [-].
    max_drive, max_brake : float
        Torque limits, total over both axles [N m].

    Returns
    -------
    states : ndarray, shape (n_steps + 1, 8)
    controls : ndarray, shape (n_steps + 1, 5)
        ``[steer, drive_f, drive_r, brake_f, brake_r]`` applied over each step.
    surf : ndarray, shape (n_steps + 1,)
    n_sub : ndarray, shape (n_steps + 1,)
        RK4 sub-steps taken in each step.
    """
    n = x0.shape[0]
    states = np.empty((n_steps + 1, n))
    controls = np.zeros((n_steps + 1, 5))
    surf = np.empty(n_steps + 1, dtype=np.int64)
    nsub = np.ones(n_steps + 1, dtype=np.int64)
    x = x0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    lf = p[P_LF]
    lr = p[P_LR]
    wb = lf + lr
    R = p[P_R]
    m = p[P_MASS]
    integ = 0.0
    idx = 0
    npath = path_x.shape[0]
    if steer_mode == 1:
        idx = nearest_on_path(path_x, path_y, x[5], x[6], 0, 5, npath, True)
    for k in range(n_steps + 1):
        t = k * dt
        si = surface_index(mode, t, x[5], x[6], times, time_idx, rects, rect_idx, n_rects, base)
        states[k] = x
        surf[k] = si
        vx = x[0]
        # --- driver -----------------------------------------------------------------
        if steer_mode == 0:
            steer = steer_ff[k] + k_r * (rref[k] - x[2])
            vr = v_ref[k]
            ar = a_ref[k]
        else:
            idx = nearest_on_path(path_x, path_y, x[5], x[6], idx, 5, 80, True)
            la = lookahead0 + lookahead_gain * max(vx, 0.0)
            j = idx
            for _ in range(npath):
                dxp = path_x[j] - x[5]
                dyp = path_y[j] - x[6]
                if dxp * dxp + dyp * dyp >= la * la:
                    break
                j = (j + 1) % npath
            dxp = path_x[j] - x[5]
            dyp = path_y[j] - x[6]
            cp = math.cos(x[7])
            sp = math.sin(x[7])
            lx = cp * dxp + sp * dyp
            ly = -sp * dxp + cp * dyp
            ld = math.sqrt(lx * lx + ly * ly)
            steer = math.atan(2.0 * wb * ly / max(ld * ld, 1e-6))
            # speed reference previewed along the path
            dist = speed_preview * max(vx, 0.0)
            jj = idx
            acc = 0.0
            vr = path_v[idx]
            for _ in range(npath):
                jn = (jj + 1) % npath
                acc += math.sqrt((path_x[jn] - path_x[jj]) ** 2 + (path_y[jn] - path_y[jj]) ** 2)
                jj = jn
                vr = min(vr, path_v[jj])
                if acc >= dist:
                    break
            ar = 0.0
        steer = _clip(steer, p[P_MAXSTEER])
        e = vr - vx
        a_cmd = ar + kp * e + ki * integ
        torque = m * a_cmd * R
        if torque > max_drive:
            torque = max_drive
        elif torque < -max_brake:
            torque = -max_brake
        else:
            integ += e * dt  # conditional integration: no wind-up at the limits
        if torque >= 0.0:
            tdf = drive_front * torque
            tdr = torque - tdf
            tbf = 0.0
            tbr = 0.0
        else:
            tdf = 0.0
            tdr = 0.0
            tbf = -brake_front * torque
            tbr = -torque - tbf
        controls[k, 0] = steer
        controls[k, 1] = tdf
        controls[k, 2] = tdr
        controls[k, 3] = tbf
        controls[k, 4] = tbr
        if k == n_steps:
            break
        # --- integration with sub-steps ------------------------------------------
        u = math.sqrt(vx * vx + p[P_VEPS] ** 2)
        lam = max(lam_wheel / u + (tbf + tbr) / (p[P_IW] * p[P_WEPS]), lam_body / u)
        ns = max(1, math.ceil(dt * lam / 2.0))
        nsub[k] = ns
        h = dt / ns
        rows = table[si]
        pk = peaks[si]
        for _ in range(ns):
            _rk4_planar(x, h, steer, tdf, tdr, tbf, tbr, rows, pk, p, k1, k2, k3, k4, tmp)
    return states, controls, surf, nsub
