r"""The multi-body engine's closed-loop driver and its compiled RK4 integration.

A driver follows a :class:`Path` (points with a speed profile): pure pursuit
for the steering (a road-wheel angle target; the package's steering-rate input
is a proportional servo onto it and the package's own rate limit applies), a
PI speed controller with the path's acceleration as feed-forward for the
package's acceleration input, and a simple anti-lock and traction control that
scales the acceleration command down while any wheel's longitudinal slip
exceeds the slip limit (:data:`SLIP_LIMIT`). :func:`integrate_mb` integrates
the compiled model of :mod:`roadgrip.sim.mb_model` under this driver by
fixed-step RK4, the driver's commands held over each step, the surface under
the vehicle's CG looked up at the start of each step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import NDArray

from roadgrip.sim.engine import field_surface, nearest_on_path
from roadgrip.sim.mb_model import WHEEL_SIZE, MBState, compiled_rhs, wheel_forces

__all__ = ["SLIP_LIMIT", "MBDriver", "MBPath", "MBStepping", "Path", "integrate_mb"]

SLIP_LIMIT = 0.08
"""Longitudinal wheel slip above which the ABS / TCS reduces the command [-]."""

_RHS = compiled_rhs().mb

# The state entries the driver reads, as module constants (numba freezes them when it
# compiles; it cannot read the attributes of the plain class ``MBState``).
_X, _Y, _STEER, _VX, _PSI, _YAW_RATE, _VY = (MBState.X, MBState.Y, MBState.STEER, MBState.VX, MBState.PSI,
                                             MBState.YAW_RATE, MBState.VY)
_OMEGA_0 = MBState.OMEGA_LF
"""First of the four wheel speeds (``LF, RF, LR, RR``)."""

# Entries of the package's input vector ``u``.
_U_STEER_RATE, _U_ACCEL = 0, 1
_U_SIZE = 2


class MBStepping(NamedTuple):
    """Time stepping of :func:`integrate_mb`: internal step [s], recorded steps after the
    pre-roll, unrecorded pre-roll steps (straight, at the initial speed), output stride."""

    dt: float
    n_steps: int
    n_settle: int
    stride: int


class MBPath(NamedTuple):
    """A path as the compiled driver takes it (:meth:`Path.encode`): points [m], speed
    profile [m/s], its acceleration ``v dv/ds`` [m/s²], and whether it is a loop."""

    x: np.ndarray
    y: np.ndarray
    v: np.ndarray
    a: np.ndarray
    closed: bool


class MBDriver(NamedTuple):
    """Gains of the multi-body driver.

    Pure-pursuit look-ahead ``lookahead0 + lookahead_gain vx`` [m, s]; the speed
    profile is read ``preview`` ahead [s]; steering servo gain ``k_steer`` [1/s]
    (steering rate ``k_steer (delta_ref - delta)``); PI speed gains ``kp``, ``ki``
    [1/s, 1/s²]; ABS / TCS threshold ``slip_limit`` on the longitudinal wheel slip [-].
    """

    lookahead0: float
    lookahead_gain: float
    preview: float
    k_steer: float
    kp: float
    ki: float
    slip_limit: float


@njit(cache=True)
def _rhs_into(x, u, p, xs, out):
    """The package's right-hand side at ``x`` (copied to ``xs`` first: it clips wheel speeds)."""
    for i in range(x.shape[0]):
        xs[i] = x[i]
    f = _RHS(xs, u, p)
    for i in range(x.shape[0]):
        out[i] = f[i]


