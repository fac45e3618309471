r"""Multi-body engine: CommonRoad's ``vehicle_dynamics_mb`` driven along a path.

The truth of this engine is a vehicle model that none of roadgrip's estimators
assumes: the multi-body model of the CommonRoad vehicle models (package
``commonroad-vehicle-models`` 3.0.2, module ``vehiclemodels.vehicle_dynamics_mb``;
Althoff and Würsching, "CommonRoad: Vehicle Models", 2020). Its 29 states carry
the sprung mass in roll, pitch and heave, front and rear unsprung masses with
their own roll and heave, four wheels with their own spin dynamics, and
compliant joints; the tires are PAC2002 Magic Formula with combined slip and
load- and camber-dependent forces.

The package's functions are used as they are: :func:`compiled_rhs` compiles the
package's own Python code of ``vehicle_dynamics_mb`` and of its tire, steering
and acceleration functions with numba (the same code objects, with their global
names bound to the compiled versions), so that an RK4 step at 1 kHz costs
microseconds. The test suite checks the compiled right-hand side against the
package's Python function.

Conventions and adaptations
---------------------------
* **Friction.** A surface of peak friction ``mu`` scales the tire's peak
  coefficients ``p_dx1`` and ``p_dy1`` and the vertical shift ``p_vx1`` by
  ``mu / p_dx1`` and ``mu / p_dy1`` of the nominal tire, so that both the
  pure-slip longitudinal and lateral peaks ``F / F_z`` equal ``mu`` at zero
  camber. The slip stiffnesses (``p_kx1``, ``p_ky1``) are kept, so the slip of
  the peak shrinks on a slippery surface, as on real tires. The surface under
  the vehicle's CG is looked up at the start of each 1 ms step.
* **Camber-gated shifts.** The package multiplies ``p_hy1``, ``p_hy3``,
  ``p_vy1`` and ``p_vy3`` by ``sign(camber)``, which makes ``F_y`` jump when a
  camber crosses zero; they are set to zero.
* **Settling.** The package's ``init_mb`` state is not an equilibrium of the
  suspension; every drive starts with an unrecorded straight pre-roll at the
  initial speed (:data:`SETTLE_TIME`) so that the heave and pitch transients
  have died out before ``t = 0``.
* **Integration.** Fixed-step RK4 at :data:`INTERNAL_RATE` (stable for
  5-25 m/s); the driver's commands are held over each step.
* **Wheel names.** The package calls ``L`` the wheels on the *right* of ISO
  8855 axes (y to the left, yaw counter-clockwise): its ``u_w_lf = (vx + T/2 r)
  cos(delta) + ...``, its normal loads and its roll angle all agree on that, and
  its roll and pitch angles are the negatives of ISO's (roll positive left side
  down, pitch positive nose up). roadgrip's columns are ISO: ``omega_fl`` is the
  package's ``RF`` wheel speed (:data:`WHEEL_SENSOR_STATE`), and the body
  angles are negated before the accelerometer and gyro are modelled. The truth
  uses axle sums, which do not depend on the naming.

The driver
----------
A closed-loop driver follows a path given as points with a speed profile:
pure pursuit for the steering (a road-wheel angle target; the package's
steering-rate input is a proportional servo onto it and the package's own rate
limit applies), a PI speed controller with the path's acceleration as feed-
forward for the package's acceleration input, and a simple anti-lock and
traction control that scales the acceleration command down while any wheel's
longitudinal slip exceeds :data:`SLIP_LIMIT`.
"""

from __future__ import annotations

import dataclasses
import math
import types
from collections import namedtuple
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import pandas as pd
from numba import njit
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.drive import Drive
from roadgrip.signals import wheel_centre_speeds
from roadgrip.sim.engine import nearest_on_path, surface_index
from roadgrip.sim.friction import FrictionField
from roadgrip.sim.sensors import SensorSpec, apply_sensors, sensors_to_dict
from roadgrip.vehicle.params import VehicleParams
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles

