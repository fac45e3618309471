"""Compiled parts of the whole GP-SSM step (:mod:`roadgrip.estimators.gpssm.block`).

The time update of the information matrices (:func:`roadgrip.estimators.gpssm.linalg.refactor`,
``flush``, and the ``'fast'`` mode's carried posterior moved at a refactorisation),
systematic resampling with the ancestors' bookkeeping
(:func:`roadgrip.estimators.gpssm.state.resample`), and the odd-part features of the
peak search (:func:`roadgrip.estimators.gpssm.posterior.peak_rhs`, ``peak_grid``)
evaluated from the basis tables as the particle pass evaluates its features.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from roadgrip.estimators.gpssm.kernel_ops import _sines
from roadgrip.estimators.gpssm.linalg import _fold, _gather_sorted, _rebuild

# slots of the scalar state (block.SC)
(_K, _T, _STEER, _VX, _NU, _SS, _PS, _C, _SINCE, _NHIST, _PKV, _PAR, _SIG,
 _FLOOR, _BAD, _UNTIL, _RESETS, _HEAD, _TAIL, _FLOOR_ACCEL, _USED_F, _USED_R, _SC_SIZE) = range(23)


@numba.njit(cache=True)
def _refactor(lin, sc, c0):  # pragma: no cover - compiled
    """:func:`roadgrip.estimators.gpssm.linalg.refactor` on the buffers, ``c = c0`` (the
    buffered rows were folded a step ahead, so this folds the last step's row at most and
    inverts)."""
    si = int(sc[_SIG])
    _rebuild(lin.sigma2[si], lin.sanc, lin.hist, lin.hanc, lin.hcoef, int(sc[_NHIST]), sc[_SS], c0,
             lin.sigma2[1 - si], lin.pinv)
    lin.pgain2[int(sc[_PAR])][:] = 0.0
    sc[_SIG] = 1 - si
    sc[_SS] = 1.0
    sc[_PS] = 1.0
    sc[_C] = c0
    sc[_SINCE] = 0.0
    sc[_NHIST] = 0.0
    sc[_PKV] = 0.0
    for n in range(lin.panc.shape[0]):
        lin.panc[n] = n
        lin.sanc[n] = n


@numba.njit(cache=True)
def _flush(lin, sc):  # pragma: no cover - compiled
    """:func:`roadgrip.estimators.gpssm.linalg.flush`: the buffered rank-1 terms into ``Sigma``
    (every ``FOLD_ROWS`` data updates and a step before a refactorisation)."""
    nh = int(sc[_NHIST])
    if nh == 0:
        return
    si = int(sc[_SIG])
    _fold(lin.sigma2[si], lin.sigma2[1 - si], lin.sanc, lin.hist, lin.hanc, lin.hcoef, nh)
    sc[_SIG] = 1 - si
    sc[_NHIST] = 0.0
    for n in range(lin.sanc.shape[0]):
        lin.sanc[n] = n


@numba.njit(cache=True, fastmath=True)
def _refactored_posterior(M, Lam, lam, pinv, p_scale, eps):  # pragma: no cover - compiled
    """``'fast'`` mode after a refactorisation moved the prior weight by ``eps``
    (:func:`roadgrip.estimators.gpssm.stepping._refactored_posterior`): ``M' = M (I - eps
    P_B')``, ``Lambda' = Lambda + eps M M'^T / lam``, in place."""
    N, G, d, m = M.shape
    M0 = np.empty(m)
    row = np.empty((d, m))
    for n in range(N):
        for g in range(G):
            P = pinv[n, g]
            for a in range(d):
                for k in range(m):
                    M0[k] = M[n, g, a, k]
                for j in range(m):
                    acc = 0.0
                    for k in range(m):
                        acc += M0[k] * P[k, j]
                    row[a, j] = M0[j] + acc * (-eps * p_scale)
            for a in range(d):
                for c in range(d):
                    acc = 0.0
                    for k in range(m):
                        acc += M[n, g, a, k] * row[c, k]
                    Lam[n, g, a, c] += (eps / lam) * acc
            for a in range(d):
                for k in range(m):
                    M[n, g, a, k] = row[a, k]


