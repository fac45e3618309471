"""Compiled building blocks of the GP-SSM filter, and the peak summary.

The matrix-vector products and the Neumann-series solve that the particle pass
(:mod:`roadgrip.estimators.gpssm.kernel`) and the linear algebra
(:mod:`roadgrip.estimators.gpssm.linalg`) share, the slot plan of the deferred
updates, the prior Magic Formula and the basis sines, and :func:`peak_summary`, the
peak friction per axle from the particles' posterior mean curves.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["PEAK", "PeakGrid", "PeakParams", "PeakPosterior", "neumann_solve", "peak_summary", "slot_plan"]


class PEAK:
    """Slots of a row of :func:`peak_summary`'s output (one row per axle)."""

    MU, LOWER, UPPER, ALPHA, OBSERVED, ALPHA_BAND, SIZE = range(7)


# the same slots as module constants (compiled code reads globals, not class attributes)
_PK_MU, _PK_LO, _PK_HI, _PK_ALPHA, _PK_OBS, _PK_BAND = range(6)


class PeakPosterior(NamedTuple):
    """The particles' posterior as :func:`peak_summary` reads it."""

    M: NDArray
    """(N, G, d, m) posterior mean (eq. 28a)."""
    Lam: NDArray
    """(N, G, d, d) posterior ``Lambda``."""
    logw: NDArray
    """(N,) normalised log weights."""
    vpk: NDArray
    """(N, G, np) ``f^T H^{-1} f`` of the peak features."""


class PeakGrid(NamedTuple):
    """The slip grid of the peak search and its features."""

    feats: NDArray
    """(2, ng, m) odd-part features of each axle's curve."""
    prior: NDArray
    """(ng,) prior mean curve."""
    grid: NDArray
    """(ng,) slip angles [rad]."""
    where: NDArray
    """(2, 2) (group, row) per axle."""
    col: NDArray
    """(2, 2) columns of ``vpk`` per axle."""


class PeakParams(NamedTuple):
    """Scalars of :func:`peak_summary`."""

    qdof: float
    margin: float
    z95: float
    floor2: float
    peak_max: float
    narrow: float
    ell: float


@numba.njit(cache=True, fastmath=True, inline="always")
def _sines(a, L, nf, out):  # pragma: no cover - compiled
    """``out[j] = sin(pi (j + 1) (a + L) / (2 L)) / sqrt(L)``, ``a`` clipped to [-L, L]."""
    if a > L:
        a = L
    elif a < -L:
        a = -L
    th = math.pi * (a + L) / (2.0 * L)
    s1, c1 = math.sin(th), math.cos(th)
    s, c = s1, c1
    k = 1.0 / math.sqrt(L)
    for j in range(nf):
        out[j] = s * k
        s, c = s * c1 + c * s1, c * c1 - s * s1


@numba.njit(cache=True, inline="always")
def _mf(a, B, C, D, E):  # pragma: no cover - compiled
    bs = B * a
    return D * math.sin(C * math.atan(bs - E * (bs - math.atan(bs))))


@numba.njit(cache=True, inline="always")
def _sym_pd(S, floor):  # pragma: no cover - compiled
    """In place: symmetrise a (d, d) matrix, floor its diagonal, keep a 2 x 2 one PD."""
    d = S.shape[0]
    for i in range(d):
        for j in range(i + 1, d):
            v = 0.5 * (S[i, j] + S[j, i])
            S[i, j] = v
            S[j, i] = v
        if S[i, i] < floor:
            S[i, i] = floor
    if d == 2:
        lim = math.sqrt(S[0, 0] * S[1, 1]) * (1.0 - 1e-9)
        v = min(max(S[0, 1], -lim), lim)
        S[0, 1] = v
        S[1, 0] = v