__all__ = [
    "COMMONROAD_VEHICLES",
    "INTERNAL_RATE",
    "MB_SENSOR_COLUMNS",
    "SETTLE_TIME",
    "SLIP_LIMIT",
    "WHEEL_SENSOR_STATE",
    "MBState",
    "Path",
    "commonroad_parameters",
    "compiled_rhs",
    "integrate_mb",
    "parameter_tuple",
    "simulate_multibody",
    "tire_overrides",
    "vehicle_from_commonroad",
    "wheel_forces",
]

COMMONROAD_VEHICLES: dict[str, int] = {"ford-escort": 1, "vw-vanagon": 3}
"""roadgrip preset name -> CommonRoad parameter-set id."""

INTERNAL_RATE = 1000.0
"""Integration rate of the multi-body engine [Hz]."""

SETTLE_TIME = 3.0
"""Unrecorded straight pre-roll before ``t = 0`` [s]."""

MAX_SURFACES = 4
"""Most surface labels one multi-body drive can use."""

SLIP_LIMIT = 0.08
"""Longitudinal wheel slip above which the ABS / TCS reduces the command [-]."""


class MBState:
    """Index layout of the 29 multi-body states (the package's ``x1 .. x29``)."""

    X = 0
    Y = 1
    STEER = 2
    VX = 3
    PSI = 4
    YAW_RATE = 5
    ROLL = 6
    ROLL_RATE = 7
    PITCH = 8
    PITCH_RATE = 9
    VY = 10
    Z = 11
    VZ = 12
    ROLL_F = 13
    ROLL_RATE_F = 14
    VY_F = 15
    Z_F = 16
    VZ_F = 17
    ROLL_R = 18
    ROLL_RATE_R = 19
    VY_R = 20
    Z_R = 21
    VZ_R = 22
    OMEGA_LF = 23
    OMEGA_RF = 24
    OMEGA_LR = 25
    OMEGA_RR = 26
    DELTA_Y_F = 27
    DELTA_Y_R = 28
    SIZE = 29


WHEEL_SENSOR_STATE: dict[str, int] = {
    "omega_fl": MBState.OMEGA_RF,
    "omega_fr": MBState.OMEGA_LF,
    "omega_rl": MBState.OMEGA_RR,
    "omega_rr": MBState.OMEGA_LR,
}
"""roadgrip wheel-speed column -> package state, placed by wheel kinematics (module docstring)."""

_CAMBER_GATED = ("p_hy1", "p_hy3", "p_vy1", "p_vy3")


# ---------------------------------------------------------------------------------------
# the package, compiled
# ---------------------------------------------------------------------------------------
def _rejit(fn, names: dict[str, Any]):
    """``fn``'s own code object with some global names rebound, compiled by numba."""
    glb = dict(fn.__globals__)
    glb.update(names)
    new = types.FunctionType(fn.__code__, glb, fn.__name__, fn.__defaults__, fn.__closure__)
    new.__qualname__ = fn.__qualname__
    new.__module__ = fn.__module__
    return njit(new)


