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
* **Load sensitivity.** The package's tire has a peak ``F / F_z`` and a slip
  stiffness per unit load that do not depend on the load. roadgrip's tire
  parameters carry five more fields (:data:`TIRE_LOAD_FIELDS`): a nominal load
  ``fz_nominal`` and the relative change per relative load change
  ``dfz = F_z / fz_nominal - 1`` of the peaks (``peak_load_x``, ``peak_load_y``)
  and of the slip stiffnesses per unit load (``stiffness_load_x``,
  ``stiffness_load_y``). The package's tire functions are called as they are, at
  the load ``s F_z`` and the slip ``c alpha``, with ``s = 1 + peak_load dfz``
  and ``c = (1 + stiffness_load dfz) / s``: the peak becomes ``s mu F_z`` and the
  slope at zero slip ``(1 + stiffness_load dfz) |p_ky1| F_z``. With all four
  zero (the named vehicles) the calls, and the drives, are the package's to the
  bit; the surface's ``mu`` is the peak at the nominal load.
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
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache
from typing import Any

import numpy as np
from numba import njit

from roadgrip.constants import GRAVITY
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BODY_GRADIENTS",
    "COMMONROAD_VEHICLES",
    "TIRE_LOAD_FIELDS",
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
    "MBVehicle",
    "body_gradients",
    "commonroad_parameters",
    "compiled_rhs",
    "named_mb_vehicle",
    "parameter_tuple",
    "single_track_params",
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

TIRE_LOAD_FIELDS = ("fz_nominal", "peak_load_x", "peak_load_y", "stiffness_load_x", "stiffness_load_y")
"""roadgrip's tire fields beyond the package's (module docstring, load sensitivity): nominal
wheel load [N] and four relative sensitivities [-] (peaks and slip stiffnesses per unit load,
longitudinal and lateral)."""

_LOAD_SCALE_FLOOR = 0.2
"""Least factor the load sensitivity may apply to a peak or a slip stiffness [-] (a wheel
loaded far beyond its nominal load keeps a positive peak and stiffness)."""


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


def _load_scales(F_z, peak_load, stiffness_load, fz_nominal):
    """Peak factor ``s`` and slip factor ``c`` of the load sensitivity (module docstring)."""
    dfz = F_z / fz_nominal - 1.0
    s = max(1.0 + peak_load * dfz, _LOAD_SCALE_FLOOR)
    k = max(1.0 + stiffness_load * dfz, _LOAD_SCALE_FLOOR)
    return s, k / s


_load_scales_jit = njit(cache=True)(_load_scales)
_pkg: Any = None
"""Placeholder for the package's tire function that :func:`compiled_rhs` binds in the wrappers."""


def _loaded_longitudinal(kappa, gamma, F_z, p):
    """The package's ``formula_longitudinal`` with roadgrip's load sensitivity."""
    s, c = _load_scales(F_z, p.peak_load_x, p.stiffness_load_x, p.fz_nominal)
    return _pkg(c * kappa, gamma, s * F_z, p)


def _loaded_lateral(alpha, gamma, F_z, p):
    """The package's ``formula_lateral`` with roadgrip's load sensitivity; ``[F_y, mu_y]``
    with ``mu_y`` the peak at this load."""
    s, c = _load_scales(F_z, p.peak_load_y, p.stiffness_load_y, p.fz_nominal)
    res = _pkg(c * alpha, gamma, s * F_z, p)
    return [res[0], res[1] * s]


