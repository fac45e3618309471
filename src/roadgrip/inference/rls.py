r"""Recursive least squares and bistable RLS with reference (paper 002, eq. 5-7).

Model: ``y(t) = phi(t)^T theta(t) + noise`` (eq. 5). Notation (paper 002, eq. 6):

=================  =========================================================
symbol             meaning
=================  =========================================================
``theta``          parameter estimate, shape ``(n,)``
``S``              scaled covariance ("information inverse"), ``(n, n)``
``phi``            regressor, ``(n,)``
``mu``             forgetting factor in ``(0, 1]`` (``forgetting`` below)
``eps``            prediction error ``y - phi^T theta(t-1)``
``eps_ref``        error blended with the reference term
``gamma``          excitation scale of the regressor, same unit as ``phi``
``theta_ref``      reference value of the parameter
=================  =========================================================

RLS (Ljung and Söderström 1983)::

    eta   = mu + phi^T S phi
    K     = S phi / eta                  (= S(t) phi, as eq. 6 writes it)
    theta = theta + K eps
    S     = (S - S phi phi^T S / eta) / mu

bRLS replaces ``eps`` by::

    eps_ref = (1 - w) eps + w phi^T (theta_ref - theta),   w = exp(-|phi| / gamma)

so that weakly excited samples (``|phi|`` small against ``gamma``) pull the
estimate towards ``theta_ref`` instead of fitting the noise.

Note on ``gamma``. The extracted eq. 6 prints the weight as ``exp(-gamma |phi|)``,
but the paper's text says that *as gamma decreases bRLS tends to RLS* and that
gamma "determines the phi-region where the estimate is driven to the
reference". Both statements hold for ``w = exp(-|phi| / gamma)``, i.e. gamma is
the width of that region in regressor units, and this is the form used here:
``gamma = 0`` is exactly RLS and a larger gamma widens the reference region.
(The printed form is the same family with ``gamma_printed = 1 / gamma``.)

Smooth turn-off (eq. 7): with ``theta_ref = theta(t-1)`` the reference term
vanishes and ``eps_ref = (1 - w) eps``, so unexcited samples leave the estimate
where it was.

Covariance wind-up. With ``mu < 1`` and no excitation ``S`` grows as
``mu^-t``; it is clipped element-wise to ``s_max`` on the diagonal (the
off-diagonal terms scaled alike), a standard anti-wind-up guard that never
acts while the data are excited.

The kernels are pure functions over :class:`RLSState`; :func:`brls_scalar_batch`
is a compiled loop for the scalar case used by the friction classifier.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "RLSState",
    "batch_least_squares",
    "brls_scalar_batch",
    "brls_step",
    "data_weight",
    "rls_init",
    "rls_step",
]


class RLSState(NamedTuple):
    """State of an (b)RLS estimator.

    Attributes
    ----------
    theta : ndarray, shape (n,)
        Parameter estimate.
    S : ndarray, shape (n, n)
        Scaled covariance of the estimate.
    """

    theta: NDArray[np.float64]
    S: NDArray[np.float64]


def rls_init(theta0: ArrayLike, s0: float | ArrayLike = 100.0) -> RLSState:
    """Initial state: ``theta0`` (shape (n,)) and ``S = s0 I`` (or the given matrix)."""
    theta = np.atleast_1d(np.asarray(theta0, dtype=float)).copy()
    n = theta.shape[0]
    s = np.asarray(s0, dtype=float)
    S = s * np.eye(n) if s.ndim == 0 else s.copy()
    if S.shape != (n, n):
        raise ValueError(f"S0 must be scalar or shape ({n}, {n}), got {S.shape}")
    if not np.all(np.isfinite(theta)) or not np.all(np.isfinite(S)):
        raise ValueError("theta0 and S0 must be finite")
    return RLSState(theta, S)


def _check_forgetting(forgetting: float) -> None:
    if not (0.0 < forgetting <= 1.0):
        raise ValueError(f"forgetting factor must lie in (0, 1], got {forgetting!r}")


def data_weight(phi_norm: ArrayLike, gamma: float) -> NDArray[np.float64]:
    """Weight of the measurement in eq. 6, ``1 - exp(-|phi| / gamma)`` (1 for gamma = 0)."""
    a = np.abs(np.asarray(phi_norm, dtype=float))
    if gamma < 0:
        raise ValueError(f"gamma must be >= 0, got {gamma!r}")
    if gamma == 0.0:
        return np.ones_like(a)
    return 1.0 - np.exp(-a / gamma)


def _cov_update(S: NDArray, phi: NDArray, forgetting: float, s_max: float):
    Sphi = S @ phi
    eta = forgetting + phi @ Sphi
    S_new = (S - np.outer(Sphi, Sphi) / eta) / forgetting
    d = np.max(np.diag(S_new))
    if d > s_max:
        S_new = S_new * (s_max / d)
    return Sphi / eta, S_new


def rls_step(
    state: RLSState, phi: ArrayLike, y: float, forgetting: float = 1.0, s_max: float = np.inf
) -> tuple[RLSState, float]:
    """One RLS update (eq. 6 with the plain prediction error).

    Parameters
    ----------
    state : RLSState
    phi : array_like, shape (n,)
        Regressor.
    y : float
        Output.
    forgetting : float
        Forgetting factor ``mu`` in (0, 1].
    s_max : float
        Anti-wind-up bound on the diagonal of ``S``.

    Returns
    -------
    state : RLSState
    eps : float
        Prediction error before the update.
    """
    _check_forgetting(forgetting)
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    eps = float(y - phi @ state.theta)
    K, S = _cov_update(state.S, phi, forgetting, s_max)
    return RLSState(state.theta + K * eps, S), eps


def brls_step(
    state: RLSState,
    phi: ArrayLike,
    y: float,
    theta_ref: ArrayLike | None,
    forgetting: float,
    gamma: float,
    s_max: float = np.inf,
) -> tuple[RLSState, float]:
    """One bRLS update (eq. 6); ``theta_ref=None`` means the previous estimate (eq. 7).

    Parameters
    ----------
    state : RLSState
    phi : array_like, shape (n,)
    y : float
    theta_ref : array_like, shape (n,), or None
        Reference the estimate is driven to when the data are not excited.
    forgetting : float
        ``mu`` in (0, 1].
    gamma : float
        Excitation scale [unit of ``phi``]; 0 gives RLS (module docstring).
    s_max : float
        Anti-wind-up bound on the diagonal of ``S``.

    Returns
    -------
    state : RLSState
    w_data : float
        Weight of the measurement, ``1 - exp(-|phi| / gamma)``.
    """
    _check_forgetting(forgetting)
    phi = np.atleast_1d(np.asarray(phi, dtype=float))
    theta = state.theta
    ref = theta if theta_ref is None else np.atleast_1d(np.asarray(theta_ref, dtype=float))
    eps = float(y - phi @ theta)
    w_data = float(data_weight(np.linalg.norm(phi), gamma))
    eps_ref = w_data * eps + (1.0 - w_data) * float(phi @ (ref - theta))
    K, S = _cov_update(state.S, phi, forgetting, s_max)
    return RLSState(theta + K * eps_ref, S), w_data


def batch_least_squares(Phi: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """Ordinary least squares ``argmin ||y - Phi theta||``; ``Phi`` (T, n), ``y`` (T,)."""
    Phi = np.asarray(Phi, dtype=float)
    y = np.asarray(y, dtype=float)
    return np.linalg.lstsq(Phi, y, rcond=None)[0]


@numba.njit(cache=True)
def brls_scalar_batch(phi, y, theta_ref, theta0, s0, forgetting, gamma, s_max):  # pragma: no cover - compiled
    """Scalar bRLS over a whole record (compiled loop).

    Parameters
    ----------
    phi, y : ndarray, shape (T,)
        Regressor and output.
    theta_ref : ndarray, shape (T,)
        Reference per sample; NaN means the previous estimate (eq. 7).
    theta0, s0 : float
        Initial estimate and ``S``.
    forgetting, gamma, s_max : float
        As in :func:`brls_step`; ``gamma = 0`` gives RLS.

    Returns
    -------
    theta, S, w_data : ndarray, shape (T,)
        Estimate, ``S`` and measurement weight after each sample.
    """
    n = phi.shape[0]
    theta_out = np.empty(n)
    s_out = np.empty(n)
    w_out = np.empty(n)
    th = theta0
    s = s0
    for i in range(n):
        p = phi[i]
        ref = theta_ref[i]
        if ref != ref:
            ref = th
        w = 1.0 if gamma == 0.0 else 1.0 - np.exp(-abs(p) / gamma)
        eps = y[i] - p * th
        eps_ref = w * eps + (1.0 - w) * p * (ref - th)
        sp = s * p
        eta = forgetting + p * sp
        th = th + sp / eta * eps_ref
        s = (s - sp * sp / eta) / forgetting
        if s > s_max:
            s = s_max
        theta_out[i] = th
        s_out[i] = s
        w_out[i] = w
    return theta_out, s_out, w_out
