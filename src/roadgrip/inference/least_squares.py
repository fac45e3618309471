r"""Least squares on sensor data: correlated residuals, noisy regressors, held samples.

Three things a regression on logged signals must allow for, each a small pure function:

- **Correlated residuals.** Filtered signals give residuals correlated from one sample to
  the next; the coefficients' covariance is inflated by ``n / n_eff`` with ``n_eff = n (1 -
  rho_1)/(1 + rho_1)`` (``rho_1`` the residuals' lag-one autocorrelation)
  (:func:`lstsq`).
- **Noisy regressors.** White noise ``dX`` on the regressors inflates ``X'X`` by ``E[dX'
  dX]`` and draws plain least squares towards zero (regression dilution, Fuller 1987,
  *Measurement Error Models*, section 2.2). Where that noise is known the corrected
  estimate ``b = (X'X - E[dX' dX])^-1 X'y`` is consistent (:func:`eiv_lstsq`); the noise
  of a filtered signal is its white noise times the filter's energy ``sum w_k²``
  (:func:`filter_noise_energy`).
- **A second, independent measurement of a function of the coefficients.** An estimate
  ``b`` with covariance ``C`` and an independent scalar measurement ``z = g(b) + e``,
  ``e ~ N(0, v)``, combine into the generalised least-squares estimate minimising ``(b' -
  b)' C^-1 (b' - b) + (z - g(b'))² / v`` (Gauss-Newton on ``g``; exact in one step for a
  linear ``g``) (:func:`fuse_scalar`).
- **Held samples.** A logger that resamples a bus repeats the last value received while a
  message is missing; during the hold the channel is late by up to the hold's length. A
  channel whose white noise exceeds its resolution never repeats a value
  ``HOLD_SAMPLES`` times by chance, so such runs are holds (:func:`held_samples`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.io.derived import savgol_quadratic, white_noise_std

__all__ = ["HOLD_SAMPLES", "eiv_lstsq", "filter_noise_energy", "fuse_scalar", "held_samples", "lstsq",
           "n_eff"]

HOLD_SAMPLES = 4
"""Fewest consecutive identical samples taken for a hold (on a channel whose white noise
exceeds its resolution, three repeats by chance have probability below ~1e-4)."""


def n_eff(res: NDArray) -> float:
    """Effective number of independent residuals, ``n (1 - rho_1)/(1 + rho_1)`` (at least 2).

    Parameters
    ----------
    res : ndarray, shape (n,)
        Residuals in time order.

    Returns
    -------
    float
    """
    n = len(res)
    if n < 3:
        return float(n)
    r0 = float(np.dot(res, res))
    rho = float(np.dot(res[1:], res[:-1]) / r0) if r0 > 0 else 0.0
    rho = min(max(rho, 0.0), 0.999)
    return max(n * (1.0 - rho) / (1.0 + rho), 2.0)


def lstsq(X: NDArray, y: NDArray) -> tuple[NDArray, NDArray, float]:
    """Ordinary least squares with the residuals' correlation in the covariance.

    Parameters
    ----------
    X : ndarray, shape (n, p)
    y : ndarray, shape (n,)

    Returns
    -------
    beta : ndarray, shape (p,)
    cov : ndarray, shape (p, p)
        ``sigma² (X'X)^-1``, ``sigma²`` the residual variance times ``n / n_eff``.
    rss : float
        Residual sum of squares.
    """
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    res = y - X @ beta
    rss = float(res @ res)
    n, p = X.shape
    sigma2 = rss / max(n - p, 1) * (n / n_eff(res))
    return beta, sigma2 * np.linalg.pinv(X.T @ X), rss


def eiv_lstsq(X: NDArray, y: NDArray, noise: NDArray) -> tuple[NDArray, NDArray, float, float]:
    """Least squares corrected for the known noise of the regressors (module docstring).

    ``b = (X'X - noise)^-1 X'y`` minimises ``|y - X b|² - b' noise b``; with ``noise = 0`` it
    is :func:`lstsq`.

    Parameters
    ----------
    X : ndarray, shape (n, p)
        Measured regressors.
    y : ndarray, shape (n,)
    noise : ndarray, shape (p, p)
        ``E[dX' dX]``: the regressors' noise covariance summed over the ``n`` rows.

    Returns
    -------
    beta : ndarray, shape (p,)
    cov : ndarray, shape (p, p)
        ``sigma² A^-1 X'X A^-1``, ``A = X'X - noise``, ``sigma²`` as in :func:`lstsq`.
    rss : float
        Residual sum of squares at ``beta``.
    objective : float
        The corrected objective at its minimum, ``y'y - y'X b`` (to profile over a
        parameter that moves ``y``, e.g. a delay).

    Raises
    ------
    numpy.linalg.LinAlgError
        ``X'X - noise`` is singular (the noise explains a regressor whole).
    """
    xtx = X.T @ X
    A = xtx - noise
    xty = X.T @ y
    beta = np.linalg.solve(A, xty)
    res = y - X @ beta
    rss = float(res @ res)
    n, p = X.shape
    sigma2 = rss / max(n - p, 1) * (n / n_eff(res))
    a_inv = np.linalg.inv(A)
    return beta, sigma2 * a_inv @ xtx @ a_inv, rss, float(y @ y - xty @ beta)


def fuse_scalar(beta: NDArray, cov: NDArray, g: Callable[[NDArray], float], z: float,
                var: float, *, iterations: int = 20) -> tuple[NDArray, NDArray]:
    """An estimate combined with an independent measurement of a scalar function of it
    (module docstring).

    Parameters
    ----------
    beta : ndarray, shape (p,)
        The estimate.
    cov : ndarray, shape (p, p)
        Its covariance (positive definite).
    g : callable
        ``g(b) -> float``, smooth near ``beta``; differentiated numerically.
    z : float
        The measurement of ``g``, in ``g``'s unit.
    var : float
        Its variance, ``> 0``.
    iterations : int
        Most Gauss-Newton steps.

    Returns
    -------
    beta : ndarray, shape (p,)
        The combined estimate.
    cov : ndarray, shape (p, p)
        Its covariance, ``(C^-1 + h h' / var)^-1`` with ``h`` the gradient of ``g`` there.

    Raises
    ------
    ValueError
        ``var`` not positive and finite.

    Examples
    --------
    >>> b, c = fuse_scalar(np.array([1.0, 2.0]), np.eye(2), lambda b: b[0], 3.0, 1.0)
    >>> b.round(6), c.round(6)
    (array([2., 2.]), array([[0.5, 0. ],
           [0. , 1. ]]))
    """
    if not (np.isfinite(var) and var > 0):
        raise ValueError(f"the measurement's variance must be positive and finite, got {var!r}")
    beta = np.asarray(beta, float)
    c_inv = np.linalg.inv(cov)
    b = beta.copy()

    def grad(b):
        h = 1e-7 * np.maximum(np.abs(b), 1e-12)
        g0 = g(b)
        return np.array([(g(b + h[k] * np.eye(len(b))[k]) - g0) / h[k] for k in range(len(b))])

    for _ in range(iterations):
        h = grad(b)
        info = c_inv + np.outer(h, h) / var
        step = np.linalg.solve(info, c_inv @ (beta - b) + h * (z - g(b)) / var)
        b = b + step
        if np.all(np.abs(step) <= 1e-12 * np.maximum(np.abs(b), 1e-300)):
            break
    h = grad(b)
    return b, np.linalg.inv(c_inv + np.outer(h, h) / var)


def filter_noise_energy(m: int, deriv: int = 0, delta: float = 1.0, shift: float = 0.0) -> float:
    """``sum w_k²`` of a quadratic Savitzky-Golay filter of ``2 m + 1`` samples
    (:func:`roadgrip.io.derived.savgol_quadratic`), after a linear interpolation by a
    fraction ``shift`` of a sample: white noise of standard deviation ``s`` leaves the
    filtered signal with variance ``s² sum w_k²``.

    Parameters
    ----------
    m : int
        Half-width [samples], ``>= 1``.
    deriv : {0, 1}
        Value or slope.
    delta : float
        Sample spacing [s] (for ``deriv=1``: the energy is then in 1/s²).
    shift : float
        Interpolation offset [samples]; only its fractional part matters.

    Returns
    -------
    float

    Examples
    --------
    >>> round(filter_noise_energy(1, deriv=1), 3)  # (v[i+1] - v[i-1]) / 2
    0.5
    """
    impulse = np.zeros(4 * m + 3)
    impulse[2 * m + 1] = 1.0
    w = savgol_quadratic(impulse, 2 * m + 1, deriv=deriv, delta=delta)
    w = w[np.isfinite(w)]
    f = float(shift) % 1.0
    if f:
        w = np.convolve(w, [1.0 - f, f])
    return float(w @ w)


def held_samples(v: ArrayLike) -> NDArray[np.bool_]:
    """Samples of a noisy channel that repeat a value held by the logger (module docstring).

    Parameters
    ----------
    v : array_like, shape (n,)
        One channel as logged.

    Returns
    -------
    ndarray of bool, shape (n,)
        True on every sample of a run of at least :data:`HOLD_SAMPLES` identical values;
        all False when the channel's white noise (:func:`roadgrip.io.derived.white_noise_std`)
        does not exceed its resolution (its smallest non-zero step: such a channel may
        sit still for real).

    Examples
    --------
    >>> v = np.sin(np.arange(12.0))
    >>> v[4:9] = v[4]
    >>> held_samples(v).nonzero()[0]
    array([4, 5, 6, 7, 8])
    """
    v = np.asarray(v, float)
    n = len(v)
    out = np.zeros(n, bool)
    if n < HOLD_SAMPLES:
        return out
    step = np.abs(np.diff(v))
    moving = step[np.isfinite(step) & (step > 0)]
    if not moving.size or not white_noise_std(v) > float(moving.min()):
        return out
    same = np.concatenate(([False], step == 0))
    run_id = np.cumsum(~same)
    length = np.bincount(run_id)
    return length[run_id] >= HOLD_SAMPLES