@cache
def compiled_rhs():
    """The package's ``vehicle_dynamics_mb`` and tire functions, compiled.

    Returns
    -------
    types.SimpleNamespace
        ``mb(x, u, p)`` (right-hand side; ``x`` ndarray (29,), ``u`` ndarray (2,),
        ``p`` a :func:`parameter_tuple`; returns a list of 29 floats, and clips
        negative wheel speeds in ``x`` as the package does), and the tire
        functions ``formula_longitudinal``, ``formula_lateral`` (with roadgrip's load
        sensitivity, module docstring; ``formula_lateral`` returns the peak ``mu_y`` at
        the load), ``formula_longitudinal_comb``, ``formula_lateral_comb``.
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
    tire_fns["formula_longitudinal"] = _rejit(_loaded_longitudinal, {"_pkg": tire_fns["formula_longitudinal"],
                                                                      "_load_scales": _load_scales_jit})
    tire_fns["formula_lateral"] = _rejit(_loaded_lateral, {"_pkg": tire_fns["formula_lateral"],
                                                            "_load_scales": _load_scales_jit})
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
        if name == "MBTireParameters":
            names += list(TIRE_LOAD_FIELDS)
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
    extra = set(_CLASSES[name]._fields) - set(values)
    values.update({k: float(overrides[k]) for k in extra})
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


def parameter_tuple(vehicle_id, mu: float | None = None, *, camber_shifts: bool = False,
                    load_sensitivity: Mapping[str, float] | None = None):
    """The package's parameters as a numba-friendly named tuple.

    Parameters
    ----------
    vehicle_id : int or vehiclemodels.vehicle_parameters.VehicleParameters
        CommonRoad parameter set, or a parameter object (a sampled vehicle).
    mu : float, optional
        Surface peak friction; None keeps the package's tire unchanged.
    camber_shifts : bool
        Keep the camber-gated shifts (only for comparisons with the package).
    load_sensitivity : mapping, optional
        ``peak_load_x``, ``peak_load_y``, ``stiffness_load_x``, ``stiffness_load_y`` [-]
        (:data:`TIRE_LOAD_FIELDS`; missing ones are 0, no sensitivity). The nominal
        load is a quarter of the vehicle's weight.
    """
    p = commonroad_parameters(vehicle_id) if isinstance(vehicle_id, int) else vehicle_id
    load = {k: 0.0 for k in TIRE_LOAD_FIELDS[1:]}
    for k, v in dict(load_sensitivity or {}).items():
        if k not in load:
            raise ValueError(f"unknown tire load sensitivity {k!r}; known: {sorted(load)}")
        if not np.isfinite(v):
            raise ValueError(f"tire load sensitivity {k} must be finite, got {v!r}")
        load[k] = float(v)
    load["fz_nominal"] = p.m * GRAVITY / 4.0
    over: dict[str, float] = {}
    if mu is not None:
        over = tire_overrides(p, mu)
    if camber_shifts:
        over = {k: v for k, v in over.items() if k not in _CAMBER_GATED}
    elif mu is None:
        over = dict.fromkeys(_CAMBER_GATED, 0.0)
    return _namedtuple_of(p, "MBParameters", {"tire": {**over, **load}})


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
        the left), the pure-slip peaks ``mu_x``, ``mu_y`` [-] at the wheel's camber and load,
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
        sx = _load_scales_jit(fz, t.peak_load_x, t.stiffness_load_x, t.fz_nominal)[0]
        out[i, WHEEL_MU_X] = t.p_dx1 * (1 - t.p_dx3 * g**2) * sx
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


def body_gradients(p) -> tuple[float, float]:
    """Roll and pitch gradients [rad/(m/s²)] of a parameter set, from its springs.

    Quasi-static: the sprung mass's moment about the ground (``m_s h_s a``) over the
    roll stiffness (per axle the springs ``K_s T² / 2`` and the auxiliary torsion
    ``|K_ts|`` in series with the tires ``K_zt T² / 2``) less the gravity term
    ``m_s g h_s``, and likewise in pitch (springs ``2 K_s a²``, ``2 K_s b²`` in series
    with the tires). The engine's own slopes (:data:`BODY_GRADIENTS`) are 2 % (roll) and
    8 % (pitch) larger than this estimate on the two CommonRoad vehicles, so a sampled
    vehicle takes its base vehicle's measured gradient times the ratio of the estimates
    (:class:`MBVehicle`).
    """
    def series(k1, k2):
        return k1 * k2 / (k1 + k2)

    roll = (series(0.5 * p.K_sf * p.T_f**2 + abs(p.K_tsf), 0.5 * p.K_zt * p.T_f**2)
            + series(0.5 * p.K_sr * p.T_r**2 + abs(p.K_tsr), 0.5 * p.K_zt * p.T_r**2))
    pitch = series(2 * p.K_sf * p.a**2, 2 * p.K_zt * p.a**2) + series(2 * p.K_sr * p.b**2, 2 * p.K_zt * p.b**2)
    moment = p.m_s * p.h_s
    return moment / (roll - moment * _PKG_G), moment / (pitch - moment * _PKG_G)


_PKG_G = 9.81
"""Gravity inside the package's equations [m/s²]."""