@njit(cache=True)
def _rk4(x, u, p, h, k1, k2, k3, k4, tmp, xs):
    n = x.shape[0]
    _rhs_into(x, u, p, xs, k1)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k1[i]
    _rhs_into(tmp, u, p, xs, k2)
    for i in range(n):
        tmp[i] = x[i] + 0.5 * h * k2[i]
    _rhs_into(tmp, u, p, xs, k3)
    for i in range(n):
        tmp[i] = x[i] + h * k3[i]
    _rhs_into(tmp, u, p, xs, k4)
    for i in range(n):
        x[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
    # the package forbids negative wheel spin
    for i in range(_OMEGA_0, _OMEGA_0 + 4):
        if x[i] < 0.0:
            x[i] = 0.0


@njit(cache=True)
def _next_on_path(j, n, closed):
    """The point after ``j`` on a path of ``n`` points; -1 past the end of an open path."""
    if j + 1 < n:
        return j + 1
    return 0 if closed else -1


@njit(cache=True)
def _max_wheel_slip(x, p):
    """Largest braking slip and largest driving slip over the four wheels [-]."""
    vx = x[_VX]
    r = x[_YAW_RATE]
    brk = 0.0
    drv = 0.0
    if vx < 1.0:
        return brk, drv
    for i in range(4):
        half = 0.5 * (p.T_f if i < 2 else p.T_r)
        sgn = 1.0 if i % 2 == 0 else -1.0
        uw = vx + sgn * half * r
        if i < 2:
            uw = uw * math.cos(x[_STEER]) + (x[_VY] + p.a * r) * math.sin(x[_STEER])
        uw = max(uw, 0.5)
        s = 1.0 - p.R_w * x[_OMEGA_0 + i] / uw
        brk = max(brk, s)
        drv = max(drv, -s)
    return brk, drv


@njit(cache=True)
def _pursuit(path, drv, x, idx, wb):
    """Pure-pursuit road-wheel angle target [rad] and the speed reference [m/s] read
    ahead along the :class:`MBPath` ``path`` from the state ``x``; ``idx``: nearest point."""
    npath = path.x.shape[0]
    vx = max(x[_VX], 0.0)
    la = drv.lookahead0 + drv.lookahead_gain * vx
    j = idx
    for _ in range(npath):
        jn = _next_on_path(j, npath, path.closed)
        if jn < 0:
            break
        dxp = path.x[jn] - x[_X]
        dyp = path.y[jn] - x[_Y]
        j = jn
        if dxp * dxp + dyp * dyp >= la * la:
            break
    dxp = path.x[j] - x[_X]
    dyp = path.y[j] - x[_Y]
    cp = math.cos(x[_PSI])
    sp = math.sin(x[_PSI])
    lx = cp * dxp + sp * dyp
    ly = -sp * dxp + cp * dyp
    ld2 = max(lx * lx + ly * ly, 1e-6)
    delta_ref = math.atan(2.0 * wb * ly / ld2)
    # speed reference previewed along the path
    dist = drv.preview * vx
    jj = idx
    acc = 0.0
    vr = path.v[idx]
    for _ in range(npath):
        jn = _next_on_path(jj, npath, path.closed)
        if jn < 0:
            break
        acc += math.sqrt((path.x[jn] - path.x[jj]) ** 2 + (path.y[jn] - path.y[jj]) ** 2)
        jj = jn
        vr = min(vr, path.v[jj])
        if acc >= dist:
            break
    return delta_ref, vr


@njit(cache=True)
def integrate_mb(x0, steps, params, path, driver, field):
    """RK4 of the multi-body model with its path-following driver (module docstring).

    Parameters
    ----------
    x0 : ndarray, shape (29,)
        Initial state (``init_mb``, :class:`~roadgrip.sim.mb_model.MBState` layout); the
        pre-roll starts from it.
    steps : MBStepping
        Internal step ``dt`` [s], ``n_steps`` recorded steps after ``n_settle`` unrecorded
        pre-roll steps (straight, speed held at ``x0``'s speed); every ``stride``-th step
        is recorded (the output rate).
    params : tuple of MBParameters
        One parameter tuple per surface index of the friction field.
    path : MBPath
        Path points [m], speed profile [m/s] and its acceleration [m/s²], with
        ``(path.x[0], path.y[0])`` the start of the recorded drive; ``closed``: a loop.
    driver : MBDriver
        Look-ahead, preview, steering servo, PI speed and ABS / TCS gains.
    field : FieldCode
        Friction field encoding (:func:`roadgrip.sim.engine.field_code`).

    Returns
    -------
    states : ndarray, shape (n_out, 29)
    derivs : ndarray, shape (n_out, 29)
        Right-hand side at the recorded states with the inputs applied from them.
    inputs : ndarray, shape (n_out, 2)
        Steering rate [rad/s] and acceleration command [m/s²] from the recorded states.
    wheels : ndarray, shape (n_out, 4, WHEEL_SIZE)
        :func:`~roadgrip.sim.mb_model.wheel_forces` at the recorded states.
    surf : ndarray, shape (n_out,)
        Surface index at the recorded states.
    """
    dt = steps.dt
    n_steps = steps.n_steps
    stride = steps.stride
    n = x0.shape[0]
    n_out = n_steps // stride + 1
    states = np.empty((n_out, n))
    derivs = np.empty((n_out, n))
    inputs = np.empty((n_out, _U_SIZE))
    wheels = np.empty((n_out, 4, WHEEL_SIZE))
    surf = np.empty(n_out, dtype=np.int64)
    x = x0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    xs = np.empty(n)
    u = np.zeros(_U_SIZE)
    p0 = params[0]
    wb = p0.a + p0.b
    v0 = x0[_VX]
    integ = 0.0
    k_brake = 1.0
    k_drive = 1.0
    idx = 0
    for k in range(-steps.n_settle, n_steps + 1):
        if k == 0:
            # place the settled car at the start of the path, heading along it
            x[_X] = path.x[0]
            x[_Y] = path.y[0]
            x[_PSI] = math.atan2(path.y[1] - path.y[0], path.x[1] - path.x[0])
            idx = 0
        t = k * dt
        if k < 0:
            si = field.base if field.mode != 1 else field.time_idx[0]
            delta_ref = 0.0
            vr = v0
            ar = 0.0
        else:
            si = field_surface(field, t, x[_X], x[_Y])
            idx = nearest_on_path(path.x, path.y, x[_X], x[_Y], idx, 20, 200, path.closed)
            delta_ref, vr = _pursuit(path, driver, x, idx, wb)
            ar = path.a[idx]
        p = params[si]
        u[_U_STEER_RATE] = driver.k_steer * (delta_ref - x[_STEER])
        e = vr - x[_VX]
        a_cmd = ar + driver.kp * e + driver.ki * integ
        if abs(a_cmd) < p.longitudinal.a_max:
            integ += e * dt
        brk, drv = _max_wheel_slip(x, p)
        if brk > driver.slip_limit:
            k_brake = max(k_brake - 20.0 * dt, 0.0)
        else:
            k_brake = min(k_brake + 4.0 * dt, 1.0)
        if drv > driver.slip_limit:
            k_drive = max(k_drive - 20.0 * dt, 0.0)
        else:
            k_drive = min(k_drive + 4.0 * dt, 1.0)
        u[_U_ACCEL] = a_cmd * (k_brake if a_cmd < 0.0 else k_drive)
        if k >= 0 and k % stride == 0:
            o = k // stride
            states[o] = x
            inputs[o, _U_STEER_RATE] = u[_U_STEER_RATE]
            inputs[o, _U_ACCEL] = u[_U_ACCEL]
            surf[o] = si
            _rhs_into(x, u, p, xs, tmp)
            derivs[o] = tmp
            wheel_forces(x, p, wheels[o])
        if k == n_steps:
            break
        _rk4(x, u, p, dt, k1, k2, k3, k4, tmp, xs)
    return states, derivs, inputs, wheels, surf


@dataclass(frozen=True, eq=False)
class Path:
    """A path for the driver: points, speed profile, open or closed.

    Attributes
    ----------
    x, y : ndarray, shape (n,)
        Points [m], spaced about evenly; the drive starts at the first.
    v : ndarray, shape (n,)
        Speed reference at each point [m/s].
    closed : bool
        The last point connects back to the first.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    v: NDArray[np.float64]
    closed: bool = False

    def __post_init__(self) -> None:
        n = len(self.x)
        if n < 3 or len(self.y) != n or len(self.v) != n:
            raise ValueError("a path needs at least 3 points with matching x, y and v")
        for name in ("x", "y", "v"):
            arr = np.asarray(getattr(self, name), float)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"path {name} must be finite")
            object.__setattr__(self, name, arr)
        if np.any(self.v <= 0):
            raise ValueError("path speeds must be positive")

    def arc_length(self) -> NDArray[np.float64]:
        """Distance along the path from the first point [m], shape (n,)."""
        return np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(self.x), np.diff(self.y)))])

    def acceleration(self) -> NDArray[np.float64]:
        """Feed-forward acceleration ``v dv/ds`` along the path [m/s²], shape (n,)."""
        s = self.arc_length()
        return 0.5 * np.gradient(self.v**2, s)

    def encode(self) -> MBPath:
        """The path as :func:`integrate_mb` takes it."""
        return MBPath(self.x, self.y, self.v, self.acceleration(), bool(self.closed))
