r"""Tire slip quantities: axle slip angles, wheel longitudinal slip, wheel-centre speeds.

Sign convention (ISO 8855, as paper 000 eq. 4): the slip angle of a wheel is
``alpha = -arctan(v_y,w / v_x,w)`` with the velocities in the wheel frame, so a
positive slip angle produces a positive (leftward) lateral force. For the
single-track model this gives

``alpha_f = delta - arctan((vy + lf r) / vx)``,   ``alpha_r = -arctan((vy - lr r) / vx)``.

Paper 002 (eq. 3) writes the same angles with the opposite sign; roadgrip uses
the convention above everywhere.

Low-speed regularisation: the speed in each denominator is replaced by
``sign(vx) * sqrt(vx**2 + v_eps**2)`` (``v_eps`` defaults to
:data:`roadgrip.constants.V_EPS`), with ``sign(0) = +1``. Slip angles then stay
finite (``|alpha| < pi/2``) and continuous for forward motion down to and
including standstill, instead of the singular ``0/0`` of the textbook
definitions; at ``vx = 0`` they equal ``-arctan(v_lat / v_eps)``, which is zero
only when the lateral velocity of the axle is. The denominator changes sign
with ``vx``, so for a non-zero lateral velocity the slip angle flips sign when
the car passes from forward to reverse.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import V_EPS
from roadgrip.vehicle.params import VehicleParams

__all__ = ["longitudinal_slip", "regularized_speed", "slip_angles", "wheel_centre_speeds"]


def regularized_speed(vx: ArrayLike, v_eps: float = V_EPS) -> NDArray[np.float64]:
    """``sign(vx) sqrt(vx² + v_eps²)`` [m/s]: never zero, equal to ``vx`` at speed."""
    vx = np.asarray(vx, dtype=float)
    return np.where(vx >= 0.0, 1.0, -1.0) * np.sqrt(vx * vx + v_eps * v_eps)


def slip_angles(
    vx: ArrayLike,
    vy: ArrayLike,
    yaw_rate: ArrayLike,
    steer: ArrayLike,
    params: VehicleParams,
    *,
    exact: bool = True,
    v_eps: float = V_EPS,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Front and rear axle slip angles [rad], vectorised over any shape.

    Parameters
    ----------
    vx, vy : array_like
        CG velocity in body axes [m/s].
    yaw_rate : array_like
        [rad/s], positive counter-clockwise.
    steer : array_like
        Front road-wheel angle [rad].
    params : VehicleParams
        Uses ``lf`` and ``lr``.
    exact : bool
        ``True``: arctan form. ``False``: the linearised form
        ``alpha_f = delta - (vy + lf r)/vx``, ``alpha_r = -(vy - lr r)/vx``.
    v_eps : float
        Low-speed regularisation [m/s] (module docstring).

    Returns
    -------
    alpha_f, alpha_r : ndarray
        Broadcast shape of the inputs.
    """
    u = regularized_speed(vx, v_eps)
    vy = np.asarray(vy, dtype=float)
    r = np.asarray(yaw_rate, dtype=float)
    steer = np.asarray(steer, dtype=float)
    qf = (vy + params.lf * r) / u
    qr = (vy - params.lr * r) / u
    if exact:
        return steer - np.arctan(qf), -np.arctan(qr)
    return steer - qf, -qr


def longitudinal_slip(
    omega: ArrayLike,
    vx_wheel: ArrayLike,
    wheel_radius: float,
    *,
    v_eps: float = V_EPS,
) -> NDArray[np.float64]:
    """Longitudinal slip ``(r w - vx) / max(vx, r w)`` (paper 002, eq. 2), regularised.

    Parameters
    ----------
    omega : array_like
        Wheel angular speed [rad/s].
    vx_wheel : array_like
        Longitudinal speed of the wheel centre in the wheel frame [m/s].
    wheel_radius : float
        Rolling radius [m].
    v_eps : float
        The denominator is ``sqrt(max(|vx|, |r w|)² + v_eps²)`` [m/s], so the slip
        is finite at standstill and lies in ``(-1, 1)`` for forward motion.

    Returns
    -------
    ndarray
        Slip ratio [-]; positive when driving (wheel faster than the ground).
    """
    rw = wheel_radius * np.asarray(omega, dtype=float)
    vx = np.asarray(vx_wheel, dtype=float)
    den = np.sqrt(np.maximum(np.abs(vx), np.abs(rw)) ** 2 + v_eps * v_eps)
    return (rw - vx) / den


def wheel_centre_speeds(
    vx: ArrayLike, vy: ArrayLike, yaw_rate: ArrayLike, steer: ArrayLike, params: VehicleParams
) -> NDArray[np.float64]:
    """Speed of each wheel centre along its wheel's heading (the free-rolling ``R omega``).

    The wheels sit at ``x = lf`` (front), ``x = -lr`` (rear) and ``y = ± b/2``
    (``b`` the track width, left positive); a rigid body moving with
    ``(vx, vy, r)`` at the CG moves a wheel centre with ``(vx - r y, vy + r x)``,
    which is projected on the wheel heading (``steer`` at the front, 0 at the rear):

    ``v_fl = (vx - r b/2) cos(delta) + (vy + lf r) sin(delta)``, ``v_rl = vx - r b/2``,
    and ``+ r b/2`` on the right.

    Parameters
    ----------
    vx, vy : array_like, shape (...)
        CG velocity in body axes [m/s].
    yaw_rate : array_like, shape (...)
        [rad/s].
    steer : array_like, shape (...)
        Front road-wheel angle [rad].
    params : VehicleParams
        ``lf`` and ``track_width`` [m] are used.

    Returns
    -------
    ndarray, shape (..., 4)
        Wheel-centre speeds ``fl, fr, rl, rr`` [m/s].
    """
    vx = np.asarray(vx, float)
    hb = 0.5 * params.track_width * np.asarray(yaw_rate, float)
    steer = np.asarray(steer, float)
    c, s = np.cos(steer), np.sin(steer)
    lat_f = (np.asarray(vy, float) + params.lf * np.asarray(yaw_rate, float)) * s
    vl, vr = vx - hb, vx + hb
    return np.stack(np.broadcast_arrays(vl * c + lat_f, vr * c + lat_f, vl, vr), axis=-1)