@dataclass(frozen=True, eq=False)
class MBVehicle:
    """A vehicle of the multi-body engine: its CommonRoad parameters and what the estimators know.

    Attributes
    ----------
    name : str
        ``'ford-escort'``, ``'vw-vanagon'`` or ``'random:SEED'``.
    commonroad : vehiclemodels.vehicle_parameters.VehicleParameters
        The package's parameter object the engine integrates.
    params : VehicleParams
        roadgrip's single-track description of the same vehicle (true cornering
        stiffnesses of its tires at the static loads, drive layout, body gradients).
    load_sensitivity : dict
        Tire load sensitivities (:func:`parameter_tuple`); empty for none.
    description : dict
        JSON-serialisable description for ``meta.truth['vehicle']`` (sampled values).
    sensors : object, optional
        Sensor errors sampled with the vehicle (:class:`roadgrip.sim.sensors.SensorErrors`);
        None: the scenario's sensors as they are.
    """

    name: str
    commonroad: Any
    params: VehicleParams
    load_sensitivity: dict[str, float] = field(default_factory=dict)
    description: dict[str, Any] = field(default_factory=dict)
    sensors: Any = None

    def parameter_tuple(self, mu: float):
        """The engine's parameters on a surface of peak friction ``mu``."""
        return parameter_tuple(self.commonroad, mu, load_sensitivity=self.load_sensitivity)


def single_track_params(name: str, p, *, drive: str | None = None, gradients: tuple[float, float],
                        stiffness_load: float = 0.0) -> VehicleParams:
    """roadgrip's single-track parameters of a CommonRoad parameter object (see
    :func:`vehicle_from_commonroad`); ``stiffness_load``: the lateral slip-stiffness load
    sensitivity, the tires' cornering stiffness taken at each wheel's static load."""
    wb = p.a + p.b
    lf = (p.m_s * p.a + p.m_ur * wb) / p.m
    lr = wb - lf
    iz = p.I_z + p.m_s * (p.a - lf) ** 2 + p.m_uf * lf**2 + p.m_ur * lr**2
    fzf = p.m * GRAVITY * lr / wb
    fzr = p.m * GRAVITY * lf / wb
    ky = abs(p.tire.p_ky1)
    fz0 = p.m * GRAVITY / 4.0
    kf = ky * (1.0 + stiffness_load * (0.5 * fzf / fz0 - 1.0))
    kr = ky * (1.0 + stiffness_load * (0.5 * fzr / fz0 - 1.0))
    if drive is None:
        drive = "fwd" if p.T_se >= 0.99 else ("rwd" if p.T_se <= 0.01 else "awd")
    return VehicleParams(
        name=name, mass=p.m, yaw_inertia=iz, lf=lf, lr=lr, cg_height=p.h_cg,
        wheel_radius=p.R_w, track_width=0.5 * (p.T_f + p.T_r), wheel_inertia=p.I_y_w,
        cornering_stiffness_front=kf * fzf, cornering_stiffness_rear=kr * fzr,
        drive=drive, max_steer=p.steering.max, gear_ratio=1.0,
        roll_gradient=gradients[0], pitch_gradient=gradients[1],
    )


def named_mb_vehicle(name: str) -> MBVehicle:
    """The engine's vehicle of a CommonRoad preset name (:data:`COMMONROAD_VEHICLES`)."""
    vp = vehicle_from_commonroad(name)
    return MBVehicle(name=name, commonroad=commonroad_parameters(COMMONROAD_VEHICLES[name]), params=vp,
                     description={"name": name, "parameter_set": COMMONROAD_VEHICLES[name]})


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
    return single_track_params(name, commonroad_parameters(vid), gradients=BODY_GRADIENTS[name])
