r"""Compiled fixed-step RK4 integrators of the lateral and planar single-track models.

The derivative functions here are scalar numba ports of the numpy reference
models :func:`roadgrip.vehicle.lateral.lateral_derivatives` and
:func:`roadgrip.vehicle.planar.planar_derivatives`; the tests check that both
agree. The state of the integrators is the model state followed by the pose:
``[vy, yaw_rate, x, y, psi]`` (lateral, :class:`LateralSimState`) and
``[vx, vy, yaw_rate, omega_f, omega_r, x, y, psi]`` (planar, :class:`PlanarSimState`).

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
from typing import NamedTuple

import numpy as np
from numba import njit

__all__ = [
    "C_SIZE", "P_SIZE", "FieldCode", "LateralDriver", "LateralParams", "LateralSimState", "PlanarInputs",
    "PlanarModel", "PlanarParams", "PlanarSimState", "PursuitPath", "RK4Scratch", "SpeedControl",
    "SteerReference", "field_code", "field_surface", "integrate_lateral", "integrate_planar", "lateral_rhs",
    "nearest_on_path", "planar_rhs", "surface_index", "tire_mu",
]

# State layouts of the integrators. The kernels index with the module constants (numba
# freezes a module's globals when it compiles; it cannot read a plain class's attributes).
_L_VY, _L_R, _L_X, _L_Y, _L_PSI = range(5)
_S_VX, _S_VY, _S_R, _S_WF, _S_WR, _S_X, _S_Y, _S_PSI = range(8)


class LateralSimState:
    """Index layout of the lateral integrator state."""
    VY, YAW_RATE, X, Y, PSI = _L_VY, _L_R, _L_X, _L_Y, _L_PSI
    SIZE = 5


class PlanarSimState:
    """Index layout of the planar integrator state (first five as ``PlanarState``)."""
    VX, VY, YAW_RATE, OMEGA_F, OMEGA_R = _S_VX, _S_VY, _S_R, _S_WF, _S_WR
    X, Y, PSI = _S_X, _S_Y, _S_PSI
    SIZE = 8


class PlanarParams(NamedTuple):
    """Planar model's vehicle in the ``P_*`` order of its parameter vector (``wheel_inertia``:
    one axle's [kg m²]; ``omega_eps``: the brake torque's wheel-speed regularisation [rad/s])."""
    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    cg_height: float
    wheel_radius: float
    wheel_inertia: float
    v_eps: float
    gravity: float
    omega_eps: float
    max_steer: float

    def vector(self) -> np.ndarray:
        """The parameter vector (``P_*`` layout) that :func:`planar_rhs` takes."""
        return np.array(self, dtype=np.float64)


# Layout of the planar parameter vector passed to the kernels.
P_MASS, P_IZ, P_LF, P_LR, P_H, P_R, P_IW, P_VEPS, P_G, P_WEPS, P_MAXSTEER = range(len(PlanarParams._fields))
P_SIZE = len(PlanarParams._fields)
# Columns of the planar integrator's ``controls`` output.
C_STEER, C_DRIVE_F, C_DRIVE_R, C_BRAKE_F, C_BRAKE_R = range(5)
C_SIZE = 5


# --- the kernels' parameter structures (module level, so numba's cache can pickle them) ---
class FieldCode(NamedTuple):
    """Friction field encoding (``friction.FrictionField.encode``), see :func:`field_code`."""
    mode: int
    times: np.ndarray
    time_idx: np.ndarray
    rects: np.ndarray
    rect_idx: np.ndarray
    n_rects: int
    base: int


def field_code(enc) -> FieldCode:
    """:class:`FieldCode` of a ``FrictionField.encode()`` dictionary."""
    return FieldCode(enc["mode"], enc["times"], enc["time_idx"], enc["rects"], enc["rect_idx"],
                     enc.get("n_rects", 0), enc["base"])


class LateralParams(NamedTuple):
    """Lateral model's vehicle: mass [kg], yaw inertia [kg m²], CG to axles [m],
    static axle loads [N], slip regularisation [m/s]."""
    mass: float
    yaw_inertia: float
    lf: float
    lr: float
    fz_front: float
    fz_rear: float
    v_eps: float


class LateralDriver(NamedTuple):
    """Half-step references and gains of the lateral driver (:func:`integrate_lateral`)."""
    vx_h: np.ndarray
    steer_h: np.ndarray
    rref_h: np.ndarray
    k_r: float
    k_b: float
    max_steer: float


class PlanarModel(NamedTuple):
    """Vehicle (``P_*`` vector), tires and stiffness bounds of :func:`integrate_planar`."""
    p: np.ndarray
    table: np.ndarray
    peaks: np.ndarray
    lam_wheel: float
    lam_body: float


class SteerReference(NamedTuple):
    """Open-loop references at the step times and the yaw-rate feedback gain."""
    steer_ff: np.ndarray
    rref: np.ndarray
    v_ref: np.ndarray
    a_ref: np.ndarray
    k_r: float


class PursuitPath(NamedTuple):
    """Closed path of the pure-pursuit driver, its speed profile and look-ahead."""
    x: np.ndarray
    y: np.ndarray
    v: np.ndarray
    lookahead0: float
    lookahead_gain: float
    speed_preview: float


class SpeedControl(NamedTuple):
    """PI speed controller, torque split and torque limits of the planar driver."""
    kp: float
    ki: float
    drive_front: float
    brake_front: float
    max_drive: float
    max_brake: float


class PlanarInputs(NamedTuple):
    """Steering [rad] and axle drive and brake torques [N m] held over a step."""
    steer: float
    tdf: float
    tdr: float
    tbf: float
    tbr: float


class RK4Scratch(NamedTuple):
    """Work arrays of an RK4 step: the four stage slopes and the stage state."""
    k1: np.ndarray
    k2: np.ndarray
    k3: np.ndarray
    k4: np.ndarray
    tmp: np.ndarray


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
def field_surface(field, t, x, y):
    """Surface index of the encoded friction field ``field`` (:class:`FieldCode`) at ``t, x, y``."""
    return surface_index(field.mode, t, x, y, field.times, field.time_idx, field.rects, field.rect_idx,
                         field.n_rects, field.base)


@njit(cache=True)
def _reg(v, v_eps):
    s = 1.0 if v >= 0.0 else -1.0
    return s * math.sqrt(v * v + v_eps * v_eps)


# --- lateral model (paper 000, eq. 1-2) ---------------------------------------------------
@njit(cache=True)
def lateral_rhs(s, vx, steer, rows, p, out):
    """``d/dt [vy, r, x, y, psi]`` (``LateralSimState`` layout); ``p``: :class:`LateralParams`."""
    vy = s[_L_VY]
    r = s[_L_R]
    psi = s[_L_PSI]
    u = _reg(vx, p.v_eps)
    af = steer - math.atan((vy + p.lf * r) / u)
    ar = -math.atan((vy - p.lr * r) / u)
    fyf = p.fz_front * tire_mu(rows[0], af) * math.cos(steer)
    fyr = p.fz_rear * tire_mu(rows[1], ar)
    out[_L_VY] = -vx * r + (fyf + fyr) / p.mass
    out[_L_R] = (p.lf * fyf - p.lr * fyr) / p.yaw_inertia
    out[_L_X] = vx * math.cos(psi) - vy * math.sin(psi)
    out[_L_Y] = vx * math.sin(psi) + vy * math.cos(psi)
    out[_L_PSI] = r


@njit(cache=True)
def _clip(v, lim):
    return min(max(v, -lim), lim)


@njit(cache=True)
def _driver(drv, j, x):
    """Feed-forward + yaw-rate feedback + sideslip counter-steer, clipped, at half-step ``j``."""
    return _clip(drv.steer_h[j] + drv.k_r * (drv.rref_h[j] - x[_L_R])
                 + drv.k_b * x[_L_VY] / max(abs(drv.vx_h[j]), 0.1), drv.max_steer)


@njit(cache=True)
def integrate_lateral(x0, dt, n_steps, driver, table, p, field):
    """RK4 of the lateral model with a yaw-rate feedback driver.

    Parameters
    ----------
    x0 : ndarray, shape (5,)
        Initial state (``LateralSimState`` layout).
    dt, n_steps : float, int
        Step [s] and number of steps.
    driver : LateralDriver
        ``vx_h``, ``steer_h``, ``rref_h``, shape (2 n_steps + 1,): speed [m/s], feed-forward
        steering [rad] and yaw-rate reference [rad/s] at times ``k dt / 2``; ``k_r``: yaw-rate
        feedback gain [rad s / rad]; ``k_b``: counter-steer gain on the body sideslip
        ``vy / vx`` [rad / rad]; ``max_steer``: steering limit [rad].
    table : ndarray, shape (n_surfaces, 4, 5)
        Encoded curves (``friction.tire_table``).
    p : LateralParams
    field : FieldCode

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
    w = RK4Scratch(np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n))
    k1, k2, k3, k4, tmp = w.k1, w.k2, w.k3, w.k4, w.tmp
    vx_h = driver.vx_h
    for k in range(n_steps + 1):
        t = k * dt
        si = field_surface(field, t, x[_L_X], x[_L_Y])
        rows = table[si]
        states[k] = x
        surf[k] = si
        d1 = _driver(driver, 2 * k, x)
        steer[k] = d1
        if k == n_steps:
            break
        lateral_rhs(x, vx_h[2 * k], d1, rows, p, k1)
        for i in range(n):
            tmp[i] = x[i] + 0.5 * dt * k1[i]
        d2 = _driver(driver, 2 * k + 1, tmp)
        lateral_rhs(tmp, vx_h[2 * k + 1], d2, rows, p, k2)
        for i in range(n):
            tmp[i] = x[i] + 0.5 * dt * k2[i]
        d3 = _driver(driver, 2 * k + 1, tmp)
        lateral_rhs(tmp, vx_h[2 * k + 1], d3, rows, p, k3)
        for i in range(n):
            tmp[i] = x[i] + dt * k3[i]
        d4 = _driver(driver, 2 * k + 2, tmp)
        lateral_rhs(tmp, vx_h[2 * k + 2], d4, rows, p, k4)
        for i in range(n):
            x[i] = x[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    return states, steer, surf


# --- planar model -------------------------------------------------------------------------
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
    vx = s[_S_VX]
    vy = s[_S_VY]
    r = s[_S_R]
    wf = s[_S_WF]
    wr = s[_S_WR]
    psi = s[_S_PSI]
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
    out[_S_VX] = ax + r * vy
    out[_S_VY] = ay - r * vx
    out[_S_R] = (lf * fzf * gyf - lr * fzr * myr) / p[P_IZ]
    weps = p[P_WEPS]
    out[_S_WF] = (tdf - tbf * math.tanh(wf / weps) - R * fzf * mxf) / p[P_IW]
    out[_S_WR] = (tdr - tbr * math.tanh(wr / weps) - R * fzr * mxr) / p[P_IW]
    out[_S_X] = vx * math.cos(psi) - vy * math.sin(psi)
    out[_S_Y] = vx * math.sin(psi) + vy * math.cos(psi)
    out[_S_PSI] = r


@njit(cache=True)
def _rk4_planar(x, h, u, rows, peaks, p, w):
    """One RK4 step of length ``h`` in place; ``u``: :class:`PlanarInputs`, ``w``: :class:`RK4Scratch`."""
    n = x.shape[0]
    k1, k2, k3, k4, tmp = w.k1, w.k2, w.k3, w.k4, w.tmp
    planar_rhs(x, u.steer, u.tdf, u.tdr, u.tbf, u.tbr, rows, peaks, p, k1)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    planar_rhs(tmp, u.steer, u.tdf, u.tdr, u.tbf, u.tbr, rows, peaks, p, k2)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    planar_rhs(tmp, u.steer, u.tdf, u.tdr, u.tbf, u.tbr, rows, peaks, p, k3)
    for i in range(n):
        tmp[i] = x[i] + h * k3[i]
    planar_rhs(tmp, u.steer, u.tdf, u.tdr, u.tbf, u.tbr, rows, peaks, p, k4)
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
def _pursuit(path, x, idx, wb):
    """Pure-pursuit steering [rad] and previewed speed reference [m/s]; ``idx``: nearest point."""
    npath = path.x.shape[0]
    vx = x[_S_VX]
    la = path.lookahead0 + path.lookahead_gain * max(vx, 0.0)
    j = idx
    for _ in range(npath):
        dxp = path.x[j] - x[_S_X]
        dyp = path.y[j] - x[_S_Y]
        if dxp * dxp + dyp * dyp >= la * la:
            break
        j = (j + 1) % npath
    dxp = path.x[j] - x[_S_X]
    dyp = path.y[j] - x[_S_Y]
    cp = math.cos(x[_S_PSI])
    sp = math.sin(x[_S_PSI])
    lx = cp * dxp + sp * dyp
    ly = -sp * dxp + cp * dyp
    ld = math.sqrt(lx * lx + ly * ly)
    steer = math.atan(2.0 * wb * ly / max(ld * ld, 1e-6))
    # speed reference previewed along the path
    dist = path.speed_preview * max(vx, 0.0)
    jj = idx
    acc = 0.0
    vr = path.v[idx]
    for _ in range(npath):
        jn = (jj + 1) % npath
        acc += math.sqrt((path.x[jn] - path.x[jj]) ** 2 + (path.y[jn] - path.y[jj]) ** 2)
        jj = jn
        vr = min(vr, path.v[jj])
        if acc >= dist:
            break
    return steer, vr


@njit(cache=True)
def _axle_torques(torque, sc):
    """:class:`SpeedControl` ``sc``'s split of a total wheel torque: ``(tdf, tdr, tbf, tbr)``."""
    if torque >= 0.0:
        tdf = sc.drive_front * torque
        return tdf, torque - tdf, 0.0, 0.0
    tbf = -sc.brake_front * torque
    return 0.0, 0.0, tbf, -torque - tbf


@njit(cache=True)
def integrate_planar(x0, dt, n_steps, model, steer_mode, ref, path, speed, field):
    """RK4 of the planar model with its driver (module docstring).

    Parameters
    ----------
    x0 : ndarray, shape (8,)
        Initial state (``PlanarSimState`` layout).
    dt, n_steps : float, int
        Internal step [s] and number of steps.
    model : PlanarModel
        ``p``: parameter vector, shape (P_SIZE,); ``table``, ``peaks``: encoded curves, shapes
        (n_surfaces, 4, 5) and (n_surfaces, 4); ``lam_wheel``: wheel-mode stiffness
        ``R² m g k_x,max / I_w`` [m/s²] (the wheel eigenvalue bound [1/s] is
        ``lam_wheel / sqrt(vx² + v_eps²)``); ``lam_body``: body-mode stiffness [m/s²], likewise.
    steer_mode : int
        0: ``steer_ff + k_r (rref - r)``; 1: pure pursuit of the path.
    ref : SteerReference
        ``steer_ff``, ``rref``, ``v_ref``, ``a_ref``, shape (n_steps + 1,): driver
        references at the step times (open-loop mode); ``k_r``: yaw-rate gain.
    path : PursuitPath
        ``x``, ``y``, ``v``, shape (n_path,): closed path [m] and its speed profile [m/s]
        (path mode); pure-pursuit look-ahead ``lookahead0 + lookahead_gain vx`` [m, s]; the
        path speed is read ``speed_preview`` ahead [s] (so the car brakes before corners).
    speed : SpeedControl
        PI speed gains ``kp``, ``ki`` [1/s, 1/s²]; front shares ``drive_front``,
        ``brake_front`` of the drive and brake torque [-]; torque limits
        ``max_drive``, ``max_brake``, total over both axles [N m].
    field : FieldCode

    Returns
    -------
    states : ndarray, shape (n_steps + 1, 8)
    controls : ndarray, shape (n_steps + 1, C_SIZE)
        ``[steer, drive_f, drive_r, brake_f, brake_r]`` (``C_*`` layout) applied over each step.
    surf : ndarray, shape (n_steps + 1,)
    n_sub : ndarray, shape (n_steps + 1,)
        RK4 sub-steps taken in each step.
    """
    n = x0.shape[0]
    states = np.empty((n_steps + 1, n))
    controls = np.zeros((n_steps + 1, C_SIZE))
    surf = np.empty(n_steps + 1, dtype=np.int64)
    nsub = np.ones(n_steps + 1, dtype=np.int64)
    x = x0.copy()
    w = RK4Scratch(np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n))
    p = model.p
    lf = p[P_LF]
    lr = p[P_LR]
    wb = lf + lr
    R = p[P_R]
    m = p[P_MASS]
    integ = 0.0
    idx = 0
    npath = path.x.shape[0]
    if steer_mode == 1:
        idx = nearest_on_path(path.x, path.y, x[_S_X], x[_S_Y], 0, 5, npath, True)
    for k in range(n_steps + 1):
        t = k * dt
        si = field_surface(field, t, x[_S_X], x[_S_Y])
        states[k] = x
        surf[k] = si
        vx = x[_S_VX]
        # --- driver -----------------------------------------------------------------
        if steer_mode == 0:
            steer = ref.steer_ff[k] + ref.k_r * (ref.rref[k] - x[_S_R])
            vr = ref.v_ref[k]
            ar = ref.a_ref[k]
        else:
            idx = nearest_on_path(path.x, path.y, x[_S_X], x[_S_Y], idx, 5, 80, True)
            steer, vr = _pursuit(path, x, idx, wb)
            ar = 0.0
        steer = _clip(steer, p[P_MAXSTEER])
        e = vr - vx
        a_cmd = ar + speed.kp * e + speed.ki * integ
        torque = m * a_cmd * R
        if torque > speed.max_drive:
            torque = speed.max_drive
        elif torque < -speed.max_brake:
            torque = -speed.max_brake
        else:
            integ += e * dt  # conditional integration: no wind-up at the limits
        tdf, tdr, tbf, tbr = _axle_torques(torque, speed)
        controls[k, C_STEER] = steer
        controls[k, C_DRIVE_F] = tdf
        controls[k, C_DRIVE_R] = tdr
        controls[k, C_BRAKE_F] = tbf
        controls[k, C_BRAKE_R] = tbr
        if k == n_steps:
            break
        # --- integration with sub-steps ------------------------------------------
        u = math.sqrt(vx * vx + p[P_VEPS] ** 2)
        lam = max(model.lam_wheel / u + (tbf + tbr) / (p[P_IW] * p[P_WEPS]), model.lam_body / u)
        ns = max(1, math.ceil(dt * lam / 2.0))
        nsub[k] = ns
        h = dt / ns
        rows = model.table[si]
        pk = model.peaks[si]
        held = PlanarInputs(steer, tdf, tdr, tbf, tbr)
        for _ in range(ns):
            _rk4_planar(x, h, held, rows, pk, p, w)
    return states, controls, surf, nsub