@numba.njit(cache=True, fastmath=True, inline="always")
def _mv3(P, src, o, dst, fac):  # pragma: no cover - compiled
    """``dst[o:o+3] = fac P src[o:o+3]`` (rows are vectors), four rows of ``P`` at a time."""
    m = P.shape[0]
    z = 0.0
    m4 = m - m % 4
    for i in range(0, m4, 4):
        a00 = z; a01 = z; a02 = z; a10 = z; a11 = z; a12 = z  # noqa: E702
        a20 = z; a21 = z; a22 = z; a30 = z; a31 = z; a32 = z  # noqa: E702
        for j in range(m):
            p0 = P[i, j]; p1 = P[i + 1, j]; p2 = P[i + 2, j]; p3 = P[i + 3, j]  # noqa: E702
            r0 = src[o, j]; r1 = src[o + 1, j]; r2 = src[o + 2, j]  # noqa: E702
            a00 += p0 * r0; a01 += p0 * r1; a02 += p0 * r2  # noqa: E702
            a10 += p1 * r0; a11 += p1 * r1; a12 += p1 * r2  # noqa: E702
            a20 += p2 * r0; a21 += p2 * r1; a22 += p2 * r2  # noqa: E702
            a30 += p3 * r0; a31 += p3 * r1; a32 += p3 * r2  # noqa: E702
        dst[o, i] = fac * a00; dst[o + 1, i] = fac * a01; dst[o + 2, i] = fac * a02  # noqa: E702
        dst[o, i + 1] = fac * a10; dst[o + 1, i + 1] = fac * a11; dst[o + 2, i + 1] = fac * a12  # noqa: E702
        dst[o, i + 2] = fac * a20; dst[o + 1, i + 2] = fac * a21; dst[o + 2, i + 2] = fac * a22  # noqa: E702
        dst[o, i + 3] = fac * a30; dst[o + 1, i + 3] = fac * a31; dst[o + 2, i + 3] = fac * a32  # noqa: E702
    for i in range(m4, m):
        for r in range(o, o + 3):
            acc = z
            for j in range(m):
                acc += P[i, j] * src[r, j]
            dst[r, i] = fac * acc


@numba.njit(cache=True, fastmath=True, inline="always")
def _mv2(P, src, o, dst, fac):  # pragma: no cover - compiled
    """``dst[o:o+2] = fac P src[o:o+2]``, four rows of ``P`` at a time."""
    m = P.shape[0]
    z = 0.0
    m4 = m - m % 4
    for i in range(0, m4, 4):
        a00 = z; a01 = z; a10 = z; a11 = z; a20 = z; a21 = z; a30 = z; a31 = z  # noqa: E702
        for j in range(m):
            p0 = P[i, j]; p1 = P[i + 1, j]; p2 = P[i + 2, j]; p3 = P[i + 3, j]  # noqa: E702
            r0 = src[o, j]; r1 = src[o + 1, j]  # noqa: E702
            a00 += p0 * r0; a01 += p0 * r1; a10 += p1 * r0; a11 += p1 * r1  # noqa: E702
            a20 += p2 * r0; a21 += p2 * r1; a30 += p3 * r0; a31 += p3 * r1  # noqa: E702
        dst[o, i] = fac * a00; dst[o + 1, i] = fac * a01  # noqa: E702
        dst[o, i + 1] = fac * a10; dst[o + 1, i + 1] = fac * a11  # noqa: E702
        dst[o, i + 2] = fac * a20; dst[o + 1, i + 2] = fac * a21  # noqa: E702
        dst[o, i + 3] = fac * a30; dst[o + 1, i + 3] = fac * a31  # noqa: E702
    for i in range(m4, m):
        for r in range(o, o + 2):
            acc = z
            for j in range(m):
                acc += P[i, j] * src[r, j]
            dst[r, i] = fac * acc


@numba.njit(cache=True, fastmath=True, inline="always")
def _mv1(P, src, o, dst, fac):  # pragma: no cover - compiled
    """``dst[o] = fac P src[o]``, four rows of ``P`` at a time."""
    m = P.shape[0]
    z = 0.0
    m4 = m - m % 4
    for i in range(0, m4, 4):
        a0 = z; a1 = z; a2 = z; a3 = z  # noqa: E702
        for j in range(m):
            r0 = src[o, j]
            a0 += P[i, j] * r0; a1 += P[i + 1, j] * r0  # noqa: E702
            a2 += P[i + 2, j] * r0; a3 += P[i + 3, j] * r0  # noqa: E702
        dst[o, i] = fac * a0; dst[o, i + 1] = fac * a1  # noqa: E702
        dst[o, i + 2] = fac * a2; dst[o, i + 3] = fac * a3  # noqa: E702
    for i in range(m4, m):
        acc = z
        for j in range(m):
            acc += P[i, j] * src[o, j]
        dst[o, i] = fac * acc


@numba.njit(cache=True, inline="always")
def _mv(P, src, nrhs, dst, fac):  # pragma: no cover - compiled
    """``dst[:nrhs] = fac P src[:nrhs]`` in register-blocked chunks of up to three vectors."""
    o = 0
    while o < nrhs:
        k = nrhs - o
        if k >= 3:
            _mv3(P, src, o, dst, fac)
            o += 3
        elif k == 2:
            _mv2(P, src, o, dst, fac)
            o += 2
        else:
            _mv1(P, src, o, dst, fac)
            o += 1


