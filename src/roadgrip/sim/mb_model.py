r"""The CommonRoad multi-body vehicle, compiled: right-hand side, parameters, tire forces.

The truth of the multi-body engine (:mod:`roadgrip.sim.multibody`) is a vehicle
model that none of roadgrip's estimators assumes: the multi-body model of the
CommonRoad vehicle models (package ``commonroad-vehicle-models`` 3.0.2, module
``vehiclemodels.vehicle_dynamics_mb``; Althoff and Würsching, "CommonRoad:
Vehicle Models", 2020). Its 29 states (:class:`MBState`) carry the sprung mass
in roll, pitch and heave, front and rear unsprung masses with their own roll
and heave, four wheels with their own spin dynamics, and compliant joints; the
tires are PAC2002 Magic Formula with combined slip and load- and
camber-dependent forces.

The package's functions are used as they are: :func:`compiled_rhs` compiles the
package's own Python code of ``vehicle_dynamics_mb`` and of its tire, steering
and acceleration functions with numba (the same code objects, with their global
names bound to the compiled versions), so that an RK4 step at 1 kHz costs
microseconds. The package's parameter dataclasses become named tuples defined
in this module (:func:`parameter_tuple`), so that numba can compile and cache
the functions that take them. The test suite checks the compiled right-hand
side against the package's Python function.

Adaptations
-----------
* **Friction.** A surface of peak friction ``mu`` scales the tire's peak
  coefficients ``p_dx1`` and ``p_dy1`` and the vertical shift ``p_vx1`` by
  ``mu / p_dx1`` and ``mu / p_dy1`` of the nominal tire, so that both the
  pure-slip longitudinal and lateral peaks ``F / F_z`` equal ``mu`` at zero
  camber (:func:`tire_overrides`). The slip stiffnesses (``p_kx1``, ``p_ky1``)
  are kept, so the slip of the peak shrinks on a slippery surface, as on real
  tires.
* **Camber-gated shifts.** The package multiplies ``p_hy1``, ``p_hy3``,
  ``p_vy1`` and ``p_vy3`` by ``sign(camber)``, which makes ``F_y`` jump when a
  camber crosses zero; they are set to zero.
* **Wheel names.** The package calls ``L`` the wheels on the *right* of ISO
  8855 axes (y to the left, yaw counter-clockwise): its ``u_w_lf = (vx + T/2 r)
  cos(delta) + ...``, its normal loads and its roll angle all agree on that, and
  its roll and pitch angles are the negatives of ISO's (roll positive left side
  down, pitch positive nose up). roadgrip's columns are ISO: ``omega_fl`` is the
  package's ``RF`` wheel speed (:data:`WHEEL_SENSOR_STATE`).
"""

from __future__ import annotations

import dataclasses
import math
import types
from collections import namedtuple
from functools import cache
from typing import Any

import numpy as np
from numba import njit

from roadgrip.constants import GRAVITY
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BODY_GRADIENTS",
    "COMMONROAD_VEHICLES",
    "WHEEL_ALPHA",
    "WHEEL_CAMBER",
    "WHEEL_FX",
    "WHEEL_FY",
    "WHEEL_FZ",
    "WHEEL_MU_X",
    "WHEEL_MU_Y",
    "WHEEL_SENSOR_STATE",
    "WHEEL_SIZE",
    "WHEEL_SLIP",
    "MBState",
    "commonroad_parameters",
    "compiled_rhs",
    "parameter_tuple",
    "tire_overrides",
    "vehicle_from_commonroad",
    "wheel_forces",
]

COMMONROAD_VEHICLES: dict[str, int] = {"ford-escort": 1, "vw-vanagon": 3}
"""roadgrip preset name -> CommonRoad parameter-set id."""


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
    return types.SimpleNamespace(mb=rhs, **tire_fns)


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


# ---------------------------------------------------------------------------------------
# vehicles
# ---------------------------------------------------------------------------------------
BODY_GRADIENTS = {"ford-escort": (0.0157, 0.0062), "vw-vanagon": (0.0116, 0.0061)}
"""Roll and pitch gradients [rad/(m/s²)] of the CommonRoad vehicles on this engine (8.8 and 6.5
deg/g of roll, 3.5 deg/g of pitch): the slopes of the body angles over the horizontal
accelerations in the engine's own drives, as a skid pad and a brake test measure them
(checked by the tests of the engine)."""


def vehicle_from_commonroad(name: str) -> VehicleParams:
    """roadgrip's single-track parameters of a CommonRoad vehicle.

    Derived from the package's parameter set, as a user would derive them from
    a data sheet: total mass; CG of the sprung mass and both unsprung masses
    (at their axles); yaw inertia of that rigid assembly about the CG; the
    package's CG height, rolling radius and wheel inertia; the mean of the two
    track widths; axle cornering stiffness ``|p_ky1|`` times the static axle
    load; the driven axle from the engine-torque split ``T_se``; the steering
    limit; the body's roll and pitch gradients (:data:`BODY_GRADIENTS`), which
    a user measures on a skid pad and in a straight-line brake test.

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
        roll_gradient=BODY_GRADIENTS[name][0], pitch_gradient=BODY_GRADIENTS[name][1],
    )