@cache
def compiled_rhs():
    """The package's ``vehicle_dynamics_mb`` and tire functions, compiled.

    Returns
    -------
    types.SimpleNamespace
        ``mb(x, u, p)`` (right-hand side; ``x`` ndarray (29,), ``u`` ndarray (2,),
        ``p`` a :func:`parameter_tuple`; returns a list of 29 floats, and clips
        negative wheel speeds in ``x`` as the package does), and the tire
        functions ``formula_longitudinal``, ``formula_lateral``,
        ``formula_longitudinal_comb``, ``formula_lateral_comb``.
    """
    import vehiclemodels.utils.acceleration_constraints as acc
    import vehiclemodels.utils.steering_constraints as steer
    import vehiclemodels.utils.tire_model as tire
    import vehiclemodels.utils.vehicle_dynamics_ks_cog as ks
    import vehiclemodels.vehicle_dynamics_mb as mb

    sign = _rejit(tire.sign, {})
    tire_fns = {
        name: _rejit(getattr(tire, name), {"sign": sign})
        for name in ("formula_longitudinal", "formula_lateral",
                     "formula_longitudinal_comb", "formula_lateral_comb")
    }
    tire_module = types.ModuleType("roadgrip_compiled_tire_model")
    for k, v in tire_fns.items():
        setattr(tire_module, k, v)
    sc = _rejit(steer.steering_constraints, {})
    ac = _rejit(acc.acceleration_constraints, {})
    ks_cog = _rejit(ks.vehicle_dynamics_ks_cog, {"steering_constraints": sc, "acceleration_constraints": ac})
    rhs = _rejit(mb.vehicle_dynamics_mb, {
        "steering_constraints": sc, "acceleration_constraints": ac,
        "vehicle_dynamics_ks_cog": ks_cog, "tireModel": tire_module,
    })
    return types.SimpleNamespace(mb=rhs, steering_constraints=sc, acceleration_constraints=ac, **tire_fns)


@cache
def commonroad_parameters(vehicle_id: int):
    """The package's parameter set ``vehicle_id`` (1: Ford Escort, 3: VW Vanagon)."""
    from vehiclemodels.vehicle_parameters import setup_vehicle_parameters

    return setup_vehicle_parameters(vehicle_id=vehicle_id)


def _tuple_classes() -> dict[str, type]:
    """Named-tuple twins of the package's parameter dataclasses, defined in this module
    (so that numba can cache the compiled functions that take them)."""
    from vehiclemodels.vehicle_parameters import VehicleParameters

    classes: dict[str, type] = {}

    def make(dc, name: str) -> type:
        names = []
        for f in dataclasses.fields(dc):
            names.append(f.name)
            sub = f.default_factory if f.default_factory is not dataclasses.MISSING else None
            if sub is not None and dataclasses.is_dataclass(sub):
                make(sub, f"MB{sub.__name__}")
        cls = namedtuple(name, names)
        cls.__module__ = __name__
        classes[name] = cls
        return cls

    make(VehicleParameters, "MBParameters")
    return classes


_CLASSES = _tuple_classes()
globals().update(_CLASSES)


def _namedtuple_of(obj, name: str, overrides: dict[str, Any]):
    values = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if dataclasses.is_dataclass(v):
            v = _namedtuple_of(v, f"MB{type(v).__name__}", overrides.get(f.name, {}))
        else:
            v = float("nan") if v is None else float(overrides.get(f.name, v))
        values[f.name] = v
    return _CLASSES[name](**values)


def tire_overrides(params, mu: float) -> dict[str, float]:
    """Tire coefficients changed for a surface of peak friction ``mu`` (module docstring)."""
    t = params.tire
    if not (np.isfinite(mu) and mu > 0):
        raise ValueError(f"surface friction must be positive and finite, got {mu!r}")
    sx = mu / t.p_dx1
    sy = mu / t.p_dy1
    out = {"p_dx1": t.p_dx1 * sx, "p_vx1": t.p_vx1 * sx, "p_dy1": t.p_dy1 * sy}
    out.update({k: 0.0 for k in _CAMBER_GATED})
    return out


def parameter_tuple(vehicle_id: int, mu: float | None = None, *, camber_shifts: bool = False):
    """The package's parameters as a numba-friendly named tuple.

    Parameters
    ----------
    vehicle_id : int
        CommonRoad parameter set.
    mu : float, optional
        Surface peak friction; None keeps the package's tire unchanged.
    camber_shifts : bool
        Keep the camber-gated shifts (only for comparisons with the package).
    """
    p = commonroad_parameters(vehicle_id)
    over: dict[str, float] = {}
    if mu is not None:
        over = tire_overrides(p, mu)
    if camber_shifts:
        over = {k: v for k, v in over.items() if k not in _CAMBER_GATED}
    elif mu is None:
        over = dict.fromkeys(_CAMBER_GATED, 0.0)
    return _namedtuple_of(p, "MBParameters", {"tire": over})