@numba.njit(cache=True, fastmath=True, inline="always")
def neumann_solve(P, p_scale, delta, R, nr, n_exact, tol, max_terms, X, pb, cur, nxt):  # pragma: no cover
    """``X[:nr] = H^{-1} R[:nr]`` (rows are right-hand sides) by the Neumann series
    ``sum_n (-delta)^n P_B^{n+1}`` with ``P_B = p_scale P``. Rows below ``n_exact`` get
    terms until one falls below ``tol`` of the sum (at most ``max_terms``); the others one
    correction term. ``pb = P_B R[0]``."""
    m = P.shape[0]
    _mv(P, R, nr, cur, p_scale)
    for r in range(nr):
        for i in range(m):
            X[r, i] = cur[r, i]
    for i in range(m):
        pb[i] = cur[0, i]
    if delta != 0.0 and max_terms > 0:
        xmax = 0.0
        for r in range(n_exact):
            for i in range(m):
                v = abs(X[r, i])
                if v > xmax:
                    xmax = v
        fac = -delta * p_scale
        n_rhs = nr
        for _it in range(max_terms):
            _mv(P, cur, n_rhs, nxt, fac)
            tmax = 0.0
            for r in range(n_rhs):
                for i in range(m):
                    v = nxt[r, i]
                    X[r, i] += v
                    if r < n_exact and abs(v) > tmax:
                        tmax = abs(v)
            cur, nxt = nxt, cur
            n_rhs = n_exact
            if tmax <= tol * xmax:
                break


@numba.njit(cache=True)
def slot_plan(panc):  # pragma: no cover - compiled
    """Destination slot and processing order for :func:`particle_pass`, shape (N,) each.

    ``panc[n]`` is the slot particle ``n`` reads. The first particle reading a slot keeps
    it and updates it in place; the others (copies of a resampled particle) are given
    the slots nobody reads and are processed first, while their source is intact.
    ``pdst`` is a permutation of the slots.
    """
    N = panc.shape[0]
    first = np.full(N, -1, np.int64)
    for n in range(N):
        if first[panc[n]] < 0:
            first[panc[n]] = n
    pdst = np.empty(N, np.int64)
    order = np.empty(N, np.int64)
    free = 0
    k = 0
    for n in range(N):
        s = panc[n]
        if first[s] == n:
            pdst[n] = s
        else:
            while first[free] >= 0:
                free += 1
            pdst[n] = free
            free += 1
            order[k] = n
            k += 1
    for n in range(N):
        if first[panc[n]] == n:
            order[k] = n
            k += 1
    return pdst, order


