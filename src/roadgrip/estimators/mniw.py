r"""Matrix-normal inverse-Wishart (MNIW) conjugate model for ``zeta = A phi + w``.

Model (paper 000, eq. 14 and 24; Svensson & Schön 2017): ``zeta`` in ``R^d``, features
``phi`` in ``R^m``, ``w ~ N(0, Q)``, prior

.. math::

    Q \sim \mathcal{IW}(\nu_0, \Lambda_0), \qquad A \mid Q \sim \mathcal{MN}(0, Q, V),

with ``V`` the column covariance of ``A``. The features of
:mod:`roadgrip.estimators.basis` are whitened so that ``V = I``: the prior precision added
to the data statistic is the identity. The inverse-Wishart density is
``|Q|^{-(nu + d + 1)/2} exp(-tr(Lambda Q^{-1})/2)``, mean ``Lambda / (nu - d - 1)``.

Sufficient statistics (eq. 26-29), with forgetting factor ``lam``::

    time update    Phi <- lam Phi,  Psi <- lam Psi,  Sigma <- lam Sigma,  nu <- lam nu   (29)
    data update    Phi += zeta zeta^T, Psi += zeta phi^T, Sigma += phi phi^T, nu += 1      (28)

(eq. 28c of the extracted text reads ``zeta alpha^T``; it is ``zeta zeta^T``, as in 27a).
Posterior (eq. 25): ``Q ~ IW(nu, Lambda)``, ``A | Q ~ MN(M, Q, (Sigma + I)^{-1})`` with
``M = Psi (Sigma + I)^{-1}`` and ``Lambda = Lambda_0 + Phi - M Psi^T``. The one-step
predictive of ``zeta`` at a new ``phi`` (marginal of eq. 31-32) is the multivariate
Student-t with ``nu - d + 1`` degrees of freedom, location ``M phi`` and scale matrix
``(1 + phi^T (Sigma + I)^{-1} phi) Lambda / (nu - d + 1)``.

All functions broadcast over leading batch axes (particles, groups).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "MNIWPosterior",
    "MNIWStats",
    "batch_stats",
    "forget",
    "posterior",
    "predictive",
    "prior_stats",
    "sample_matrix_t",
    "sample_student_t",
    "update",
]


class MNIWStats(NamedTuple):
    """Sufficient statistics; leading axes ``...`` are batch axes.

    Attributes
    ----------
    Sigma : ndarray, shape (..., m, m)
        ``sum phi phi^T`` (eq. 26c), whitened features.
    Psi : ndarray, shape (..., d, m)
        ``sum zeta phi^T`` (eq. 26b).
    Phi : ndarray, shape (..., d, d)
        ``sum zeta zeta^T`` (eq. 26a).
    nu : ndarray, shape (...)
        Degrees of freedom of the inverse-Wishart posterior (eq. 28f).
    """

    Sigma: NDArray[np.float64]
    Psi: NDArray[np.float64]
    Phi: NDArray[np.float64]
    nu: NDArray[np.float64]


class MNIWPosterior(NamedTuple):
    """Posterior parameters (eq. 25): ``M`` (..., d, m), ``P = (Sigma + I)^{-1}`` (..., m, m),
    ``Lambda`` (..., d, d), ``nu`` (...)."""

    M: NDArray[np.float64]
    P: NDArray[np.float64]
    Lambda: NDArray[np.float64]
    nu: NDArray[np.float64]


def prior_stats(batch: tuple[int, ...], m: int, d: int, nu0: float) -> MNIWStats:
    """Zero statistics with ``nu = nu0`` for a batch of independent models."""
    return MNIWStats(
        np.zeros((*batch, m, m)),
        np.zeros((*batch, d, m)),
        np.zeros((*batch, d, d)),
        np.full(batch, float(nu0)),
    )


def forget(stats: MNIWStats, lam: float) -> MNIWStats:
    """Time update (eq. 29): every statistic and ``nu`` scaled by ``lam``."""
    return MNIWStats(lam * stats.Sigma, lam * stats.Psi, lam * stats.Phi, lam * stats.nu)


def update(stats: MNIWStats, phi: NDArray, zeta: NDArray) -> MNIWStats:
    """Data update (eq. 28b-d, f) with features ``phi`` (..., m) and target ``zeta`` (..., d)."""
    return MNIWStats(
        stats.Sigma + phi[..., :, None] * phi[..., None, :],
        stats.Psi + zeta[..., :, None] * phi[..., None, :],
        stats.Phi + zeta[..., :, None] * zeta[..., None, :],
        stats.nu + 1.0,
    )


def batch_stats(phis: NDArray, zetas: NDArray, nu0: float, lam: float = 1.0) -> MNIWStats:
    """Closed form of eq. 26 over a record, with forgetting weights ``lam^(T-1-k)``.

    Parameters
    ----------
    phis : ndarray, shape (T, m)
    zetas : ndarray, shape (T, d)
    nu0 : float
    lam : float
        Forgetting factor; the statistics equal ``T`` updates (:func:`update`) with a
        :func:`forget` between consecutive ones (none before the first).
    """
    T = len(phis)
    w = lam ** np.arange(T - 1, -1, -1, dtype=float)
    Sigma = (phis * w[:, None]).T @ phis
    Psi = (zetas * w[:, None]).T @ phis
    Phi = (zetas * w[:, None]).T @ zetas
    nu = lam ** (T - 1) * nu0 + w.sum()
    return MNIWStats(Sigma, Psi, Phi, np.asarray(nu))


def posterior(stats: MNIWStats, Lambda0: NDArray) -> MNIWPosterior:
    """MNIW posterior parameters (eq. 25) by a direct solve (reference implementation)."""
    m = stats.Sigma.shape[-1]
    H = stats.Sigma + np.eye(m)
    P = np.linalg.inv(H)
    P = 0.5 * (P + np.swapaxes(P, -1, -2))
    M = stats.Psi @ P
    Lam = Lambda0 + stats.Phi - M @ np.swapaxes(stats.Psi, -1, -2)
    Lam = 0.5 * (Lam + np.swapaxes(Lam, -1, -2))
    return MNIWPosterior(M, P, Lam, stats.nu)


def predictive(
    post: MNIWPosterior, phi: NDArray
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Student-t predictive of ``zeta = A phi + w`` (eq. 31-32).

    Returns
    -------
    loc : ndarray, shape (..., d)
    scale : ndarray, shape (..., d, d)
        Scale matrix (covariance ``scale dof / (dof - 2)``).
    dof : ndarray, shape (...)
    """
    d = post.M.shape[-2]
    loc = np.einsum("...dm,...m->...d", post.M, phi)
    s = np.einsum("...m,...mn,...n->...", phi, post.P, phi)
    dof = post.nu - d + 1.0
    scale = post.Lambda * ((1.0 + s) / dof)[..., None, None]
    return loc, scale, dof


