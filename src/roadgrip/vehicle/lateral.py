r"""Lateral-only single-track model (paper 000, eq. 1-2).

State ``x = [vy, yaw_rate]`` ([m/s, rad/s]), input ``u = [steer, vx]`` ([rad,
m/s]), axle friction ``mu = [mu_f, mu_r]`` (lateral force per unit normal load,
positive to the left). With the static axle loads of eq. 2,

.. math::

    \dot v_y = -v_x r + (F_f^z \mu_f \cos\delta + F_r^z \mu_r + F_f^z \mu^x_f \sin\delta)/m \\
    I_{zz} \dot r = l_f F_f^z \mu_f \cos\delta - l_r F_r^z \mu_r + l_f F_f^z \mu^x_f \sin\delta

and the accelerometer reads ``ay = dvy/dt + vx r``, i.e. the force sum over the
mass. Every function is vectorised over a leading batch axis (particles or
time): ``x`` has shape ``(..., 2)``.

The discrete form used by the GP-SSM filter is the forward-Euler step
``x[k+1] = a(x, u) + G(x, u) mu`` and ``y = h(x, u) + D(x, u) mu`` (paper 000,
eq. 7-8), with ``y = [ay, yaw_rate]``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "LateralInput",
    "LateralState",
    "lateral_derivatives",
    "lateral_discrete",
    "lateral_measurement",
    "steady_state_linear",
]


class LateralState:
    """Index layout of the lateral state vector."""

    VY = 0
    YAW_RATE = 1
    SIZE = 2


class LateralInput:
    """Index layout of the lateral input vector."""

    STEER = 0
    VX = 1
    SIZE = 2


class _Split(NamedTuple):
    vy: NDArray[np.float64]
    r: NDArray[np.float64]
    steer: NDArray[np.float64]
    vx: NDArray[np.float64]


def _split(x: ArrayLike, u: ArrayLike) -> _Split:
    x = np.asarray(x, dtype=float)
    u = np.asarray(u, dtype=float)
    return _Split(
        x[..., LateralState.VY], x[..., LateralState.YAW_RATE],
        u[..., LateralInput.STEER], u[..., LateralInput.VX],
    )


def lateral_derivatives(
    x: ArrayLike,
    u: ArrayLike,
    mu_f: ArrayLike,
    mu_r: ArrayLike,
    params: VehicleParams,
    mu_xf: ArrayLike = 0.0,
) -> NDArray[np.float64]:
    """Continuous-time ``dx/dt`` of eq. 1, shape ``(..., 2)``.

    Parameters
    ----------
    x : array_like, shape (..., 2)
        ``[vy, yaw_rate]`` [m/s, rad/s].
    u : array_like, shape (..., 2)
        ``[steer, vx]`` [rad, m/s].
    mu_f, mu_r : array_like, shape (...)
        Lateral axle friction [-].
    params : VehicleParams
    mu_xf : array_like
        Front longitudinal friction [-] (zero for free rolling).
    """
    s = _split(x, u)
    fzf, fzr = params.fz_front, params.fz_rear
    fyf = fzf * (np.asarray(mu_f) * np.cos(s.steer) + np.asarray(mu_xf) * np.sin(s.steer))
    fyr = fzr * np.asarray(mu_r)
    dvy = -s.vx * s.r + (fyf + fyr) / params.mass
    dr = (params.lf * fyf - params.lr * fyr) / params.yaw_inertia
    return np.stack([dvy, dr], axis=-1)


def lateral_discrete(
    x: ArrayLike, u: ArrayLike, params: VehicleParams, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Forward-Euler ``x[k+1] = a + G @ [mu_f, mu_r]`` (paper 000, eq. 7).

    Returns
    -------
    a : ndarray, shape (..., 2)
    G : ndarray, shape (..., 2, 2)
        ``G[..., i, j]``: effect of axle ``j`` (0 front, 1 rear) on state ``i``.
    """
    s = _split(x, u)
    fzf, fzr = params.fz_front, params.fz_rear
    a = np.stack([s.vy - dt * s.vx * s.r, s.r], axis=-1)
    c = np.cos(s.steer)
    G = np.empty((*a.shape, 2))
    G[..., 0, 0] = dt * fzf * c / params.mass
    G[..., 0, 1] = dt * fzr / params.mass
    G[..., 1, 0] = dt * params.lf * fzf * c / params.yaw_inertia
    G[..., 1, 1] = -dt * params.lr * fzr / params.yaw_inertia
    return a, G


def lateral_measurement(
    x: ArrayLike, u: ArrayLike, params: VehicleParams
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``y = h + D @ mu`` with ``y = [ay, yaw_rate]`` (paper 000, eq. 8).

    Returns
    -------
    h : ndarray, shape (..., 2)
        ``[0, yaw_rate]``.
    D : ndarray, shape (..., 2, 2)
        ``[[Fzf cos(delta)/m, Fzr/m], [0, 0]]``.
    """
    s = _split(x, u)
    h = np.stack([np.zeros_like(s.r), s.r], axis=-1)
    D = np.zeros((*h.shape, 2))
    D[..., 0, 0] = params.fz_front * np.cos(s.steer) / params.mass
    D[..., 0, 1] = params.fz_rear / params.mass
    return h, D


def steady_state_linear(steer: ArrayLike, vx: ArrayLike, params: VehicleParams) -> NDArray[np.float64]:
    """Linear steady-state yaw rate ``vx delta / (l + K vx²)`` [rad/s].

    ``K`` is :attr:`VehicleParams.understeer_gradient`; valid for small angles
    with the axle cornering stiffnesses of ``params``.
    """
    vx = np.asarray(vx, dtype=float)
    return vx * np.asarray(steer, dtype=float) / (
        params.wheelbase + params.understeer_gradient * vx**2
    )