@numba.njit(cache=True, fastmath=True)
def peak_summary(post, pg, a_vis, prm, out):  # pragma: no cover - compiled
    """Peak friction per axle (:func:`roadgrip.estimators.gpssm.posterior.peak_estimates`).

    Parameters
    ----------
    post : PeakPosterior
        ``M`` (N, G, d, m), ``Lam`` (N, G, d, d), ``logw`` (N,) normalised log weights,
        ``vpk`` (N, G, np).
    pg : PeakGrid
        ``feats`` (2, ng, m) odd-part features of each axle's curve on ``grid`` (ng,)
        [rad]; ``prior`` (ng,) prior mean curve; ``where`` (2, 2) (group, row) per axle;
        ``col`` (2, 2) columns of ``vpk`` per axle: at the unrestricted peak and at the
        band point (the lower band of an unobserved peak uses the larger of the two
        variances).
    a_vis : (2,) visited slip range [rad]
    prm : PeakParams
        ``qdof = max(nu - d - 1, 1)``; ``margin`` how far [rad] the visited range
        must pass the argmax for the peak to be observed; ``narrow`` the largest 95 %
        half-width [-] of an observed peak; ``z95``;
        ``floor2`` the variance [-] added to every particle's (``curve_sigma_floor²``:
        the basis truncation error, which moves the peak of a represented curve too);
        ``peak_max`` the upper band of a peak that was not observed; ``ell`` the kernel
        length scale [rad] (the correlation of the truncation error at two slip angles).
    out : (2, PEAK.SIZE) rows front/rear, slots of :class:`PEAK`
    """
    M, Lam, logw, vpk = post.M, post.Lam, post.logw, post.vpk
    feats, prior, grid, where, col = pg.feats, pg.prior, pg.grid, pg.where, pg.col
    qdof, margin, z95, floor2, peak_max = prm.qdof, prm.margin, prm.z95, prm.floor2, prm.peak_max
    N = M.shape[0]
    m = M.shape[3]
    ng = grid.shape[0]
    Mr = np.empty((N, m))
    fT = np.empty((m, ng))
    C = np.empty((N, ng))
    mean = np.empty(ng)
    peaks = np.empty(N)
    vis = np.empty(N)
    w = np.empty(N)
    for n in range(N):
        w[n] = math.exp(logw[n])
    for ax in range(2):
        g = where[ax, 0]
        r = where[ax, 1]
        n_in = 0
        for k in range(ng):
            mean[k] = 0.0
            if grid[k] < a_vis[ax]:
                n_in += 1
        # every particle's curve on the grid as one matrix product (BLAS)
        for n in range(N):
            for j in range(m):
                Mr[n, j] = M[n, g, r, j]
        for j in range(m):
            for k in range(ng):
                fT[j, k] = feats[ax, k, j]
        np.dot(Mr, fT, C)
        for n in range(N):
            best = -np.inf
            best_in = -np.inf
            for k in range(ng):
                acc = prior[k] + C[n, k]
                mean[k] += w[n] * acc
                if acc > best:
                    best = acc
                if grid[k] < a_vis[ax] and acc > best_in:
                    best_in = acc
            peaks[n] = best
            vis[n] = best_in
        # the learned maximum where the data are (past the visited range the mean curve
        # is the prior's and can swing anywhere); over the whole grid before any data
        jmax = 0
        for k in range(1, ng):
            if mean[k] > mean[jmax] and (n_in <= 1 or grid[k] < a_vis[ax]):
                jmax = k
        a_pk = grid[jmax]
        # the data passed the learned maximum: each particle's peak is its maximum inside
        # the visited range (past it the curves are the prior's), and observed when the
        # band there is narrow
        candidate = a_vis[ax] >= a_pk + margin - 1e-12 and a_pk > 0.0 and jmax < ng - 1 and n_in > 1
        pm = 0.0
        for n in range(N):
            pm += w[n] * (vis[n] if candidate else peaks[n])
        pv = 0.0
        for n in range(N):
            var_in = max(vpk[n, g, col[ax, 0]], 0.0) * Lam[n, g, r, r] / qdof + floor2
            pv += w[n] * (((vis[n] if candidate else peaks[n]) - pm) ** 2 + var_in)
        hi = pm + z95 * math.sqrt(max(pv, 0.0))
        # the data demonstrate the drop: at some visited slip at least ``margin`` past the
        # peak the curve is lower than at the peak by more than z95 standard deviations
        # of the difference (the particles' spread of it and the basis truncation error's,
        # correlated over the kernel length scale ``ell``): never because the prior bends
        # the mean down at the edge of the data
        # (or the data pass it by a kernel length scale, past the reach of the edge's pull:
        # a flat-topped curve saturated over several degrees has no drop to show)
        dropped = a_vis[ax] >= a_pk + prm.ell - 1e-12
        if candidate and z95 * math.sqrt(max(pv, 0.0)) <= prm.narrow and not dropped:
            for k in range(jmax + 1, ng):
                if grid[k] >= a_vis[ax] or dropped:
                    break
                if grid[k] < a_pk + margin - 1e-12:
                    continue
                dm = 0.0
                for n in range(N):
                    dm += w[n] * (prior[jmax] + C[n, jmax] - prior[k] - C[n, k])
                dk = (grid[k] - a_pk) / prm.ell
                dv = 2.0 * floor2 * (1.0 - math.exp(-0.5 * dk * dk))
                for n in range(N):
                    dn = prior[jmax] + C[n, jmax] - prior[k] - C[n, k]
                    dv += w[n] * (dn - dm) ** 2
                dropped = dm > z95 * math.sqrt(max(dv, 0.0))
        observed = dropped and candidate and z95 * math.sqrt(max(pv, 0.0)) <= prm.narrow
        a_band = a_pk
        if observed:
            mu_hat = pm
            lo = pm - z95 * math.sqrt(max(pv, 0.0))
        elif n_in <= 1:
            mu_hat = 0.0
            lo = 0.0
        else:
            mu_hat = 0.0
            for n in range(N):
                mu_hat += w[n] * vis[n]
            vv = 0.0
            for n in range(N):
                var_in = max(max(vpk[n, g, col[ax, 1]], 0.0), max(vpk[n, g, col[ax, 0]], 0.0))
                var_in = var_in * Lam[n, g, r, r] / qdof + floor2
                vv += w[n] * ((vis[n] - mu_hat) ** 2 + var_in)
            lo = mu_hat - z95 * math.sqrt(max(vv, 0.0))
            jb = 0
            for k in range(1, ng):
                if grid[k] < a_vis[ax] and mean[k] > mean[jb]:
                    jb = k
            a_band = grid[jb]
        if not observed:
            # past the visited range the curve is the prior's: the data bound the peak
            # only from below
            hi = peak_max
        out[ax, _PK_MU] = mu_hat
        out[ax, _PK_LO] = max(lo, 0.0)
        out[ax, _PK_HI] = max(hi, mu_hat)
        out[ax, _PK_ALPHA] = a_pk
        out[ax, _PK_OBS] = 1.0 if observed else 0.0
        out[ax, _PK_BAND] = a_band