# ---------------------------------------------------------------------------------------
# per-wheel tire quantities (the package's own kinematics and tire calls)
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def _wheel_inputs(x, p, out):
    """Normal load, longitudinal slip, slip angle and camber of each wheel.

    The lines of ``vehicle_dynamics_mb`` before its tire calls; ``out`` has
    shape (4, 4): rows ``LF, RF, LR, RR``, columns ``F_z, s, alpha, gamma``
    (the package's signs: ``s > 0`` braking, ``alpha`` opposite to ISO's).
    """
    R = p.R_w
    Kzt = p.K_zt
    Tf = p.T_f
    Tr = p.T_r
    out[0, 0] = (x[16] + R * (math.cos(x[13]) - 1) - 0.5 * Tf * math.sin(x[13])) * Kzt
    out[1, 0] = (x[16] + R * (math.cos(x[13]) - 1) + 0.5 * Tf * math.sin(x[13])) * Kzt
    out[2, 0] = (x[21] + R * (math.cos(x[18]) - 1) - 0.5 * Tr * math.sin(x[18])) * Kzt
    out[3, 0] = (x[21] + R * (math.cos(x[18]) - 1) + 0.5 * Tr * math.sin(x[18])) * Kzt
    uw = np.empty(4)
    uw[0] = (x[3] + 0.5 * Tf * x[5]) * math.cos(x[2]) + (x[10] + p.a * x[5]) * math.sin(x[2])
    uw[1] = (x[3] - 0.5 * Tf * x[5]) * math.cos(x[2]) + (x[10] + p.a * x[5]) * math.sin(x[2])
    uw[2] = x[3] + 0.5 * Tr * x[5]
    uw[3] = x[3] - 0.5 * Tr * x[5]
    for i in range(4):
        if uw[i] < 0.0:
            uw[i] = 0.0
        out[i, 1] = 0.0 if abs(x[3]) < 0.1 else 1 - R * x[23 + i] / uw[i]
    if abs(x[3]) < 0.1:
        for i in range(4):
            out[i, 2] = 0.0
    else:
        vf = x[10] + p.a * x[5] - x[14] * (R - x[16])
        vr = x[10] - p.b * x[5] - x[19] * (R - x[21])
        out[0, 2] = math.atan(vf / (x[3] + 0.5 * Tf * x[5])) - x[2]
        out[1, 2] = math.atan(vf / (x[3] - 0.5 * Tf * x[5])) - x[2]
        out[2, 2] = math.atan(vr / (x[3] + 0.5 * Tr * x[5]))
        out[3, 2] = math.atan(vr / (x[3] - 0.5 * Tr * x[5]))
    hs = p.h_s
    z_lf = (hs - R + x[16] - x[11]) / math.cos(x[6]) - hs + R + p.a * x[8] + 0.5 * (x[6] - x[13]) * Tf
    z_rf = (hs - R + x[16] - x[11]) / math.cos(x[6]) - hs + R + p.a * x[8] - 0.5 * (x[6] - x[13]) * Tf
    z_lr = (hs - R + x[21] - x[11]) / math.cos(x[6]) - hs + R - p.b * x[8] + 0.5 * (x[6] - x[18]) * Tr
    z_rr = (hs - R + x[21] - x[11]) / math.cos(x[6]) - hs + R - p.b * x[8] - 0.5 * (x[6] - x[18]) * Tr
    out[0, 3] = x[6] + p.D_f * z_lf + p.E_f * z_lf**2
    out[1, 3] = x[6] - p.D_f * z_rf - p.E_f * z_rf**2
    out[2, 3] = x[6] + p.D_r * z_lr + p.E_r * z_lr**2
    out[3, 3] = x[6] - p.D_r * z_rr - p.E_r * z_rr**2


