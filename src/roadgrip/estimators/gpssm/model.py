r"""The GP-SSM filter's lateral single-track model (paper 000, eq. 1-2, 7-8), one copy.

State ``x = [vy, yaw_rate]`` ([m/s, rad/s], layout :class:`State`), input ``u = [steer,
vx]`` (layout :class:`Input`), axle friction ``mu = [mu_f, mu_r]`` (lateral force per unit static normal load,
positive to the left). The forward-Euler step of eq. 7 and the accelerometer of eq. 8
are

.. math::

    v_y' = v_y - \Delta t\, v_x r + \Delta t\,(F^z_f \mu_f \cos\delta + F^z_r \mu_r)/m, \qquad
    r' = r + \Delta t\,(l_f F^z_f \mu_f \cos\delta - l_r F^z_r \mu_r)/I_{zz},

    a_y = (F^z_f \cos\delta / m)\, \mu_f + (F^z_r / m)\, \mu_r .

The functions below are written once, with arithmetic and NumPy ufuncs only, so that
the same code runs on arrays over the particles (the NumPy reference,
:mod:`roadgrip.estimators.gpssm.reference`) and compiled on scalars inside the particle
loop of :mod:`roadgrip.estimators.gpssm.kernel` (the ``*_jit`` versions). They agree
with :mod:`roadgrip.vehicle.lateral` and :func:`roadgrip.vehicle.slip.slip_angles`,
which the simulator uses.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from roadgrip.constants import V_EPS
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "Input",
    "State",
    "VehicleConstants",
    "ay_gains",
    "euler_step",
    "regularised_speed",
    "slip_angles",
    "vehicle_constants",
]


class State:
    """Index layout of the filter's state vector ``x`` (N, SIZE): lateral velocity
    [m/s], yaw rate [rad/s] and the accelerometer gain [-] (``a_y,meas = AY_GAIN a_y``,
    :attr:`~roadgrip.estimators.gpssm.config.GPSSMConfig.ay_gain_sigma`)."""

    VY = 0
    YAW_RATE = 1
    AY_GAIN = 2
    SIZE = 3


class Input:
    """Index layout of the filter's input vector ``u = [steer, vx]`` ([rad, m/s])."""

    STEER = 0
    VX = 1
    SIZE = 2


class VehicleConstants(NamedTuple):
    """The vehicle as the model needs it (SI units)."""

    mass: float
    """[kg]"""
    fz_front: float
    """Static front axle load [N]."""
    fz_rear: float
    """Static rear axle load [N]."""
    lf: float
    """CG to front axle [m]."""
    lr: float
    """CG to rear axle [m]."""
    yaw_inertia: float
    """[kg m²]"""
    v_eps: float
    """Speed regularisation of the slip angles [m/s]."""


def vehicle_constants(veh: VehicleParams) -> VehicleConstants:
    """:class:`VehicleConstants` of a vehicle."""
    return VehicleConstants(float(veh.mass), float(veh.fz_front), float(veh.fz_rear), float(veh.lf),
                            float(veh.lr), float(veh.yaw_inertia), float(V_EPS))


def euler_step(vy, r, cos_steer, vx, mu_f, mu_r, dt, v):
    """Forward-Euler step of eq. 7: ``(vy, r)`` after ``dt`` [s] under the friction
    ``mu_f, mu_r`` with the previous input (``cos_steer = cos(steer)``, ``vx`` [m/s])."""
    vy_new = vy - dt * vx * r + dt * (v.fz_front * cos_steer * mu_f + v.fz_rear * mu_r) / v.mass
    r_new = r + dt * (v.lf * v.fz_front * cos_steer * mu_f - v.lr * v.fz_rear * mu_r) / v.yaw_inertia
    return vy_new, r_new


def regularised_speed(vx, v_eps):
    """``sign(vx) sqrt(vx² + v_eps²)`` [m/s] for a scalar ``vx``: the slip angles stay
    finite at standstill."""
    u = math.sqrt(vx * vx + v_eps * v_eps)
    return -u if vx < 0.0 else u


def slip_angles(vy, r, steer, ureg, v):
    """ISO axle slip angles ``(alpha_f, alpha_r)`` [rad] with the regularised speed
    ``ureg`` (:func:`regularised_speed`)."""
    return steer - np.arctan((vy + v.lf * r) / ureg), -np.arctan((vy - v.lr * r) / ureg)


def ay_gains(cos_steer, v):
    """``(d ay / d mu_f, d ay / d mu_r)`` [m/s²] of eq. 8 (``h = 0`` for ``ay``)."""
    return v.fz_front * cos_steer / v.mass, v.fz_rear / v.mass


euler_step_jit = numba.njit(cache=True, inline="always")(euler_step)
slip_angles_jit = numba.njit(cache=True, inline="always")(slip_angles)
ay_gains_jit = numba.njit(cache=True, inline="always")(ay_gains)
