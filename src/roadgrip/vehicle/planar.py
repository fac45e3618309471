r"""Planar single-track model with axle spin dynamics, combined slip and load transfer.

State ``x = [vx, vy, yaw_rate, omega_f, omega_r]`` ([m/s, m/s, rad/s, rad/s,
rad/s]; :class:`PlanarState`), input ``u = [steer, drive_torque, brake_torque]``
([rad, N m, N m]; :class:`PlanarInput`), both vectorised over leading axes.
The left and right wheels of an axle are lumped: ``omega_f`` is the mean spin of
the front wheels, and the axle carries the inertia of two wheels.

Equations
---------
Slip angles are those of :func:`roadgrip.vehicle.slip.slip_angles` (exact form).
The front wheel-centre speed along the wheel is
``v_xf = vx cos(delta) + (vy + lf r) sin(delta)``, the rear one ``vx``; the
longitudinal slips are :func:`roadgrip.vehicle.slip.longitudinal_slip` (paper 002,
eq. 2). Pure-slip friction ``mu_x0 = f_x(kappa)``, ``mu_y0 = f_y(alpha)``
comes from the axle's curves. Combined slip uses the *friction ellipse*: with
``D_x``, ``D_y`` the curves' peaks and ``rho = sqrt((mu_x0/D_x)² + (mu_y0/D_y)²)``,

``(mu_x, mu_y) = (mu_x0, mu_y0) / max(1, rho)``,

so the force direction follows the pure-slip forces and the resultant never
leaves the ellipse ``(mu_x/D_x)² + (mu_y/D_y)² <= 1``; in particular
``|F_y| <= D_y F_z``.

Axle forces in body axes are ``F_z (mu_x cos delta - mu_y sin delta,
mu_x sin delta + mu_y cos delta)`` at the front and ``F_z (mu_x, mu_y)`` at the
rear. The normal loads follow the longitudinal specific force ``a_x`` through
:func:`roadgrip.vehicle.params.axle_loads` (quasi-static load transfer, ``F_zf = m (g lr
- a_x h)/l``). Because every force is its load times a load-independent
``mu``, ``a_x = (F_zf g_xf + F_zr g_xr)/m`` with ``g_x`` the normalised x
forces is linear in ``a_x`` and is solved exactly,
``a_x = g (lr g_xf + lf g_xr) / (l + h (g_xf - g_xr))``: no algebraic loop and
no extra state. Then

.. math::

    \dot v_x = a_x + r v_y, \quad \dot v_y = a_y - r v_x, \quad
    I_z \dot r = l_f F_{yf} - l_r F_{yr}, \\
    2 I_w \dot\omega_i = T_{d,i} - T_{b,i} \tanh(\omega_i/\omega_\epsilon) - R F_z \mu_{x,i}.

Drive torque is split by the drive layout (``fwd`` all front, ``rwd`` all rear,
``awd`` :data:`AWD_FRONT_SHARE` front) and brake torque by
:data:`BRAKE_FRONT_SHARE`. The brake torque acts against the spin through
``tanh(omega/omega_eps)`` (``omega_eps`` = :data:`OMEGA_EPS`), a regularised
Coulomb term that is finite and continuous at standstill. Aerodynamic drag and
rolling resistance are not modelled.

Low speed: every slip divides by ``sqrt(v² + v_eps²)``
(:mod:`roadgrip.vehicle.slip`), so all derivatives are finite down to and at
standstill. The wheel spin mode is stiff there (eigenvalue of order
``R² F_z k_x / (2 I_w v)``); the simulator's integrator sub-divides its steps
accordingly (:mod:`roadgrip.sim.engine`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import GRAVITY, V_EPS
from roadgrip.tire import FrictionModel
from roadgrip.vehicle.params import VehicleParams, axle_loads, driven_wheels
from roadgrip.vehicle.slip import longitudinal_slip, slip_angles

__all__ = [
    "AWD_FRONT_SHARE",
    "BRAKE_FRONT_SHARE",
    "OMEGA_EPS",
    "PlanarForces",
    "PlanarInput",
    "PlanarState",
    "PlanarTires",
    "axle_torques",
    "free_rolling_omegas",
    "planar_derivatives",
    "planar_forces",
    "wheel_speeds",
]

AWD_FRONT_SHARE = 0.5
"""Front share of the drive torque for ``drive = 'awd'`` [-]."""

BRAKE_FRONT_SHARE = 0.65
"""Front share of the brake torque [-] (typical passenger-car brake balance)."""

OMEGA_EPS = 0.5
"""Wheel-speed scale of the regularised brake friction ``tanh(omega / OMEGA_EPS)`` [rad/s]."""


class PlanarState:
    """Index layout of the planar state vector."""

    VX = 0
    VY = 1
    YAW_RATE = 2
    OMEGA_F = 3
    OMEGA_R = 4
    SIZE = 5


class PlanarInput:
    """Index layout of the planar input vector."""

    STEER = 0
    DRIVE_TORQUE = 1
    BRAKE_TORQUE = 2
    SIZE = 3


class PlanarTires(NamedTuple):
    """True friction curves of the two axles (lateral vs slip angle, longitudinal vs slip ratio)."""

    front: FrictionModel
    rear: FrictionModel
    front_long: FrictionModel
    rear_long: FrictionModel


class PlanarForces(NamedTuple):
    """Everything the model computes on the way to the derivatives; each shape (...)."""

    alpha_f: NDArray[np.float64]
    alpha_r: NDArray[np.float64]
    kappa_f: NDArray[np.float64]
    kappa_r: NDArray[np.float64]
    mux_f: NDArray[np.float64]
    mux_r: NDArray[np.float64]
    muy_f: NDArray[np.float64]
    muy_r: NDArray[np.float64]
    fzf: NDArray[np.float64]
    fzr: NDArray[np.float64]
    fxf: NDArray[np.float64]
    fxr: NDArray[np.float64]
    fyf: NDArray[np.float64]
    fyr: NDArray[np.float64]
    ax: NDArray[np.float64]
    ay: NDArray[np.float64]


def axle_torques(
    drive_torque: ArrayLike, brake_torque: ArrayLike, params: VehicleParams
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Split total torques [N m] into ``(drive_f, drive_r, brake_f, brake_r)``."""
    td = np.asarray(drive_torque, float)
    tb = np.asarray(brake_torque, float)
    front, rear = driven_wheels(params.drive)[[0, 2]]
    share = AWD_FRONT_SHARE if (front and rear) else float(front)
    return share * td, (1.0 - share) * td, BRAKE_FRONT_SHARE * tb, (1.0 - BRAKE_FRONT_SHARE) * tb