_PKG = compiled_rhs()
_RHS = _PKG.mb
_F_LONG = _PKG.formula_longitudinal
_F_LAT = _PKG.formula_lateral
_F_LONG_COMB = _PKG.formula_longitudinal_comb
_F_LAT_COMB = _PKG.formula_lateral_comb

WHEEL_FZ, WHEEL_FX, WHEEL_FY, WHEEL_MU_X, WHEEL_MU_Y, WHEEL_SLIP, WHEEL_ALPHA, WHEEL_CAMBER = range(8)
WHEEL_SIZE = 8
"""Column layout of the per-wheel truth of :func:`wheel_forces` (package signs)."""


@njit(cache=True)
def wheel_forces(x, p, out):
    """Forces of the four tires by the package's own tire calls.

    Parameters
    ----------
    x : ndarray, shape (29,)
    p : MBParameters
    out : ndarray, shape (4, WHEEL_SIZE)
        Rows ``LF, RF, LR, RR`` (the package's names); columns ``F_z`` [N],
        combined-slip ``F_x``, ``F_y`` [N] in the wheel frame (``F_y`` positive to
        the left), the pure-slip peaks ``mu_x``, ``mu_y`` [-] at the wheel's camber,
        the package's longitudinal slip and slip angle, and the camber [rad].
    """
    inp = np.empty((4, 4))
    _wheel_inputs(x, p, inp)
    t = p.tire
    for i in range(4):
        fz = inp[i, 0]
        s = inp[i, 1]
        a = inp[i, 2]
        g = inp[i, 3]
        f0x = _F_LONG(s, g, fz, t)
        res = _F_LAT(a, g, fz, t)
        out[i, WHEEL_FZ] = fz
        out[i, WHEEL_FX] = _F_LONG_COMB(s, a, f0x, t)
        out[i, WHEEL_FY] = _F_LAT_COMB(s, a, g, res[1], fz, res[0], t)
        out[i, WHEEL_MU_X] = t.p_dx1 * (1 - t.p_dx3 * g**2)
        out[i, WHEEL_MU_Y] = res[1]
        out[i, WHEEL_SLIP] = s
        out[i, WHEEL_ALPHA] = a
        out[i, WHEEL_CAMBER] = g


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
        :func:`wheel_forces` at the recorded states.
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


# ---------------------------------------------------------------------------------------
# vehicles
# ---------------------------------------------------------------------------------------
def vehicle_from_commonroad(name: str) -> VehicleParams:
    """roadgrip's single-track parameters of a CommonRoad vehicle.

    Derived from the package's parameter set, as a user would derive them from
    a data sheet: total mass; CG of the sprung mass and both unsprung masses
    (at their axles); yaw inertia of that rigid assembly about the CG; the
    package's CG height, rolling radius and wheel inertia; the mean of the two
    track widths; axle cornering stiffness ``|p_ky1|`` times the static axle
    load; the driven axle from the engine-torque split ``T_se``; the steering
    limit.

    Parameters
    ----------
    name : str
        Key of :data:`COMMONROAD_VEHICLES`.
    """
    try:
        vid = COMMONROAD_VEHICLES[name]
    except KeyError:
        raise ValueError(f"unknown multi-body vehicle {name!r}; known: {sorted(COMMONROAD_VEHICLES)}") from None
    p = commonroad_parameters(vid)
    wb = p.a + p.b
    lf = (p.m_s * p.a + p.m_ur * wb) / p.m
    lr = wb - lf
    iz = p.I_z + p.m_s * (p.a - lf) ** 2 + p.m_uf * lf**2 + p.m_ur * lr**2
    fzf = p.m * GRAVITY * lr / wb
    fzr = p.m * GRAVITY * lf / wb
    ky = abs(p.tire.p_ky1)
    drive = "fwd" if p.T_se >= 0.99 else ("rwd" if p.T_se <= 0.01 else "awd")
    return VehicleParams(
        name=name, mass=p.m, yaw_inertia=iz, lf=lf, lr=lr, cg_height=p.h_cg,
        wheel_radius=p.R_w, track_width=0.5 * (p.T_f + p.T_r), wheel_inertia=p.I_y_w,
        cornering_stiffness_front=ky * fzf, cornering_stiffness_rear=ky * fzr,
        drive=drive, max_steer=p.steering.max, gear_ratio=1.0,
    )


