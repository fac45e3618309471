r"""Shared Kalman-filter kernels: EKF and unscented (UKF) predict/update steps.

Two layers:

* **Compiled primitives** (``numba.njit``), used inside the compiled loops of the
  estimators and by the Python functions below: :func:`cholesky_lower`,
  :func:`psd_sqrt`, :func:`sigma_points`,
  :func:`unscented_transform`, :func:`ukf_correct`, :func:`joseph_update`.
* **Pure Python steps** over an immutable :class:`GaussianState`:
  :func:`ukf_predict`, :func:`ukf_update`, :func:`ekf_predict`, :func:`ekf_update`.
  Models are vectorised callables taking all sigma points at once,
  shape ``(2n+1, n)``; no Python loop runs over sigma points.

Notation (as in the cascade paper 003, eq. 3 and 7)
---------------------------------------------------
======  ==============================================================
symbol  meaning
======  ==============================================================
``x``   state mean, shape (n,)
``P``   state covariance, shape (n, n)
``Q``   process-noise covariance added in the predict step, (n, n)
``R``   measurement-noise covariance, (m, m)
``X``   sigma points, one per row, shape (2n+1, n)
``Z``   sigma points mapped through the measurement function, (2n+1, m)
``S``   innovation covariance, (m, m)
``K``   gain, (n, m)
======  ==============================================================

Sigma points and weights
------------------------
Scaled sigma points of van der Merwe: ``lambda = alpha² (n + kappa) - n``,
``X_0 = x``, ``X_{1+k} = x + sqrt(n + lambda) L[:, k]``,
``X_{1+n+k} = x - sqrt(n + lambda) L[:, k]`` with ``L`` the lower Cholesky
factor, ``P = L Lᵀ``. This is the layout of filterpy's
``MerweScaledSigmaPoints`` (its rows of the upper factor are our columns of
``L``), so the two implementations agree to rounding error.

Loss of positive definiteness
-----------------------------
The unscented covariance is a weighted sum of outer products; with a negative
centre weight (small ``alpha``) or after the subtraction ``P - K S Kᵀ`` of the
update, rounding can leave ``P`` indefinite, and the Cholesky factorisation of
the next step fails. The remedy, applied in :func:`psd_sqrt` whenever the
factorisation fails: symmetrise, take the eigen-decomposition and raise every
eigenvalue to at least ``PD_FLOOR`` times the largest one (the nearest
positive-definite matrix in the Frobenius norm, up to that floor; Higham 1988),
then factorise again. Every update also symmetrises ``P``. The estimators
count how often the repair was needed (a diagnostic, normally zero).

The EKF update uses the Joseph form ``(I - K H) P (I - K H)ᵀ + K R Kᵀ``, which
stays symmetric positive semi-definite for any gain, unlike ``(I - K H) P``.

References
----------
R. van der Merwe, *Sigma-Point Kalman Filters for Probabilistic Inference in
Dynamic State-Space Models*, PhD thesis, OGI 2004.
N. J. Higham, "Computing a nearest symmetric positive semidefinite matrix",
Linear Algebra Appl. 103, 1988.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "PD_FLOOR",
    "GaussianState",
    "Innovation",
    "SigmaWeights",
    "cholesky_lower",
    "ekf_predict",
    "ekf_update",
    "joseph_update",
    "merwe_weights",
    "psd_sqrt",
    "sigma_points",
    "ukf_correct",
    "ukf_predict",
    "ukf_update",
    "unscented_transform",
]

PD_FLOOR = 1e-12
"""Smallest eigenvalue kept by the positive-definiteness repair, relative to the largest."""


class GaussianState(NamedTuple):
    """Mean and covariance of a Gaussian state estimate.

    Attributes
    ----------
    mean : ndarray, shape (n,)
    cov : ndarray, shape (n, n)
    """

    mean: NDArray[np.float64]
    cov: NDArray[np.float64]


class Innovation(NamedTuple):
    """Diagnostics of one measurement update.

    Attributes
    ----------
    residual : ndarray, shape (m,)
        ``z - z_predicted``.
    cov : ndarray, shape (m, m)
        Innovation covariance ``S``.
    nis : float
        Normalised innovation squared ``residualᵀ S⁻¹ residual`` (chi² with m dof
        when the filter is consistent).
    """

    residual: NDArray[np.float64]
    cov: NDArray[np.float64]
    nis: float


class SigmaWeights(NamedTuple):
    """Weights of the scaled unscented transform.

    Attributes
    ----------
    wm, wc : ndarray, shape (2n+1,)
        Mean and covariance weights.
    gamma : float
        Sigma-point spread ``sqrt(n + lambda)``.
    """

    wm: NDArray[np.float64]
    wc: NDArray[np.float64]
    gamma: float


def merwe_weights(n: int, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0) -> SigmaWeights:
    """Weights of van der Merwe's scaled sigma points.

    Parameters
    ----------
    n : int
        State dimension.
    alpha : float
        Spread, ``0 < alpha <= 1``.
    beta : float
        Prior-knowledge term (2 is optimal for Gaussians), ``>= 0``.
    kappa : float
        Secondary scaling; ``n + kappa > 0``.

    Returns
    -------
    SigmaWeights

    Examples
    --------
    >>> w = merwe_weights(2, alpha=1.0, beta=2.0, kappa=1.0)
    >>> round(float(w.wm.sum()), 12), round(w.gamma ** 2, 12)
    (1.0, 3.0)
    """
    if n < 1:
        raise ValueError(f"state dimension must be >= 1, got {n}")
    if not 0.0 < alpha <= 1.0:
        raise ValueError(f"alpha must lie in (0, 1], got {alpha}")
    if beta < 0.0:
        raise ValueError(f"beta must be >= 0, got {beta}")
    if n + kappa <= 0.0:
        raise ValueError(f"n + kappa must be positive, got n={n}, kappa={kappa}")
    lam = alpha**2 * (n + kappa) - n
    c = 0.5 / (n + lam)
    wm = np.full(2 * n + 1, c)
    wc = np.full(2 * n + 1, c)
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    return SigmaWeights(wm, wc, float(np.sqrt(n + lam)))


# -- compiled primitives -------------------------------------------------------------


@njit(cache=True)
def cholesky_lower(a):  # pragma: no cover - compiled
    """Lower Cholesky factor of a small symmetric matrix, with a success flag.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Only the lower triangle is read.

    Returns
    -------
    L : ndarray, shape (n, n)
        ``L Lᵀ = a`` when ``ok``.
    ok : bool
        False when a pivot is not strictly positive (``a`` not positive definite).
    """
    n = a.shape[0]
    L = np.zeros((n, n))
    for j in range(n):
        s = a[j, j]
        for k in range(j):
            s -= L[j, k] * L[j, k]
        if not s > 0.0:
            return L, False
        d = np.sqrt(s)
        L[j, j] = d
        for i in range(j + 1, n):
            s = a[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    return L, True


@njit(cache=True)
def _nearest_pd(p, floor):  # pragma: no cover - compiled
    """Symmetrise ``p`` and raise its eigenvalues to ``floor * max|eigenvalue|``.

    Parameters
    ----------
    p : ndarray, shape (n, n)
    floor : float
        Relative eigenvalue floor (:data:`PD_FLOOR`).

    Returns
    -------
    ndarray, shape (n, n)
        Symmetric positive definite.
    """
    s = 0.5 * (p + p.T)
    w, v = np.linalg.eigh(s)
    top = np.max(np.abs(w))
    if not top > 0.0:
        top = 1.0
    w = np.maximum(w, floor * top)
    return (v * w) @ v.T


@njit(cache=True)
def psd_sqrt(p):  # pragma: no cover - compiled
    """Lower Cholesky factor of ``p``, repairing a matrix that lost definiteness.

    Returns
    -------
    L : ndarray, shape (n, n)
    p_used : ndarray, shape (n, n)
        ``p`` itself, or its repaired version when the factorisation failed.
    repaired : bool
        True when the repair of the module docstring was applied.
    """
    L, ok = cholesky_lower(p)
    if ok:
        return L, p, False
    q = _nearest_pd(p, PD_FLOOR)
    L, ok = cholesky_lower(q)
    scale = 1e-12
    while not ok:  # rounding left the floored matrix singular: add growing jitter
        top = np.max(np.abs(np.diag(q)))
        if not top > 0.0:
            top = 1.0
        q = q + scale * top * np.eye(p.shape[0])
        L, ok = cholesky_lower(q)
        scale *= 10.0
    return L, q, True


@njit(cache=True)
def sigma_points(x, L, gamma):  # pragma: no cover - compiled
    """Scaled sigma points, one per row.

    Parameters
    ----------
    x : ndarray, shape (n,)
    L : ndarray, shape (n, n)
        Lower Cholesky factor of the covariance.
    gamma : float
        ``sqrt(n + lambda)``.

    Returns
    -------
    ndarray, shape (2n+1, n)
    """
    n = x.shape[0]
    X = np.empty((2 * n + 1, n))
    X[0] = x
    for k in range(n):
        for i in range(n):
            d = gamma * L[i, k]
            X[1 + k, i] = x[i] + d
            X[1 + n + k, i] = x[i] - d
    return X


@njit(cache=True)
def unscented_transform(Y, wm, wc, noise):  # pragma: no cover - compiled
    """Weighted mean and covariance of transformed sigma points.

    Parameters
    ----------
    Y : ndarray, shape (2n+1, m)
    wm, wc : ndarray, shape (2n+1,)
    noise : ndarray, shape (m, m)
        Added to the covariance (``Q`` or ``R``).

    Returns
    -------
    mean : ndarray, shape (m,)
    cov : ndarray, shape (m, m)
    """
    mean = wm @ Y
    D = Y - mean
    cov = (D.T * wc) @ D + noise
    return mean, cov


@njit(cache=True)
def _solve_spd(S, B):  # pragma: no cover - compiled
    """``B S⁻¹`` for symmetric positive definite ``S`` (m, m) and ``B`` (n, m)."""
    L, _, _ = psd_sqrt(S)
    m = S.shape[0]
    n = B.shape[0]
    out = np.empty((n, m))
    for r in range(n):
        # solve S y = B[r] with L Lᵀ y = b
        y = np.empty(m)
        for i in range(m):
            s = B[r, i]
            for k in range(i):
                s -= L[i, k] * y[k]
            y[i] = s / L[i, i]
        for i in range(m - 1, -1, -1):
            s = y[i]
            for k in range(i + 1, m):
                s -= L[k, i] * y[k]
            y[i] = s / L[i, i]
        out[r] = y
    return out


@njit(cache=True)
def ukf_correct(x, P, X, Z, wm, wc, z, R):  # pragma: no cover - compiled
    """UKF measurement update from sigma points and their images.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Prior mean (the weighted mean of ``X``).
    P : ndarray, shape (n, n)
        Prior covariance.
    X : ndarray, shape (2n+1, n)
        Sigma points drawn from ``(x, P)``.
    Z : ndarray, shape (2n+1, m)
        ``h(X)`` row by row.
    wm, wc : ndarray, shape (2n+1,)
    z : ndarray, shape (m,)
        Measurement.
    R : ndarray, shape (m, m)
        Measurement-noise covariance.

    Returns
    -------
    x_post : ndarray, shape (n,)
    P_post : ndarray, shape (n, n)
        Symmetrised.
    residual : ndarray, shape (m,)
    S : ndarray, shape (m, m)
    """
    zp, S = unscented_transform(Z, wm, wc, R)
    DX = X - x
    DZ = Z - zp
    Pxz = (DX.T * wc) @ DZ
    K = _solve_spd(S, Pxz)
    resid = z - zp
    x_post = x + K @ resid
    P_post = P - K @ S @ K.T
    P_post = 0.5 * (P_post + P_post.T)
    return x_post, P_post, resid, S


@njit(cache=True)
def joseph_update(x, P, resid, H, R):  # pragma: no cover - compiled
    """Linear(ised) measurement update in Joseph form.

    Parameters
    ----------
    x : ndarray, shape (n,)
    P : ndarray, shape (n, n)
    resid : ndarray, shape (m,)
        ``z - h(x)``.
    H : ndarray, shape (m, n)
        Measurement Jacobian at ``x``.
    R : ndarray, shape (m, m)

    Returns
    -------
    x_post, P_post, S
        ``P_post = (I - K H) P (I - K H)ᵀ + K R Kᵀ``, symmetric PSD for any ``K``.
    """
    S = H @ P @ H.T + R
    S = 0.5 * (S + S.T)
    K = _solve_spd(S, P @ H.T)
    x_post = x + K @ resid
    A = np.eye(x.shape[0]) - K @ H
    P_post = A @ P @ A.T + K @ R @ K.T
    P_post = 0.5 * (P_post + P_post.T)
    return x_post, P_post, S


# -- pure Python steps ---------------------------------------------------------------


def _as_state(state: GaussianState) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    x = np.asarray(state.mean, dtype=float)
    P = np.asarray(state.cov, dtype=float)
    n = x.shape[0]
    if x.ndim != 1 or P.shape != (n, n):
        raise ValueError(f"state mean must be (n,) and cov (n, n); got {x.shape} and {P.shape}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(P))):
        raise ValueError("state mean or covariance holds NaN/inf")
    return x, P


def _square(name: str, a: ArrayLike, m: int) -> NDArray[np.float64]:
    a = np.asarray(a, dtype=float)
    if a.shape != (m, m):
        raise ValueError(f"{name} must have shape ({m}, {m}), got {a.shape}")
    return a


def _nis(resid: NDArray[np.float64], S: NDArray[np.float64]) -> float:
    return float(resid @ np.linalg.solve(S, resid))


def ukf_predict(
    state: GaussianState,
    fx: Callable[..., NDArray[np.float64]],
    Q: ArrayLike,
    weights: SigmaWeights,
    *args: object,
) -> GaussianState:
    """Unscented predict step.

    Parameters
    ----------
    state : GaussianState
        Posterior at step ``k-1``.
    fx : callable
        ``fx(X, *args) -> X_next``, vectorised over sigma points, shapes
        ``(2n+1, n) -> (2n+1, n)``.
    Q : array_like, shape (n, n)
        Process-noise covariance for this step.
    weights : SigmaWeights
        From :func:`merwe_weights` with the same ``n``.
    *args
        Passed to ``fx`` (inputs, time step, parameters).

    Returns
    -------
    GaussianState
        Prior at step ``k``.
    """
    x, P = _as_state(state)
    n = x.shape[0]
    if weights.wm.shape[0] != 2 * n + 1:
        raise ValueError(f"weights are for n={(weights.wm.shape[0] - 1) // 2}, state has n={n}")
    L, _, _ = psd_sqrt(P)
    X = sigma_points(x, L, weights.gamma)
    Y = np.asarray(fx(X, *args), dtype=float)
    if Y.shape != X.shape:
        raise ValueError(f"fx must map sigma points {X.shape} to the same shape, got {Y.shape}")
    mean, cov = unscented_transform(Y, weights.wm, weights.wc, _square("Q", Q, n))
    return GaussianState(mean, 0.5 * (cov + cov.T))


def ukf_update(
    state: GaussianState,
    z: ArrayLike,
    hx: Callable[..., NDArray[np.float64]],
    R: ArrayLike,
    weights: SigmaWeights,
    *args: object,
) -> tuple[GaussianState, Innovation]:
    """Unscented measurement update (sigma points redrawn from the prior).

    Parameters
    ----------
    state : GaussianState
        Prior.
    z : array_like, shape (m,)
        Measurement.
    hx : callable
        ``hx(X, *args) -> Z``, shapes ``(2n+1, n) -> (2n+1, m)``.
    R : array_like, shape (m, m)
    weights : SigmaWeights
    *args
        Passed to ``hx``.

    Returns
    -------
    GaussianState
        Posterior.
    Innovation
    """
    x, P = _as_state(state)
    z = np.atleast_1d(np.asarray(z, dtype=float))
    m = z.shape[0]
    L, P, _ = psd_sqrt(P)
    X = sigma_points(x, L, weights.gamma)
    Z = np.asarray(hx(X, *args), dtype=float)
    if Z.shape != (X.shape[0], m):
        raise ValueError(f"hx must return shape {(X.shape[0], m)}, got {Z.shape}")
    xp, Pp, resid, S = ukf_correct(x, P, X, Z, weights.wm, weights.wc, z, _square("R", R, m))
    return GaussianState(xp, Pp), Innovation(resid, S, _nis(resid, S))


def ekf_predict(
    state: GaussianState,
    f: Callable[..., NDArray[np.float64]],
    jac: Callable[..., NDArray[np.float64]],
    Q: ArrayLike,
    *args: object,
) -> GaussianState:
    """Extended Kalman predict step ``x = f(x), P = F P Fᵀ + Q``.

    Parameters
    ----------
    state : GaussianState
    f : callable
        ``f(x, *args) -> x_next``, shape (n,).
    jac : callable
        ``jac(x, *args) -> F``, the Jacobian of ``f`` at ``x``, shape (n, n).
    Q : array_like, shape (n, n)
    *args
        Inputs, time step, parameters.
    """
    x, P = _as_state(state)
    F = np.asarray(jac(x, *args), dtype=float)
    n = x.shape[0]
    Pn = F @ P @ F.T + _square("Q", Q, n)
    return GaussianState(np.asarray(f(x, *args), dtype=float), 0.5 * (Pn + Pn.T))


def ekf_update(
    state: GaussianState,
    z: ArrayLike,
    h: Callable[..., NDArray[np.float64]],
    jac: Callable[..., NDArray[np.float64]],
    R: ArrayLike,
    *args: object,
) -> tuple[GaussianState, Innovation]:
    """Extended Kalman update in Joseph form (:func:`joseph_update`).

    Parameters
    ----------
    state : GaussianState
    z : array_like, shape (m,)
    h : callable
        ``h(x, *args) -> z_predicted``, shape (m,).
    jac : callable
        ``jac(x, *args) -> H``, shape (m, n).
    R : array_like, shape (m, m)
    """
    x, P = _as_state(state)
    z = np.atleast_1d(np.asarray(z, dtype=float))
    m = z.shape[0]
    H = np.atleast_2d(np.asarray(jac(x, *args), dtype=float))
    resid = z - np.atleast_1d(np.asarray(h(x, *args), dtype=float))
    xp, Pp, S = joseph_update(x, P, resid, H, _square("R", R, m))
    return GaussianState(xp, Pp), Innovation(resid, S, _nis(resid, S))
