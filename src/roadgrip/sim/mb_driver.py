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

import numpy as np
from numba import njit
from numpy.typing import NDArray

from roadgrip.sim.engine import nearest_on_path, surface_index
from roadgrip.sim.mb_model import WHEEL_SIZE, compiled_rhs, wheel_forces

__all__ = ["SLIP_LIMIT", "Path", "integrate_mb"]

SLIP_LIMIT = 0.08
"""Longitudinal wheel slip above which the ABS / TCS reduces the command [-]."""

_RHS = compiled_rhs().mb


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
    for i in range(23, 27):
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
    vx = x[3]
    r = x[5]
    brk = 0.0
    drv = 0.0
    if vx < 1.0:
        return brk, drv
    for i in range(4):
        half = 0.5 * (p.T_f if i < 2 else p.T_r)
        sgn = 1.0 if i % 2 == 0 else -1.0
        uw = vx + sgn * half * r
        if i < 2:
            uw = uw * math.cos(x[2]) + (x[10] + p.a * r) * math.sin(x[2])
        uw = max(uw, 0.5)
        s = 1.0 - p.R_w * x[23 + i] / uw
        brk = max(brk, s)
        drv = max(drv, -s)
    return brk, drv


@njit(cache=True)
def integrate_mb(
    x0, dt, n_steps, n_settle, stride, params,
    path_x, path_y, path_v, path_a, closed, lookahead0, lookahead_gain, preview,
    k_steer, kp, ki, slip_limit,
    mode, times, time_idx, rects, rect_idx, n_rects, base,
):
    """RK4 of the multi-body model with its path-following driver (module docstring).

    Parameters
    ----------
    x0 : ndarray, shape (29,)
        Initial state (``init_mb``); the pre-roll starts from it.
    dt : float
        Internal step [s].
    n_steps : int
        Recorded steps after the pre-roll.
    n_settle : int
        Unrecorded pre-roll steps (straight, speed held at ``x0``'s speed).
    stride : int
        Record every ``stride``-th step (the output rate).
    params : tuple of MBParameters
        One parameter tuple per surface index of the friction field.
    path_x, path_y, path_v, path_a : ndarray, shape (n_path,)
        Path points [m], speed profile [m/s] and its acceleration ``v dv/ds``
        [m/s²], with ``(path_x[0], path_y[0])`` the start of the recorded drive.
    closed : bool
        The path is a loop.
    lookahead0, lookahead_gain : float
        Pure-pursuit look-ahead ``lookahead0 + lookahead_gain vx`` [m, s].
    preview : float
        The speed profile is read this far ahead [s].
    k_steer : float
        Steering servo gain [1/s]: steering rate ``k_steer (delta_ref - delta)``.
    kp, ki : float
        PI speed gains [1/s, 1/s²].
    slip_limit : float
        ABS / TCS threshold on the longitudinal wheel slip [-].
    mode, times, time_idx, rects, rect_idx, n_rects, base
        Friction field encoding (``FrictionField.encode``).

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
    n = x0.shape[0]
    n_out = n_steps // stride + 1
    states = np.empty((n_out, n))
    derivs = np.empty((n_out, n))
    inputs = np.empty((n_out, 2))
    wheels = np.empty((n_out, 4, WHEEL_SIZE))
    surf = np.empty(n_out, dtype=np.int64)
    x = x0.copy()
    k1 = np.empty(n)
    k2 = np.empty(n)
    k3 = np.empty(n)
    k4 = np.empty(n)
    tmp = np.empty(n)
    xs = np.empty(n)
    u = np.zeros(2)
    p0 = params[0]
    wb = p0.a + p0.b
    v0 = x0[3]
    integ = 0.0
    k_brake = 1.0
    k_drive = 1.0
    npath = path_x.shape[0]
    idx = 0
    for k in range(-n_settle, n_steps + 1):
        if k == 0:
            # place the settled car at the start of the path, heading along it
            x[0] = path_x[0]
            x[1] = path_y[0]
            x[4] = math.atan2(path_y[1] - path_y[0], path_x[1] - path_x[0])
            idx = 0
        t = k * dt
        if k < 0:
            si = base if mode != 1 else time_idx[0]
            delta_ref = 0.0
            vr = v0
            ar = 0.0
        else:
            si = surface_index(mode, t, x[0], x[1], times, time_idx, rects, rect_idx, n_rects, base)
            idx = nearest_on_path(path_x, path_y, x[0], x[1], idx, 20, 200, closed)
            vx = max(x[3], 0.0)
            la = lookahead0 + lookahead_gain * vx
            j = idx
            for _ in range(npath):
                jn = _next_on_path(j, npath, closed)
                if jn < 0:
                    break
                dxp = path_x[jn] - x[0]
                dyp = path_y[jn] - x[1]
                j = jn
                if dxp * dxp + dyp * dyp >= la * la:
                    break
            dxp = path_x[j] - x[0]
            dyp = path_y[j] - x[1]
            cp = math.cos(x[4])
            sp = math.sin(x[4])
            lx = cp * dxp + sp * dyp
            ly = -sp * dxp + cp * dyp
            ld2 = max(lx * lx + ly * ly, 1e-6)
            delta_ref = math.atan(2.0 * wb * ly / ld2)
            # speed reference previewed along the path
            dist = preview * vx
            jj = idx
            acc = 0.0
            vr = path_v[idx]
            for _ in range(npath):
                jn = _next_on_path(jj, npath, closed)
                if jn < 0:
                    break
                acc += math.sqrt((path_x[jn] - path_x[jj]) ** 2 + (path_y[jn] - path_y[jj]) ** 2)
                jj = jn
                vr = min(vr, path_v[jj])
                if acc >= dist:
                    break
            ar = path_a[idx]
        p = params[si]
        u[0] = k_steer * (delta_ref - x[2])
        e = vr - x[3]
        a_cmd = ar + kp * e + ki * integ
        if abs(a_cmd) < p.longitudinal.a_max:
            integ += e * dt
        brk, drv = _max_wheel_slip(x, p)
        if brk > slip_limit:
            k_brake = max(k_brake - 20.0 * dt, 0.0)
        else:
            k_brake = min(k_brake + 4.0 * dt, 1.0)
        if drv > slip_limit:
            k_drive = max(k_drive - 20.0 * dt, 0.0)
        else:
            k_drive = min(k_drive + 4.0 * dt, 1.0)
        u[1] = a_cmd * (k_brake if a_cmd < 0.0 else k_drive)
        if k >= 0 and k % stride == 0:
            o = k // stride
            states[o] = x
            inputs[o, 0] = u[0]
            inputs[o, 1] = u[1]
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