# ---------------------------------------------------------------------------------------
# paths
# ---------------------------------------------------------------------------------------
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


# ---------------------------------------------------------------------------------------
# simulation
# ---------------------------------------------------------------------------------------
MB_SENSOR_COLUMNS = (
    "ax", "ay", "yaw_rate", "steer", "vx",
    "omega_fl", "omega_fr", "omega_rl", "omega_rr", "x", "y", "psi",
)


_PKG_G = 9.81
"""Gravity inside the package's equations [m/s²]."""


def _specific_force(states, derivs, vehicle, p) -> tuple[NDArray, ...]:
    """Accelerometer at the CG in body axes [m/s²], the body-z angular rate [rad/s],
    and the CG's acceleration in the yaw-aligned horizontal frame [m/s²]."""
    S = MBState
    vx, vy, r = states[:, S.VX], states[:, S.VY], states[:, S.YAW_RATE]
    d = p.a - vehicle.lf  # CG ahead of the sprung-mass centre [m]
    ax = derivs[:, S.VX] - r * vy - r * r * d
    ay = derivs[:, S.VY] + r * vx + derivs[:, S.YAW_RATE] * d
    az = _PKG_G - derivs[:, S.VZ]  # upward specific force; the package's z points down
    phi = -states[:, S.ROLL]  # ISO roll, positive right side down
    theta = -states[:, S.PITCH]  # ISO pitch, positive nose down
    ct, st = np.cos(theta), np.sin(theta)
    cf, sf = np.cos(phi), np.sin(phi)
    fx = ct * ax - st * az
    fz1 = st * ax + ct * az
    fy = cf * ay + sf * fz1
    gyro = r * ct * cf - (-states[:, S.PITCH_RATE]) * sf
    return fx, fy, gyro, ax, ay