def _ellipse(mux0: NDArray, muy0: NDArray, dx: float, dy: float) -> tuple[NDArray, NDArray]:
    rho = np.sqrt((mux0 / dx) ** 2 + (muy0 / dy) ** 2)
    scale = 1.0 / np.maximum(rho, 1.0)
    return mux0 * scale, muy0 * scale


def planar_forces(
    x: ArrayLike,
    steer: ArrayLike,
    params: VehicleParams,
    tires: PlanarTires,
    *,
    v_eps: float = V_EPS,
) -> PlanarForces:
    """Slips, friction, loads and axle forces of the planar model.

    Parameters
    ----------
    x : array_like, shape (..., 5)
        Planar state (:class:`PlanarState`).
    steer : array_like, shape (...)
        Front road-wheel angle [rad].
    params : VehicleParams
    tires : PlanarTires
    v_eps : float
        Low-speed regularisation [m/s] of the slips.

    Returns
    -------
    PlanarForces
        Forces ``fx*``, ``fy*`` are in body axes [N]; ``ax``, ``ay`` the specific
        forces at the CG [m/s²].
    """
    x = np.asarray(x, float)
    vx, vy, r = x[..., PlanarState.VX], x[..., PlanarState.VY], x[..., PlanarState.YAW_RATE]
    wf, wr = x[..., PlanarState.OMEGA_F], x[..., PlanarState.OMEGA_R]
    steer = np.asarray(steer, float)
    af, ar = slip_angles(vx, vy, r, steer, params, exact=True, v_eps=v_eps)
    c, s = np.cos(steer), np.sin(steer)
    vxf = vx * c + (vy + params.lf * r) * s
    kf = longitudinal_slip(wf, vxf, params.wheel_radius, v_eps=v_eps)
    kr = longitudinal_slip(wr, vx, params.wheel_radius, v_eps=v_eps)
    mxf, myf = _ellipse(tires.front_long.mu(kf), tires.front.mu(af), tires.front_long.peak()[1], tires.front.peak()[1])
    mxr, myr = _ellipse(tires.rear_long.mu(kr), tires.rear.mu(ar), tires.rear_long.peak()[1], tires.rear.peak()[1])
    gxf = mxf * c - myf * s
    gxr = mxr
    wb, h = params.wheelbase, params.cg_height
    ax = GRAVITY * (params.lr * gxf + params.lf * gxr) / np.maximum(wb + h * (gxf - gxr), 0.1 * wb)
    fzf, fzr = axle_loads(params, ax)
    ax = (fzf * gxf + fzr * gxr) / params.mass
    gyf = mxf * s + myf * c
    fyf, fyr = fzf * gyf, fzr * myr
    return PlanarForces(
        af, ar, kf, kr, mxf, mxr, myf, myr, fzf, fzr,
        fzf * gxf, fzr * gxr, fyf, fyr, ax, (fyf + fyr) / params.mass,
    )


