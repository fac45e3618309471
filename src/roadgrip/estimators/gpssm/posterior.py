"""Posterior friction curves of the GP-SSM filter and the peak friction per axle.

Friction curves are reported for the odd part ``(mu(alpha) - mu(-alpha)) / 2`` on
``alpha >= 0`` for the peak (so both turning directions pool), and on any slip grid for
the curves. For the tensor basis the front curve is evaluated along the data manifold
``alpha_r = c alpha_f`` with ``c`` the running least-squares ratio of the estimated slips
(and the rear curve along ``alpha_f = alpha_r / c``). Each particle's function posterior
is Student-t; the curve band is the 95 % interval of the particle mixture (quantiles of
the mixture of t's); the per-step peak band uses the mixture's mean and variance. The
peak is *observed* when the slip histogram reached at least one length scale past the
argmax of the posterior mean curve with ``peak_visits`` samples; otherwise ``mu_*`` is
the highest friction demonstrated inside the visited range, a lower bound,
``mu_*_lower`` its lower band and ``mu_*_upper`` the upper band of the unrestricted peak
(``GPSSMConfig.peak_max``).
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import Z95
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.config import AXLES, GPSSMConfig
from roadgrip.estimators.gpssm.model import Input, State, regularised_speed, slip_angles
from roadgrip.estimators.gpssm.state import (
    Context,
    GPSSMState,
    manifold_ratio,
    sym_pd,
    visited_range,
)
from roadgrip.truth import true_curve

__all__ = ["CurvePosterior", "curves_frame", "mixture_quantile", "peak_estimates", "posterior_curves"]


def mixture_quantile(loc: NDArray, scale: NDArray, weight: NDArray, p: float, dof: float,
                     xtol: float = 1e-7) -> NDArray:
    """The ``p``-quantile of a mixture of Student-t distributions, per column.

    Parameters
    ----------
    loc, scale : ndarray, shape (k, n)
        The ``k`` components' locations and scales in each of ``n`` columns.
    weight : ndarray, shape (k,)
        The components' weights (summing to 1).
    p : float
        The probability, in (0, 1).
    dof : float
        Degrees of freedom of every component; above 500 the normal limit (within 1e-3).
    xtol : float
        Bracket width at the end, in the unit of ``loc``.

    Returns
    -------
    ndarray, shape (n,)
        The middle of a bracket no wider than ``xtol`` whose left end has the mixture's
        CDF below ``p`` and whose right end has it at least ``p``. Bisection from the
        bracket of the components' own ``p``-quantiles, between which the mixture's lies.
        (Newton's steps do not help: a mixture of many narrow components has a CDF of
        steps and plateaus, measured on the GP-SSM's curves.)
    """
    from scipy.special import ndtr, ndtri, stdtr, stdtrit

    normal = dof > 500.0
    comp = loc + scale * float(ndtri(p) if normal else stdtrit(dof, p))
    left, right = comp.min(axis=0), comp.max(axis=0)
    width = float(np.max(right - left)) if comp.size else 0.0
    for _ in range(math.ceil(math.log2(width / xtol)) if width > xtol else 0):
        mid = 0.5 * (left + right)
        z = (mid[None, :] - loc) / scale
        below = weight @ (ndtr(z) if normal else stdtr(dof, z)) < p
        left = np.where(below, mid, left)
        right = np.where(below, right, mid)
    return 0.5 * (left + right)


class CurvePosterior(NamedTuple):
    """Posterior friction curves of both axles on a slip grid.

    Attributes
    ----------
    alpha : ndarray, shape (n,)
        Slip angles [rad].
    mean, lower, upper : ndarray, shape (2, n)
        Mixture mean and 95 % band, rows front and rear [-].
    prior : ndarray, shape (2, n)
        Prior mean curve.
    """

    alpha: NDArray
    mean: NDArray
    lower: NDArray
    upper: NDArray
    prior: NDArray


def held(config: GPSSMConfig, alpha: ArrayLike) -> NDArray:
    """Slip angles [rad] at which the friction model is evaluated: ``alpha`` clipped to
    ``±config.alpha_limit`` (the curve is flat beyond; ``GPSSMConfig.slip_limit``)."""
    lim = config.alpha_limit
    return np.clip(np.asarray(alpha, dtype=float), -lim, lim)


def axle_features(
    config: GPSSMConfig, ratio: float, alpha: NDArray
) -> tuple[NDArray, NDArray]:
    """Features of each axle's curve at ``alpha``: two arrays (n, m) and the (group, row).

    Returns ``feats`` of shape (2, n, m) and ``where`` of shape (2, 2) = (group, row).
    Each slip angle is held to ``±config.alpha_limit`` (:func:`held`).
    """
    b = config.basis
    if b.kind == "tensor":
        ff = b.features(held(config, alpha), held(config, ratio * alpha))[..., 0, :]
        fr = b.features(held(config, alpha / ratio), held(config, alpha))[..., 0, :]
        return np.stack([ff, fr]), np.array([[0, 0], [0, 1]])
    alpha = held(config, alpha)
    f = b.features(alpha, alpha)
    return np.stack([f[..., 0, :], f[..., 1, :]]), np.array([[0, 0], [1, 0]])


def odd_features(config: GPSSMConfig, ratio: float, alpha: NDArray) -> tuple[NDArray, NDArray]:
    fp, where = axle_features(config, ratio, alpha)
    fm, _ = axle_features(config, ratio, -alpha)
    return 0.5 * (fp - fm), where



def axle_rows(config: GPSSMConfig) -> NDArray[np.int64]:
    """(group, row) of each axle's friction, shape (2, 2)."""
    return np.array([[0, 0], [0, 1]] if config.basis.kind == "tensor" else [[0, 0], [1, 0]], np.int64)


def peak_cols(config: GPSSMConfig) -> NDArray[np.int64]:
    """Columns of :func:`peak_rhs` per axle, shape (2, 2): (unrestricted peak, band point)."""
    return np.array([[0, 2], [1, 3]] if config.basis.kind == "tensor" else [[0, 1], [0, 1]], np.int64)


def peak_rhs(ctx: Context, ratio: float, peak_alpha: NDArray) -> NDArray:
    """Odd-part features at the two peak slip angles of each axle (``GPSSMState.peak_alpha``),
    by group: shape (G, m, np) with the columns of :func:`peak_cols`; cached in the
    context."""
    config = ctx.config
    # the manifold ratio to 1 %, as the peak grid (0.05 deg at 10 deg of slip, far below
    # the length scale): the features change only when the ratio or a peak point moves
    r = round(ratio, 2) if config.basis.kind == "tensor" else 1.0
    key = (r, *peak_alpha.ravel().tolist())
    cache = ctx.kernel.setdefault("peak_rhs", {})
    hit = cache.get(key)
    if hit is not None:
        return hit
    f0, _ = peak_features(config, r, float(peak_alpha[0, 0]), float(peak_alpha[0, 1]))
    f1, _ = peak_features(config, r, float(peak_alpha[1, 0]), float(peak_alpha[1, 1]))
    if config.basis.kind == "tensor":
        out = np.stack([f0[0], f0[1], f1[0], f1[1]], axis=-1)[None]
    else:
        out = np.stack([np.stack([f0[0], f1[0]], axis=-1), np.stack([f0[1], f1[1]], axis=-1)])
    out.flags.writeable = False
    if len(cache) >= 256:
        cache.pop(next(iter(cache)))
    cache[key] = out
    return out


@lru_cache(maxsize=64)
def peak_features(config: GPSSMConfig, ratio: float, a_front: float, a_rear: float) -> tuple[NDArray, NDArray]:
    """Odd-part features of the front curve at ``a_front`` and the rear at ``a_rear``,
    (2, m), and the (group, row) table of :func:`axle_features`. Cached: the peak slip
    angles are grid points and the separable bases do not depend on ``ratio``; the arrays
    are read-only."""
    fpk2, where = odd_features(config, ratio, np.array([a_front, a_rear]))  # (2, 2, m)
    fpk = np.stack([fpk2[0, 0], fpk2[1, 1]])
    fpk.flags.writeable = False
    where.flags.writeable = False
    return fpk, where


@lru_cache(maxsize=64)
def peak_grid(config: GPSSMConfig, ratio: float) -> tuple[NDArray, NDArray, NDArray]:
    """Slip grid on ``[0, min(peak_range, alpha_limit)]``, odd-part features (2, n, m) and
    prior curve."""
    grid = np.linspace(0.0, min(config.peak_range, config.alpha_limit), config.peak_grid)
    feats, _ = odd_features(config, ratio, grid)
    return grid, feats, config.prior_tire.mu(held(config, grid))


def peak_estimates(
    config: GPSSMConfig, ratio: float, MT: NDArray, Lam: NDArray, nu: float, w: NDArray,
    vpk: NDArray, visits: NDArray, where: NDArray,
) -> dict[str, list]:
    """Peak friction per axle with band and observability (module docstring)."""
    d = config.basis.outputs
    grid, feats, prior = peak_grid(config, round(ratio, 2))
    qdof = max(nu - d - 1.0, 1.0)
    out: dict[str, list] = {"mu": [], "lo": [], "hi": [], "alpha": [], "alpha_band": [], "obs": []}
    cols = peak_cols(config)
    for ax in range(2):
        g, r = where[ax]
        curves = MT[:, g, :, r] @ feats[ax].T + prior  # (N, n)
        mean = w @ curves
        a_vis = visited_range(config, visits[ax])
        inside = grid < a_vis  # strictly inside: the top bin's upper edge was not reached
        # the learned maximum where the data are (kernel_ops.peak_summary)
        j = int(np.argmax(np.where(inside, mean, -np.inf))) if inside.sum() > 1 else int(np.argmax(mean))
        a_pk = float(grid[j])
        # within-particle variances at the previous step's two peak slip angles
        var_in = np.maximum(vpk[:, g, cols[ax, 0]], 0.0) * Lam[:, g, r, r] / qdof + config.curve_sigma_floor**2
        # at the reported point of an unobserved peak, but never below the variance at the
        # unrestricted peak: a demonstrated maximum can carry a bias of the lateral
        # velocity (non-odd bases) that its own variance does not show
        var_band = np.maximum(np.maximum(vpk[:, g, cols[ax, 1]], 0.0) * Lam[:, g, r, r] / qdof
                              + config.curve_sigma_floor**2, var_in)
        # the data passed the learned maximum: each particle's peak is its maximum inside
        # the visited range, and observed when the band there is narrow (kernel_ops.peak_summary)
        candidate = bool(a_vis >= a_pk + config.peak_margin - 1e-12 and a_pk > 0.0 and j < len(grid) - 1
                         and inside.sum() > 1)
        peaks = curves[:, inside].max(axis=1) if candidate else curves.max(axis=1)
        pm = float(w @ peaks)
        pv = float(w @ ((peaks - pm) ** 2 + var_in))
        hi = pm + Z95 * math.sqrt(max(pv, 0.0))
        observed = bool(candidate and Z95 * math.sqrt(max(pv, 0.0)) <= config.peak_narrow)
        if observed and a_vis < a_pk + config.basis.ell - 1e-12:
            # the data demonstrate the drop past the peak, or pass it by a kernel length
            # scale (kernel_ops.peak_summary)
            past = np.flatnonzero((grid >= a_pk + config.peak_margin - 1e-12) & inside & (np.arange(len(grid)) > j))
            drops = curves[:, [j]] - curves[:, past]  # (N, k)
            dm = w @ drops
            dk = (grid[past] - a_pk) / config.basis.ell
            dv = w @ (drops - dm) ** 2 + 2.0 * config.curve_sigma_floor**2 * (1.0 - np.exp(-0.5 * dk**2))
            observed = bool(np.any(dm > Z95 * np.sqrt(np.maximum(dv, 0.0))))
        a_band = a_pk
        if observed:
            mu_hat, lo = pm, pm - Z95 * math.sqrt(max(pv, 0.0))
        else:
            # past the visited range the curve is the prior's: the data bound the peak
            # only from below (GPSSMConfig.peak_max)
            hi = config.peak_max
            if inside.sum() <= 1:
                mu_hat, lo = 0.0, 0.0
            else:
                ci = curves[:, inside]
                vis_peaks = ci.max(axis=1)
                mu_hat = float(w @ vis_peaks)
                vv = float(w @ ((vis_peaks - mu_hat) ** 2 + var_band))
                lo = mu_hat - Z95 * math.sqrt(max(vv, 0.0))
                a_band = float(grid[int(np.argmax(mean[inside]))])
        out["mu"].append(float(mu_hat))
        out["lo"].append(float(max(lo, 0.0)))
        out["hi"].append(float(max(hi, mu_hat)))
        out["alpha"].append(a_pk)
        out["alpha_band"].append(a_band)
        out["obs"].append(observed)
    return out



def posterior_curves(
    ctx: Context, state: GPSSMState, alpha: NDArray, level: float = 0.95
) -> CurvePosterior:
    """Posterior front and rear friction curves on ``alpha`` [rad] (any signs).

    The mean is the weighted particle mixture of ``mu_prior + M phi`` (Algorithm 1, line
    12). The band is the central ``level`` interval of the mixture of the particles'
    Student-t function posteriors (eq. 25: ``A phi | data`` is t with ``nu - d + 1``
    degrees of freedom and scale ``Lambda_nn phi^T (Sigma + I)^{-1} phi / (nu - d + 1)``),
    each also spread over the slip-angle uncertainty: the curve is learned against the
    *estimated* slip, so the component means are taken at ``alpha + o`` with three-point
    Gauss-Hermite offsets ``o`` for ``N(0, sigma_alpha²)``, ``sigma_alpha² = (particle
    spread of alpha)² + slip_sigma²`` (``GPSSMConfig.slip_sigma``; after resampling the
    particle cloud under-represents the slip error), and each component's scale includes
    ``GPSSMConfig.curve_sigma_floor`` (basis truncation error). Without a measured lateral
    velocity (``vy_source='none'``) the slip angles' scale ``k`` is not identified either
    (``GPSSMConfig.slip_scale_sigma = s``, the same unknown ``vy_std`` holds): the means
    are also taken at ``k alpha + o`` with ``log k ~ N(0, log(1 + s)²)``, independent of
    ``o`` (five components a particle: the three-point rule on each axis, sharing the
    centre). With the default ``s = 0.5`` the outer nodes are at half and twice the slip
    angle; on the random family's snow slalom (``random:102``, ``random:109``) the front
    curves' linear range came out 1.3-1.7 times too shallow, with the band on it missing
    the truth.

    While the filter relearns after a re-initialisation (``GPSSMConfig.relearn_time``
    after a step flagged ``diverged``, :mod:`~roadgrip.estimators.gpssm.guard`) the
    statistics still hold the curve learned on the wrong lateral state: the band is then
    ``[-peak_max, peak_max]`` (no claim), as the peak bands are the physics floor and
    ``peak_max``.
    """
    config = ctx.config
    alpha = np.asarray(alpha, dtype=float)
    b = config.basis
    N, d = config.particles, b.outputs
    ratio = manifold_ratio(state)
    feats, where = axle_features(config, ratio, alpha)  # (2, n, m)
    n = len(alpha)
    w = np.exp(state.logw - state.logw.max())
    w /= w.sum()
    if b.kind == "tensor":
        rhs = np.concatenate([np.swapaxes(state.Psi, -1, -2),
                              np.broadcast_to(np.concatenate([feats[0].T, feats[1].T], axis=1)[None, None],
                                              (N, 1, b.m, 2 * n))], axis=-1)
    else:
        rhs = np.concatenate([np.swapaxes(state.Psi, -1, -2),
                              np.broadcast_to(feats.transpose(0, 2, 1)[None], (N, 2, b.m, n))], axis=-1)
    X, _ = la.solve(state.lin, np.ascontiguousarray(rhs), n_exact=d)
    MT = X[..., :d]
    Lam = sym_pd(config.Lambda0 + state.Phi - np.einsum("ngdm,ngme->ngde", state.Psi, MT), 1e-12)
    dof = state.nu - d + 1.0

    prior = config.prior_tire.mu(held(config, alpha))
    # slip-angle spread of the particle cloud, per axle
    af, ar = slip_angles(state.x[:, State.VY], state.x[:, State.YAW_RATE], state.u[Input.STEER],
                         regularised_speed(float(state.u[Input.VX]), ctx.veh.v_eps), ctx.veh)
    sig_a = [math.sqrt(float(w @ (a_ - w @ a_) ** 2) + config.slip_sigma**2) for a_ in (af, ar)]
    # without a measured lateral velocity the slip angles' scale is not identified either
    # (GPSSMConfig.slip_scale_sigma): log k ~ N(0, log(1 + slip_scale_sigma)²)
    s_log = math.log1p(config.slip_scale_sigma) if config.vy_source == "none" else 0.0
    # nodes (slip offset, slip scale) in standard deviations and their weights: the
    # three-point Gauss-Hermite rule on each axis, sharing the centre (exact for the
    # moments up to the third and for each axis's fourth); without the scale it is the
    # one-dimensional three-point rule
    h = math.sqrt(3.0)
    nodes = [(0.0, 0.0, 4.0 / 6.0), (-h, 0.0, 1.0 / 6.0), (h, 0.0, 1.0 / 6.0)]
    if s_log > 0.0:
        nodes = [(0.0, 0.0, 2.0 / 6.0), *nodes[1:], (0.0, -h, 1.0 / 6.0), (0.0, h, 1.0 / 6.0)]
    mean = np.empty((2, n))
    lo = np.empty((2, n))
    hi = np.empty((2, n))
    tail = 0.5 * (1.0 - level)
    for ax in range(2):
        g, r = where[ax]
        if b.kind == "tensor":
            Pf = X[:, 0, :, d + ax * n: d + (ax + 1) * n]
        else:
            Pf = X[:, g, :, d:]
        M_ax = MT[:, g, :, r]
        loc = M_ax @ feats[ax].T + prior  # (N, n)
        quad = np.maximum(np.einsum("nm,kmn->kn", feats[ax], Pf), 1e-300)
        sc = np.sqrt(Lam[:, g, r, r][:, None] * quad / dof + config.curve_sigma_floor**2)
        mean[ax] = w @ loc
        locs, wts = [], []
        for o, q, wo in nodes:
            if o == 0.0 and q == 0.0:
                locs.append(loc)
            else:
                aj = alpha * math.exp(q * s_log) + o * sig_a[ax]
                fj, _ = axle_features(config, ratio, aj)
                locs.append(M_ax @ fj[ax].T + config.prior_tire.mu(held(config, aj)))
            wts.append(w * wo)
        L_ = np.concatenate(locs)            # (kN, n), k = 3 or 5 nodes
        S_ = np.concatenate([sc] * len(locs))
        W_ = np.concatenate(wts)             # (kN,)
        lo[ax] = mixture_quantile(L_, S_, W_, tail, dof)
        hi[ax] = mixture_quantile(L_, S_, W_, 1.0 - tail, dof)
    g = state.guard
    if state.t < g.flagged_until - config.diverge_time + config.relearn_time:
        lo[:] = -config.peak_max
        hi[:] = config.peak_max
    return CurvePosterior(alpha, mean, lo, hi, np.stack([prior, prior]))


def curves_frame(curves: dict[float, CurvePosterior], drive: Any = None) -> pd.DataFrame:
    """Long table ``t, axle, alpha, mu_mean, mu_lower, mu_upper, mu_prior[, mu_true]``.

    ``mu_true`` is the drive's true curve (:func:`roadgrip.truth.true_curve`) where the
    drive carries truth: parametric, or binned (NaN where the truth visited no bin).
    """
    frames = []
    for t, c in curves.items():
        for ax, axle in enumerate(AXLES):
            f = pd.DataFrame({
                "t": t, "axle": axle, "alpha": c.alpha, "mu_mean": c.mean[ax],
                "mu_lower": c.lower[ax], "mu_upper": c.upper[ax], "mu_prior": c.prior[ax],
            })
            if drive is not None and drive.has_truth:
                try:  # parametric, or binned (NaN where the drive's truth visited no bin)
                    f["mu_true"] = true_curve(drive, axle)(c.alpha)
                except Exception:
                    pass
            frames.append(f)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