def simulate_multibody(
    vehicle: str,
    path: Path,
    friction: FrictionField,
    mu: Mapping[str, float],
    *,
    duration: float,
    output_rate: float = 100.0,
    sensors: Mapping[str, SensorSpec] | None = None,
    seed: int = 0,
    name: str = "custom",
    truth_extra: Mapping[str, Any] | None = None,
    lookahead: tuple[float, float] = (4.0, 0.35),
    progress: bool = False,
) -> Drive:
    """Drive a CommonRoad multi-body vehicle along ``path`` and return a :class:`Drive`.

    Parameters
    ----------
    vehicle : str
        Key of :data:`COMMONROAD_VEHICLES` (``'ford-escort'``, ``'vw-vanagon'``).
    path : Path
        Where and how fast to drive.
    friction : FrictionField
        Surface label over time or position.
    mu : mapping label -> float
        Peak friction of each surface label.
    duration : float
        Recorded time [s] (after the :data:`SETTLE_TIME` pre-roll).
    output_rate : float
        Sample rate of the drive [Hz]; must divide :data:`INTERNAL_RATE`.
    sensors : mapping column -> SensorSpec, optional
        Measurement models (columns without one are exact).
    seed : int
        Seeds the sensor noise.
    name : str
        Scenario name (``meta.source = 'sim:<name>'``).
    truth_extra : mapping, optional
        Extra entries for ``meta.truth``.
    lookahead : (float, float)
        Pure-pursuit look-ahead at standstill [m] and its growth with speed [s].
    progress : bool
        Show a status line while integrating.

    Returns
    -------
    Drive
        Sensor columns, the truth columns of :data:`roadgrip.drive.TRUTH_COLUMNS`
        (``util_f_true`` / ``util_r_true``: axle friction utilisation, the axle's
        force over its friction ellipse, the per-wheel peaks at their camber
        weighted by load), and ``meta.truth`` with ``model = 'multibody'``.
    """
    vp = vehicle_from_commonroad(vehicle)
    vid = COMMONROAD_VEHICLES[vehicle]
    if duration <= 0 or not np.isfinite(duration):
        raise ValueError(f"duration must be positive, got {duration!r}")
    stride = round(INTERNAL_RATE / output_rate)
    if stride < 1 or abs(stride * output_rate - INTERNAL_RATE) > 1e-6:
        raise ValueError(f"output_rate must divide {INTERNAL_RATE:g} Hz, got {output_rate!r}")
    missing = [lab for lab in friction.labels if lab not in mu]
    if missing:
        raise ValueError(f"friction field uses surface(s) {missing} with no mu; given {sorted(mu)}")
    sensors = dict(sensors or {})
    unknown = sorted(set(sensors) - set(MB_SENSOR_COLUMNS))
    if unknown:
        raise ValueError(f"sensor models for unknown column(s) {unknown}; measured columns: {MB_SENSOR_COLUMNS}")
    labels = list(friction.labels)
    if len(labels) > MAX_SURFACES:
        raise ValueError(f"the multi-body engine takes at most {MAX_SURFACES} surfaces, got {len(labels)}")
    params = [parameter_tuple(vid, float(mu[lab])) for lab in labels]
    # a fixed-length tuple: one compiled integrator for any number of surfaces
    params = tuple(params + [params[-1]] * (MAX_SURFACES - len(params)))
    enc = friction.encode()
    from vehiclemodels.init_mb import init_mb

    p_pkg = commonroad_parameters(vid)
    x0 = np.asarray(init_mb([0.0, 0.0, 0.0, float(path.v[0]), 0.0, 0.0, 0.0], p_pkg), float)
    dt = 1.0 / INTERNAL_RATE
    n = round(duration * INTERNAL_RATE)
    status = None
    if progress:
        from rich.console import Console

        status = Console(stderr=True).status(f"simulating {name} (multi-body, {duration:.0f} s at 1 kHz)")
        status.start()
    try:
        states, derivs, inputs, wheels, surf = integrate_mb(
            x0, dt, n, round(SETTLE_TIME * INTERNAL_RATE), stride, params,
            path.x, path.y, path.v, path.acceleration(), bool(path.closed),
            float(lookahead[0]), float(lookahead[1]), 0.6, 20.0, 1.0, 0.2, SLIP_LIMIT,
            enc["mode"], enc["times"], enc["time_idx"], enc["rects"], enc["rect_idx"],
            enc.get("n_rects", 0), enc["base"],
        )
    finally:
        if status is not None:
            status.stop()
    if not np.all(np.isfinite(states)):
        bad = int(np.argmax(~np.isfinite(states).all(1)))
        raise RuntimeError(f"multi-body simulation diverged (first non-finite state at t = {bad / output_rate:.2f} s)")
    return _drive_from_run(vp, p_pkg, states, derivs, inputs, wheels, surf, labels, mu, friction,
                           output_rate, sensors, seed, name, truth_extra, vehicle)


def _axle_truth(wheels, rows):
    fz = wheels[:, rows, WHEEL_FZ].sum(1)
    fx = wheels[:, rows, WHEEL_FX].sum(1)
    fy = wheels[:, rows, WHEEL_FY].sum(1)
    wz = np.maximum(wheels[:, rows, WHEEL_FZ], 0.0)
    tot = np.maximum(wz.sum(1), 1e-9)
    mux = (wheels[:, rows, WHEEL_MU_X] * wz).sum(1) / tot
    muy = (wheels[:, rows, WHEEL_MU_Y] * wz).sum(1) / tot
    util = np.hypot(fx / mux, fy / muy) / tot
    util = np.where(fz > 0, util, 1.0)  # a lifted axle has no grip left
    return fx, fy, fz, util