def planar_derivatives(
    x: ArrayLike,
    u: ArrayLike,
    params: VehicleParams,
    tires: PlanarTires,
    *,
    v_eps: float = V_EPS,
) -> NDArray[np.float64]:
    """Continuous-time ``dx/dt`` of the planar model, shape ``(..., 5)``.

    Parameters
    ----------
    x : array_like, shape (..., 5)
        :class:`PlanarState` layout.
    u : array_like, shape (..., 3)
        ``[steer, drive_torque, brake_torque]`` [rad, N m, N m], torques total
        over both axles (split by :func:`axle_torques`), brake torque ``>= 0``.
    params : VehicleParams
    tires : PlanarTires
    v_eps : float
        Low-speed regularisation [m/s].

    Examples
    --------
    >>> import numpy as np
    >>> from roadgrip.vehicle import PRESETS
    >>> from roadgrip.tire import SURFACES
    >>> p = PRESETS["sedan"]; s = SURFACES["dry_asphalt"]
    >>> tires = PlanarTires(s.lateral, s.lateral, s.longitudinal, s.longitudinal)
    >>> x = np.array([20.0, 0.0, 0.0, 20.0 / p.wheel_radius, 20.0 / p.wheel_radius])
    >>> np.allclose(planar_derivatives(x, np.zeros(3), p, tires), 0.0)
    True
    """
    x = np.asarray(x, float)
    u = np.asarray(u, float)
    steer = u[..., PlanarInput.STEER]
    f = planar_forces(x, steer, params, tires, v_eps=v_eps)
    tdf, tdr, tbf, tbr = axle_torques(u[..., PlanarInput.DRIVE_TORQUE], u[..., PlanarInput.BRAKE_TORQUE], params)
    vx, vy, r = x[..., PlanarState.VX], x[..., PlanarState.VY], x[..., PlanarState.YAW_RATE]
    wf, wr = x[..., PlanarState.OMEGA_F], x[..., PlanarState.OMEGA_R]
    iw = 2.0 * params.wheel_inertia
    R = params.wheel_radius
    out = np.empty(np.broadcast_shapes(x.shape, (*u.shape[:-1], PlanarState.SIZE)))
    out[..., PlanarState.VX] = f.ax + r * vy
    out[..., PlanarState.VY] = f.ay - r * vx
    out[..., PlanarState.YAW_RATE] = (params.lf * f.fyf - params.lr * f.fyr) / params.yaw_inertia
    out[..., PlanarState.OMEGA_F] = (tdf - tbf * np.tanh(wf / OMEGA_EPS) - R * f.fzf * f.mux_f) / iw
    out[..., PlanarState.OMEGA_R] = (tdr - tbr * np.tanh(wr / OMEGA_EPS) - R * f.fzr * f.mux_r) / iw
    return out


def free_rolling_omegas(
    vx: ArrayLike, vy: ArrayLike, yaw_rate: ArrayLike, steer: ArrayLike, params: VehicleParams
) -> tuple[NDArray, NDArray]:
    """Axle spin speeds [rad/s] at zero longitudinal slip: wheel-centre speed / radius."""
    vx = np.asarray(vx, float)
    steer = np.asarray(steer, float)
    vxf = vx * np.cos(steer) + (np.asarray(vy) + params.lf * np.asarray(yaw_rate)) * np.sin(steer)
    return vxf / params.wheel_radius, vx / params.wheel_radius


def wheel_speeds(
    omega_f: ArrayLike, omega_r: ArrayLike, yaw_rate: ArrayLike, steer: ArrayLike, params: VehicleParams
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Four wheel-speed signals ``(fl, fr, rl, rr)`` [rad/s] from the axle speeds.

    The wheels of an axle differ by the yaw-induced speed difference of their
    centres, ``r b`` (``b`` the track width), projected on the wheel direction
    (``cos(delta)`` at the front): ``omega_fl = omega_f - r b cos(delta) / (2 R)``
    and ``omega_fr = omega_f + r b cos(delta) / (2 R)``; likewise at the rear.
    Each wheel then has the same longitudinal slip as its axle to first order.
    """
    r = np.asarray(yaw_rate, float)
    half = 0.5 * params.track_width * r / params.wheel_radius
    hf = half * np.cos(np.asarray(steer, float))
    wf, wr = np.asarray(omega_f, float), np.asarray(omega_r, float)
    return wf - hf, wf + hf, wr - half, wr + half