@numba.njit(cache=True)
def _resample(p, lin, wk, sc, rng, carry):  # pragma: no cover - compiled
    """Systematic resampling (:func:`roadgrip.estimators.gpssm.state.systematic`) and the
    particles ``idx`` with equal weights, in place (``state.resample``, ``linalg.take``)."""
    N = p.x.shape[0]
    cum, idx, tmp = wk.cum, wk.idx, wk.tmp
    c = 0.0
    for n in range(N):
        c += np.exp(p.logw[n])
        cum[n] = c
    cum[N - 1] = 1.0
    u = rng.random()
    j = 0
    for n in range(N):
        pos = (u + n) / N
        while cum[j] < pos:
            j += 1
        idx[n] = j
    _gather_sorted(p.x, idx)
    _gather_sorted(p.mu, idx)
    _gather_sorted(p.Psi.reshape(N, -1), idx)
    _gather_sorted(p.Phi.reshape(N, -1), idx)
    if carry:
        _gather_sorted(wk.M.reshape(N, -1), idx)
        _gather_sorted(wk.Lam.reshape(N, -1), idx)
    for h in range(int(sc[_NHIST])):
        for n in range(N):
            tmp[n] = lin.hanc[h, idx[n]]
        lin.hanc[h, :] = tmp
    for n in range(N):
        tmp[n] = lin.panc[idx[n]]
    lin.panc[:] = tmp
    for n in range(N):
        tmp[n] = lin.sanc[idx[n]]
    lin.sanc[:] = tmp
    p.logw[:] = -math.log(N)


@numba.njit(cache=True)
def _axle_feature(basis, ax, a, r, ef, er, out):  # pragma: no cover - compiled
    """Features of axle ``ax``'s curve at slip angle ``a`` [rad] (posterior.axle_features):
    the tensor basis along the manifold ``alpha_r = r alpha_f``, each slip held to
    ``±a_lim``."""
    if basis.tensor:
        g = 0
        if ax == 0:
            af, ar = a, r * a
        else:
            af, ar = a / r, a
    else:
        g = ax
        af, ar = a, a
    lim = basis.a_lim
    af = min(max(af, -lim), lim)
    ar = min(max(ar, -lim), lim)
    _sines(af, basis.L, basis.nf, ef)
    _sines(ar, basis.L, basis.nf, er)
    for k in range(out.shape[0]):
        v = basis.wgt[g, k]
        if basis.fidx[g, k] >= 0:
            v *= ef[basis.fidx[g, k]]
        if basis.ridx[g, k] >= 0:
            v *= er[basis.ridx[g, k]]
        out[k] = v
    return g


@numba.njit(cache=True)
def _odd_feature(basis, ax, a, r, wk):  # pragma: no cover - compiled
    """``0.5 (f(a) - f(-a))`` of axle ``ax`` into ``wk.fp``; returns its group."""
    g = _axle_feature(basis, ax, a, r, wk.ef, wk.er, wk.fp)
    _axle_feature(basis, ax, -a, r, wk.ef, wk.er, wk.fm)
    for k in range(wk.fp.shape[0]):
        wk.fp[k] = 0.5 * (wk.fp[k] - wk.fm[k])
    return g


@numba.njit(cache=True)
def _peak_rhs(basis, r, peak_alpha, wk):  # pragma: no cover - compiled
    """``wk.fpk`` (G, m, np): odd-part features at the peak slip angles
    (posterior.peak_rhs; columns of posterior.peak_cols)."""
    m = wk.fp.shape[0]
    for row in range(2):
        for ax in range(2):
            g = _odd_feature(basis, ax, peak_alpha[row, ax], r, wk)
            col = 2 * row + ax if basis.tensor else row
            for k in range(m):
                wk.fpk[g, k, col] = wk.fp[k]


@numba.njit(cache=True)
def _grid_features(basis, r, grid, wk):  # pragma: no cover - compiled
    """``wk.feats`` (2, ng, m): odd-part features of each axle's curve on the peak grid
    (posterior.peak_grid)."""
    m = wk.fp.shape[0]
    for ax in range(2):
        for j in range(grid.shape[0]):
            _odd_feature(basis, ax, grid[j], r, wk)
            for k in range(m):
                wk.feats[ax, j, k] = wk.fp[k]
