"""Models of the Kalman cascade: state layouts, the stage-2 force models and the brush tire.

The compiled functions work on all sigma points at once (one row per point);
:func:`brush_mu_inverse` is the vectorised NumPy inversion of the brush model
for analysis. The equations are in :mod:`roadgrip.estimators.cascade`.
"""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from numba import njit

__all__ = [
    "ForceMeasurement",
    "ForceState",
    "FrictionState",
    "VelocityState",
    "brush",
    "brush_mu",
    "brush_mu_inverse",
    "brush_slope",
    "force_measurement",
    "force_transition",
    "friction_measurement",
    "inverted_observation",
    "lateral_capacity",
    "rotate_integrate",
    "slip_bias_effect",
    "slip_sensitivity",
]


class VelocityState(IntEnum):
    """Stage-1 EKF state: ``vx, vy`` [m/s] (eq. 4) and the accelerometer biases [m/s²]."""

    VX = 0
    VY = 1
    BIAS_AX = 2
    BIAS_AY = 3
    SIZE = 4


class ForceState(IntEnum):
    """Stage-2 UKF1 state (eq. 6): ``vx, r, vy`` [m/s, rad/s, m/s], ``Fxf, Fyf, Fyr`` [N]."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    FXF = 3
    FYF = 4
    FYR = 5
    SIZE = 6


class ForceMeasurement(IntEnum):
    """Stage-2 UKF1 measurement (eq. 6): ``vx, r, vy`` of stage 1 and the gyro, ``ax, ay`` [m/s²]."""

    VX = 0
    YAW_RATE = 1
    VY = 2
    AX = 3
    AY = 4
    SIZE = 5


class FrictionState(IntEnum):
    """Stage-3 UKF2 state (eq. 11): front and rear axle friction [-]; also its measurement ``Fyf, Fyr``."""

    MU_F = 0
    MU_R = 1
    SIZE = 2


_NZ = int(ForceMeasurement.SIZE)  # plain integers for numba's array constructors
_NM = int(FrictionState.SIZE)


@njit(cache=True)
def force_transition(X, steer, dt, mass, iz, lf, lr):  # pragma: no cover - compiled
    """Stage-2 process model, eq. 9, for every row of ``X`` (N, 6) -> (N, 6).

    The velocity update uses :func:`rotate_integrate` (exact rotation) instead
    of the Euler step; the yaw rate and the forces follow eq. 9.
    """
    c = np.cos(steer)
    s = np.sin(steer)
    out = X.copy()
    for i in range(X.shape[0]):
        vx = X[i, ForceState.VX]
        r = X[i, ForceState.YAW_RATE]
        vy = X[i, ForceState.VY]
        fxf = X[i, ForceState.FXF]
        fyf = X[i, ForceState.FYF]
        fyr = X[i, ForceState.FYR]
        ax = (fxf * c - fyf * s) / mass
        ay = (fxf * s + fyf * c + fyr) / mass
        vx_n, vy_n = rotate_integrate(vx, vy, r, ax, ay, dt)
        out[i, ForceState.VX] = vx_n
        out[i, ForceState.YAW_RATE] = r + dt * (lf * (fxf * s + fyf * c) - lr * fyr) / iz
        out[i, ForceState.VY] = vy_n
    return out


@njit(cache=True)
def rotate_integrate(vx, vy, r, ax, ay, dt):  # pragma: no cover - compiled
    """Body-frame velocity after ``dt`` at constant yaw rate ``r`` and acceleration ``(ax, ay)``.

    ``v' = Rot(-r dt) v + dt Rot(-r dt / 2) a``: the exact rotation of the velocity
    vector plus the midpoint-rotated acceleration. The Euler step of eq. 3 and
    eq. 9 (``vx' = vx + dt (ax + vy r)``) misses the second-order term
    ``-vx (r dt)² / 2``, which acts like an accelerometer bias of ``vx r² dt / 2``
    (0.07 m/s² at 3 m/s, 1.5 rad/s and 50 Hz) and appears as a bias in ``vy``.
    """
    th = r * dt
    c = np.cos(th)
    s = np.sin(th)
    ch = np.cos(0.5 * th)
    sh = np.sin(0.5 * th)
    return (c * vx + s * vy + dt * (ch * ax + sh * ay),
            -s * vx + c * vy + dt * (-sh * ax + ch * ay))


@njit(cache=True)
def force_measurement(X, steer, mass):  # pragma: no cover - compiled
    """Stage-2 measurement model, eq. 10 (sign of ``h5`` corrected), (N, 6) -> (N, 5)."""
    c = np.cos(steer)
    s = np.sin(steer)
    out = np.empty((X.shape[0], _NZ))
    for i in range(X.shape[0]):
        fxf = X[i, ForceState.FXF]
        fyf = X[i, ForceState.FYF]
        fyr = X[i, ForceState.FYR]
        out[i, ForceMeasurement.VX] = X[i, ForceState.VX]
        out[i, ForceMeasurement.YAW_RATE] = X[i, ForceState.YAW_RATE]
        out[i, ForceMeasurement.VY] = X[i, ForceState.VY]
        out[i, ForceMeasurement.AX] = (fxf * c - fyf * s) / mass
        out[i, ForceMeasurement.AY] = (fxf * s + fyf * c + fyr) / mass
    return out


@njit(cache=True)
def brush(alpha, fz, mu, k):  # pragma: no cover - compiled
    """Scalar Fiala brush force, identical to :func:`roadgrip.tire.brush_force`."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    az = abs(z)
    if az < 3.0 * mu / k:
        return fz * (k * z - k * k * az * z / (3.0 * mu) + k * k * k * z * z * z / (27.0 * mu * mu))
    return fz * mu * (1.0 if z > 0 else (-1.0 if z < 0 else 0.0))


@njit(cache=True)
def brush_slope(alpha, fz, mu, k):  # pragma: no cover - compiled
    """``dF / dalpha`` of the brush force [N/rad]."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    u = k * abs(z) / mu
    if u >= 3.0:
        return 0.0
    return fz * k * (1.0 - u / 3.0) ** 2 * (1.0 + z * z)


@njit(cache=True)
def slip_sensitivity(alpha, fz, mu, k):  # pragma: no cover - compiled
    """``|dmu/dalpha|`` at constant force: ``|dF/dalpha| / |dF/dmu|`` of the brush model [1/rad].

    Infinite at zero slip and in the linear range (the force does not depend
    on ``mu`` there), zero in full sliding (the force does not depend on slip).
    """
    a = min(max(alpha, -1.5), 1.5)
    z = abs(np.tan(a))
    if z == 0.0:
        return np.inf
    u = k * z / mu
    if u >= 3.0:
        return 0.0
    dfdmu = fz * (k * k * z * z / (3.0 * mu * mu)) * (1.0 - 2.0 * u / 9.0)
    dfda = fz * k * (1.0 - u / 3.0) ** 2 * (1.0 + z * z)
    if dfdmu <= 0.0:
        return np.inf
    return dfda / dfdmu


@njit(cache=True)
def brush_mu(force, alpha, fz, k):  # pragma: no cover - compiled
    """Scalar exact inversion of the brush model (see :func:`brush_mu_inverse`); inf if none."""
    a = min(max(alpha, -1.5), 1.5)
    z = np.tan(a)
    lin = fz * k * abs(z)
    if force * z <= 0.0 or lin <= 0.0 or fz <= 0.0:
        return np.inf
    rho = abs(force) / lin
    if rho >= 1.0:
        return np.inf
    if rho <= 1.0 / 3.0:
        return abs(force) / fz
    u = 0.5 * (9.0 - np.sqrt(max(81.0 - 108.0 * (1.0 - rho), 0.0)))
    return k * abs(z) / u


@njit(cache=True)
def slip_bias_effect(force, alpha, fz, k, dalpha):  # pragma: no cover - compiled
    """Largest change of the friction that explains ``force`` when the slip angle moves by ``±dalpha``.

    Uses the exact brush inversion, so it also sees a bias that would move the
    tire between the adhesion and the sliding branch; inf where any of the
    three slip angles leaves no finite friction.
    """
    m0 = brush_mu(force, alpha, fz, k)
    m1 = brush_mu(force, alpha + dalpha, fz, k)
    m2 = brush_mu(force, alpha - dalpha, fz, k)
    if not (np.isfinite(m0) and np.isfinite(m1) and np.isfinite(m2)):
        return np.inf
    return max(abs(m1 - m0), abs(m2 - m0))


@njit(cache=True)
def lateral_capacity(mu, fx, fz, mu_min):  # pragma: no cover - compiled
    """Friction left for the lateral force when the axle carries ``fx`` [N] at load ``fz`` [N].

    The friction circle ``Fx² + Fy² <= (mu Fz)²``: ``sqrt(mu² - (Fx/Fz)²)``, at
    least ``mu_min`` (an axle whose longitudinal force alone exceeds ``mu Fz``
    keeps a small lateral capacity, so the brush model stays defined).
    """
    ux = fx / fz if fz > 0.0 else 0.0
    return np.sqrt(max(mu * mu - ux * ux, mu_min * mu_min))


@njit(cache=True)
def inverted_observation(force, alpha, fz, k, fx, force_var, mu_min, mu_max, max_slip_ratio,
                         slip_upper):  # pragma: no cover
    """Friction of one axle from its lateral force and slip angle alone, and its variance.

    The exact inversion of the brush model (:func:`brush_mu`) gives the
    lateral capacity; with the axle's longitudinal force ``fx`` [N] the friction
    is ``sqrt(capacity² + (fx / fz)²)`` (:func:`lateral_capacity`). The
    variance is ``force_var / (dF/dmu)²`` at that friction (``force_var``
    [N²]: the force's variance with the slip angle's contribution). The value
    does not depend on any earlier state: a map cell that fuses it collects
    what the samples taken in the cell say. ``(nan, inf)`` where no friction in
    ``[mu_min, mu_max]`` explains the force, or where the slip angle may lie
    (``slip_upper`` [rad]: the largest ``|alpha|`` its uncertainty allows)
    more than ``max_slip_ratio`` times beyond the brush model's sliding limit
    ``atan(3 capacity / k)``: far past the peak a real tire's force falls below
    its peak (the brush model's sliding force stays at it), so the force there
    is only a lower bound of the friction.
    """
    cap = brush_mu(force, alpha, fz, k)
    if not np.isfinite(cap) or fz <= 0.0:
        return np.nan, np.inf
    if k * np.tan(min(max(abs(alpha), slip_upper), 1.5)) > 3.0 * max_slip_ratio * cap:
        return np.nan, np.inf
    ux = fx / fz
    mu = np.sqrt(cap * cap + ux * ux)
    if not (mu_min <= mu <= mu_max):
        return np.nan, np.inf
    h = 1e-4 * cap
    dfdcap = (brush(alpha, fz, cap + h, k) - brush(alpha, fz, cap - h, k)) / (2.0 * h)
    dfdmu = abs(dfdcap) * mu / cap
    if dfdmu <= 0.0:
        return np.nan, np.inf
    return mu, force_var / (dfdmu * dfdmu)


@njit(cache=True)
def friction_measurement(M, alpha_f, alpha_r, fzf, fzr, kf, kr, fxf, fxr, mu_min, mu_max):  # pragma: no cover
    """Stage-3 measurement model, eq. 11 with combined slip: lateral brush forces of each row
    ``[mu_f, mu_r]`` (N, 2) -> (N, 2), each axle at the friction its longitudinal force
    ``fxf``, ``fxr`` [N] leaves (:func:`lateral_capacity`)."""
    out = np.empty((M.shape[0], _NM))
    for i in range(M.shape[0]):
        muf = min(max(M[i, FrictionState.MU_F], mu_min), mu_max)
        mur = min(max(M[i, FrictionState.MU_R], mu_min), mu_max)
        out[i, FrictionState.MU_F] = brush(alpha_f, fzf, lateral_capacity(muf, fxf, fzf, mu_min), kf)
        out[i, FrictionState.MU_R] = brush(alpha_r, fzr, lateral_capacity(mur, fxr, fzr, mu_min), kr)
    return out


def brush_mu_inverse(force, slip, fz, c_stiff):
    """Invert the brush model: the friction ``mu`` that produces ``force`` at ``slip``.

    Closed form: with ``u = k |tan(slip)| / mu`` the adhesion branch reads
    ``|F| / (Fz k |tan(slip)|) = 1 - u/3 + u²/27`` for ``u < 3``, a quadratic in
    ``u``; its root in ``[0, 3)`` gives ``mu``. Where the ratio is at most 1/3
    the tire slides fully and ``mu = |F| / Fz`` exactly.

    Parameters
    ----------
    force : array_like
        Lateral force [N] (same sign convention as ``slip``).
    slip : array_like
        Slip angle [rad].
    fz : array_like
        Normal load [N], > 0.
    c_stiff : array_like
        Normalised cornering stiffness ``C / Fz`` [1/rad].

    Returns
    -------
    mu : ndarray
        Friction [-]; ``inf`` where no finite value fits.
    sliding : ndarray of bool
        The whole contact patch slides (saturated tire): ``mu = |F| / Fz``, and
        the force no longer depends on the slip.
    identifiable : ndarray of bool
        False where the force is at or above the linear-tire force
        ``Fz k tan(slip)`` (any large ``mu`` fits; the data carry only a lower
        bound), at zero slip, or where force and slip have opposite signs.

    Examples
    --------
    >>> from roadgrip.tire import brush_force
    >>> f = brush_force(0.05, 20.0, 0.6, 7.0)
    >>> mu, sliding, ok = brush_mu_inverse(f, 0.05, 20.0, 7.0)
    >>> round(float(mu), 12), bool(sliding), bool(ok)
    (0.6, False, True)
    """
    force = np.asarray(force, dtype=float)
    z = np.tan(np.clip(np.asarray(slip, dtype=float), -1.5, 1.5))
    fz = np.asarray(fz, dtype=float)
    k = np.asarray(c_stiff, dtype=float)
    if np.any(fz <= 0) or np.any(k <= 0):
        raise ValueError("normal load and cornering stiffness must be positive")
    force, z, fz, k = np.broadcast_arrays(force, z, fz, k)
    lin = fz * k * np.abs(z)
    same_sign = force * z > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(lin > 0, np.abs(force) / np.where(lin > 0, lin, 1.0), np.inf)
    sliding = same_sign & (rho <= 1.0 / 3.0)
    identifiable = same_sign & (rho < 1.0)
    adh = identifiable & ~sliding
    disc = np.sqrt(np.maximum(81.0 - 108.0 * (1.0 - np.where(adh, rho, 1.0)), 0.0))
    u = 0.5 * (9.0 - disc)
    mu = np.full(force.shape, np.inf)
    mu = np.where(sliding, np.abs(force) / fz, mu)
    with np.errstate(divide="ignore"):
        mu = np.where(adh, k * np.abs(z) / np.where(adh, u, 1.0), mu)
    return mu, sliding, identifiable