def sample_student_t(
    rng: np.random.Generator, loc: NDArray, scale: NDArray, dof: NDArray
) -> NDArray[np.float64]:
    """One draw per batch element of a multivariate t (``loc`` (..., d), ``scale`` (..., d, d)).

    ``x = loc + chol(scale) z / sqrt(g / dof)`` with ``z ~ N(0, I)``, ``g ~ chi²(dof)``.
    """
    d = loc.shape[-1]
    L = np.linalg.cholesky(scale)
    z = rng.standard_normal(loc.shape)
    g = rng.chisquare(np.broadcast_to(dof, loc.shape[:-1]))
    return loc + np.einsum("...ij,...j->...i", L, z) * np.sqrt(dof / g)[..., None] * (d > 0)


def sample_matrix_t(
    rng: np.random.Generator, post: MNIWPosterior, size: int
) -> NDArray[np.float64]:
    """Draws of the whole matrix ``A`` from its marginal posterior (matrix-t, eq. 32).

    ``Q ~ IW(nu, Lambda)`` then ``A = M + chol(Q) Z chol(P)^T`` with ``Z`` standard normal.
    Unbatched: ``post.M`` is (d, m). Returns an array of shape (size, d, m).
    """
    from scipy.stats import invwishart

    d, m = post.M.shape
    Q = invwishart(df=float(post.nu), scale=post.Lambda).rvs(size=size, random_state=rng)
    Q = np.asarray(Q).reshape(size, d, d)
    Lq = np.linalg.cholesky(Q)
    Lp = np.linalg.cholesky(post.P)
    Z = rng.standard_normal((size, d, m))
    return post.M + Lq @ Z @ Lp.T