def _drive_from_run(vp, p_pkg, states, derivs, inputs, wheels, surf, labels, mu, friction,
                    output_rate, sensors, seed, name, truth_extra, vehicle_name) -> Drive:
    S = MBState
    n_out = states.shape[0]
    t = np.arange(n_out) / output_rate
    r = states[:, S.YAW_RATE]
    vx = states[:, S.VX]
    vy_cg = states[:, S.VY] + r * (p_pkg.a - vp.lf)
    steer = states[:, S.STEER]
    fx_b, fy_b, gyro, ax_h, ay_h = _specific_force(states, derivs, vp, p_pkg)
    true_meas = {
        "ax": fx_b, "ay": fy_b, "yaw_rate": gyro, "steer": steer, "vx": vx,
        "x": states[:, S.X], "y": states[:, S.Y], "psi": states[:, S.PSI],
    }
    for col, idx in WHEEL_SENSOR_STATE.items():
        true_meas[col] = states[:, idx]
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
    measured = apply_sensors(t, true_meas, t, sensors, rng)
    measured["psi"] = np.angle(np.exp(1j * measured["psi"]))
    af, ar = slip_angles(vx, vy_cg, r, steer, vp)
    fxf, fyf, fzf, uf = _axle_truth(wheels, [0, 1])
    fxr, fyr, fzr, ur = _axle_truth(wheels, [2, 3])
    mu_arr = np.array([float(mu[lab]) for lab in labels])
    centre = dict(zip(("fl", "fr", "rl", "rr"), wheel_centre_speeds(vx, vy_cg, r, steer, vp).T, strict=True))
    cols: dict[str, Any] = {"t": t}
    cols.update({k: measured[k] for k in MB_SENSOR_COLUMNS})
    cols.update(vx_true=vx, vy_true=vy_cg, yaw_rate_true=r, alpha_f_true=af, alpha_r_true=ar)
    for w in ("fl", "fr", "rl", "rr"):
        cols[f"kappa_{w}_true"] = longitudinal_slip(true_meas[f"omega_{w}"], centre[w], vp.wheel_radius)
    cols.update(
        mu_true=mu_arr[surf], Fxf_true=fxf, Fxr_true=fxr, Fyf_true=fyf, Fyr_true=fyr,
        Fzf_true=fzf, Fzr_true=fzr, util_f_true=uf, util_r_true=ur,
        x_true=states[:, S.X], y_true=states[:, S.Y], psi_true=states[:, S.PSI], steer_true=steer,
        ax_true=ax_h, ay_true=ay_h, roll_true=-states[:, S.ROLL], pitch_true=-states[:, S.PITCH],
        accel_cmd=inputs[:, 1],
    )
    cols["surface"] = np.array(labels, dtype=object)[surf]
    df = pd.DataFrame(cols)
    truth: dict[str, Any] = {
        "scenario": name,
        "seed": int(seed),
        "model": "multibody",
        "engine": "multibody",
        "vehicle_model": f"commonroad-vehicle-models vehicle_dynamics_mb, parameter set "
                         f"{COMMONROAD_VEHICLES[vehicle_name]} ({vehicle_name})",
        "internal_rate": INTERNAL_RATE,
        "settle_time": SETTLE_TIME,
        "force_frame": "wheel",
        "truth_curve": "binned",
        "surfaces": {lab: {"mu": float(mu[lab])} for lab in labels},
        "sensors": sensors_to_dict({c: sensors.get(c, SensorSpec()) for c in MB_SENSOR_COLUMNS}),
        "friction_field": dict(friction.to_dict(), mu={lab: float(mu[lab]) for lab in labels}),
    }
    truth.update(dict(truth_extra or {}))
    return Drive.from_frame(df, vp, source=f"sim:{name}", truth=truth, check_units=False)
