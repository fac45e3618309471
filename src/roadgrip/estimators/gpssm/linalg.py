r"""Per-particle linear algebra of the GP-SSM filter: solves with ``H = Sigma + I``.

Every particle (and basis group) carries the information matrix ``H = Sigma + I`` of its
MNIW posterior (whitened features, so the prior precision is ``I``; paper 000, eq. 25).
Each step the filter needs ``H^{-1} R`` for a few right-hand sides ``R`` (the new feature
vector, ``Psi^T`` and the features at the peak), then adds ``phi phi^T`` to ``Sigma`` and,
at the next step, scales ``Sigma`` by the forgetting factor ``lam`` (eq. 29c). Because the
prior ``I`` is not forgotten, ``lam Sigma + I`` is not a rank-1 change of the previous
``H``: a straightforward implementation inverts ``H`` for every particle at every step,
``O(N m³)``.

Three interchangeable backends (``GPSSMConfig.linalg``):

``'direct'``
    Stores ``Sigma`` and calls ``numpy.linalg.solve`` on the stack ``(N, G, m, m)`` every
    step. The reference, and the baseline of the benchmark.
``'exact'``
    Deferred forgetting of the prior. With ``c = c0 lam^j`` (``j`` steps since the last
    refactorisation) the stored matrix is ``B = Sigma + c I``: forgetting scales ``B`` by
    ``lam`` (a scalar on its inverse, ``O(1)``) and the data update is rank 1
    (Sherman-Morrison on ``P_B = B^{-1}``, ``O(m²)``). The exact ``H = B + (1 - c) I`` is
    solved by the Neumann series ``H^{-1} = sum_n (-(1 - c))^n P_B^{n+1}``, which converges
    geometrically because ``P_B <= I / c`` and ``|1 - c| << c``; terms are added until they
    fall below ``EXACT_TOL = 1e-12`` of the sum (the level of the rounding error that
    ``P_B`` itself carries after a Cholesky inverse and rank-1 updates). Every ``refactor_every = J`` steps ``P_B`` is
    recomputed from ``Sigma`` (Cholesky of ``Sigma + c0 I``, ``c0 = lam^{-J/2}`` so that
    ``1 - c`` runs from about ``-J (1 - lam) / 2`` to ``+J (1 - lam) / 2``), which also
    removes rounding drift of the rank-1 updates. ``O(N m²)`` per step, exact to
    rounding.

    Nothing of size ``m²`` is copied or written twice per step:

    * ``Sigma`` is not updated per step: the feature vectors are kept in a short history
      (one row per data update since the last fold, with its scale) and folded in, with
      one matrix product per particle, every ``FOLD_ROWS`` data updates and at the step
      before a refactorisation (:func:`reserve`, :func:`forget`), so that the
      refactorisation's own step only inverts (its time is the latency's worst case);
    * resampling copies no matrix: each particle keeps the index of its ancestor's
      ``P_B`` (``panc``), ``Sigma`` slot (``sanc``) and history rows (``hanc``);
    * the Sherman-Morrison update is deferred: a particle's own ``P_B`` is written once
      per step as its ancestor's ``P_B`` minus the ancestor's pending rank-1 term
      (``pend``, ``pgain``), by the compiled step (:mod:`roadgrip.estimators.gpssm.kernel`):
      in place in the ancestor's slot for the first particle that reads it, into a slot
      that nobody reads for the other copies of a resampled particle
      (:func:`roadgrip.estimators.gpssm.kernel_ops.slot_plan`), so one buffer serves and a
      step without resampling moves no matrix between buffers.

    :func:`settle` writes the pending terms out (for the NumPy path and for checks).
``'fast'``
    As ``'exact'``, in double precision too, with one approximation: ``H`` is taken as
    ``B = Sigma + c I``, i.e. the prior precision is ``c`` instead of 1, with ``c``
    between ``lam^{J/2}`` and ``lam^{-J/2}`` (within 0.8 % of 1 for the defaults ``lam =
    0.9998``, ``J = 80``): the forgotten prior is put back at each refactorisation instead
    of every step. Then ``B`` only scales under forgetting and changes by rank 1 with
    data, so a solve is one product with ``P_B``; the posterior mean ``M = Psi P_B`` is
    invariant under forgetting and ``Lambda = Lambda0 + Phi - M Psi^T`` only forgets, so
    the compiled step carries both by the recursive least-squares update (``M <- M + (zeta
    - M phi) (P_B phi)^T / (1 + s)``, ``Lambda <- Lambda + e e^T / (1 + s)``) and moves
    them at each refactorisation, instead of solving with ``Psi`` and forming ``Lambda``
    by cancellation. About ``2 m²`` work per particle and step (rank-1 update and one
    product) against ``(1 + d)·(terms + 1)·m²`` of ``'exact'``.

All arrays are indexed ``(N, G, ...)``: particles, basis groups. The state is consumed by
each call (buffers are updated in place and returned); :func:`take` records the
ancestors on resampling ('direct' copies rows).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.gpssm.kernel_ops import neumann_solve

__all__ = ["LINALG_MODES", "LinAlgState", "flush", "forget", "init", "inverse", "refactor", "reserve",
           "settle", "solve", "take", "update"]

LINALG_MODES = ("exact", "fast", "direct")

EXACT_TOL = 1e-12
"""Relative size of the last Neumann term of the ``'exact'`` mode."""

FOLD_ROWS = 20
"""Buffered rank-1 terms folded into ``Sigma`` at a time (:func:`reserve`): the fold of a
refactorisation period is spread over it, a quarter of the default period's rows at a
time, instead of all at the refactorisation."""


class LinAlgState(NamedTuple):
    """Per-particle information matrices (``'exact'``, ``'fast'``; see the module docstring).

    Attributes
    ----------
    mode : str
        ``'exact'``, ``'fast'`` or ``'direct'``.
    sigma : ndarray, shape (N, G, m, m)
        Slots of ``Sigma / sigma_scale`` without the buffered terms (``Sigma`` itself for
        ``'direct'``); particle ``i`` uses slot ``sanc[i]``.
    pinv : ndarray, shape (N, G, m, m)
        Slots of ``P_B / p_scale`` with ``P_B = (Sigma + c I)^{-1}`` before the pending
        term; particle ``i`` uses slot ``panc[i]``.
    spare, sigma_spare : ndarray
        Second buffers of ``pinv`` (for :func:`settle`) and ``sigma`` (refactorisation).
    pend : ndarray, shape (N, G, m)
        Pending Sherman-Morrison vector ``P_B phi`` of each ``pinv`` slot (by slot).
    pgain : ndarray, shape (N, G)
        Its gain: the slot's matrix is ``pinv - pgain pend pend^T`` (0: nothing pending).
    panc, sanc : ndarray of int, shape (N,)
        ``pinv`` and ``sigma`` slot of each particle.
    sigma_scale, p_scale : float
        Global scalar factors (forgetting is applied to them, not to the arrays).
    c : float
        Prior weight currently inside ``P_B``.
    since_refactor : int
        Steps since the last refactorisation.
    hist : ndarray, shape (J, N, G, m)
        Feature vectors of the data updates not yet folded into ``sigma``.
    hanc : ndarray of int, shape (J, N)
        Row of ``hist[j]`` that belongs to each particle.
    pkw : ndarray, shape (N, G, np, m)
        ``P_B f / p_scale`` for the features ``pkf`` (G, m, np) of the peak slip angles,
        per ``pinv`` slot (kept by the compiled step; ``pkf`` None when stale).
    hcoef : ndarray, shape (J,)
        Their scales: ``Sigma_i = sigma_scale (sigma[sanc_i] + sum_j hcoef_j h h^T)`` with
        ``h = hist[j, hanc[j, i]]``.
    nhist : int
        Rows of ``hist`` in use.
    """

    mode: str
    sigma: NDArray
    pinv: NDArray
    sigma_scale: float
    p_scale: float
    c: float
    since_refactor: int
    hist: NDArray
    hcoef: NDArray
    nhist: int
    spare: NDArray
    sigma_spare: NDArray
    pend: NDArray
    pgain: NDArray
    panc: NDArray
    sanc: NDArray
    hanc: NDArray
    pkw: NDArray | None = None
    pkf: NDArray | None = None


def init(mode: str, n: int, groups: int, m: int, history: int = 64) -> LinAlgState:
    """Prior state: ``Sigma = 0``, ``H = I``; ``history`` rank-1 terms are buffered."""
    if mode not in LINALG_MODES:
        raise ValueError(f"unknown linear-algebra mode {mode!r}; expected one of {LINALG_MODES}")
    sigma = np.zeros((n, groups, m, m))
    ar = np.arange(n)
    if mode == "direct":
        e = np.zeros(0)
        return LinAlgState(mode, sigma, e, 1.0, 1.0, 1.0, 0, np.zeros((0, n, groups, m)), e, 0,
                           e, e, np.zeros((n, groups, 0)), np.zeros((n, groups)), ar, ar,
                           np.zeros((0, n), np.int64))
    pinv = np.broadcast_to(np.eye(m), (n, groups, m, m)).copy()
    J = max(int(history), 1)
    return LinAlgState(
        mode, sigma, pinv, 1.0, 1.0, 1.0, 0, np.zeros((J, n, groups, m)), np.zeros(J), 0,
        np.empty_like(pinv), np.empty_like(sigma), np.zeros((n, groups, m)), np.zeros((n, groups)),
        ar.copy(), ar.copy(), np.zeros((J, n), np.int64),
    )


def flush(st: LinAlgState) -> LinAlgState:
    """Fold the buffered rank-1 terms into ``sigma`` (one slot per particle)."""
    if st.mode == "direct" or st.nhist == 0:
        return st
    N = st.hist.shape[1]
    _fold(st.sigma, st.sigma_spare, st.sanc, st.hist, st.hanc, st.hcoef, st.nhist)
    return st._replace(sigma=st.sigma_spare, sigma_spare=st.sigma, sanc=np.arange(N), nhist=0)


def reserve(st: LinAlgState) -> LinAlgState:
    """Make room for one more buffered rank-1 term: fold the buffer into ``Sigma`` when it
    holds ``FOLD_ROWS`` terms (or is full)."""
    if st.mode != "direct" and st.nhist >= min(st.hist.shape[0], FOLD_ROWS):
        return flush(st)
    return st


@numba.njit(cache=True)
def _folded(sigma, sanc, hist, hanc, hcoef, n, i, g, H, S):  # pragma: no cover - compiled
    """``S = sigma[sanc[i], g] + sum_j hcoef_j h h^T`` in double precision (``h = hist[j,
    hanc[j, i], g]``; the sum as one matrix product, ``H`` (n, m) scratch; one row, as
    after the fold a step before a refactorisation, without the call of the product)."""
    m = S.shape[0]
    for j in range(n):
        c = np.sqrt(hcoef[j])
        row = hist[j, hanc[j, i], g]
        for k in range(m):
            H[j, k] = c * row[k]
    if n > 1:
        np.dot(H[:n].T, H[:n], S)
    elif n == 1:
        for a in range(m):
            for b in range(m):
                S[a, b] = H[0, a] * H[0, b]
    else:
        S[:] = 0.0
    slot = sigma[sanc[i], g]
    for a in range(m):
        for b in range(m):
            S[a, b] += slot[a, b]


@numba.njit(cache=True)
def _fold(sigma, out, sanc, hist, hanc, hcoef, n):  # pragma: no cover - compiled
    """``out[i] = sigma[sanc[i]] + sum_j hcoef_j h h^T``, ``h = hist[j, hanc[j, i]]``."""
    N, G, m, _ = out.shape
    H = np.zeros((max(n, 1), m))
    S = np.empty((m, m))
    for i in range(N):
        for g in range(G):
            _folded(sigma, sanc, hist, hanc, hcoef, n, i, g, H, S)
            for a in range(m):
                for b in range(m):
                    out[i, g, a, b] = S[a, b]


def forget(st: LinAlgState, lam: float, refactor_every: int) -> LinAlgState:
    """Time update ``Sigma <- lam Sigma`` (eq. 29c)."""
    if st.mode == "direct":
        sig = st.sigma
        sig *= lam
        return st
    st = st._replace(
        sigma_scale=st.sigma_scale * lam, p_scale=st.p_scale / lam, c=st.c * lam,
        since_refactor=st.since_refactor + 1,
    )
    if st.since_refactor >= refactor_every:
        st = refactor(st, lam ** (-0.5 * refactor_every))
    elif st.since_refactor == refactor_every - 1:
        st = flush(st)  # the refactorisation's fold a step ahead: its step only inverts
    return st


def refactor(st: LinAlgState, c0: float = 1.0) -> LinAlgState:
    """Recompute ``P_B = (Sigma + c0 I)^{-1}`` from ``Sigma`` (slot plus buffered terms),
    ``c = c0``: a Cholesky inverse per particle inside a compiled loop. Nothing is pending
    afterwards and every particle owns its slots.

    :func:`forget` passes ``c0 = lam^{-J/2}`` (``J`` the refactorisation period): over the
    period ``c`` falls from ``lam^{-J/2}`` to ``lam^{J/2}``, so the Neumann parameter
    ``1 - c`` is centred on zero and half as large at worst as when starting from 1.
    """
    if st.mode == "direct":
        return st
    if not 0.5 < c0 < 2.0:
        raise ValueError(f"prior weight at refactorisation must be near 1, got {c0!r}")
    N = st.hist.shape[1]
    _rebuild(st.sigma, st.sanc, st.hist, st.hanc, st.hcoef, st.nhist, st.sigma_scale, c0,
             st.sigma_spare, st.pinv)
    st.pgain[:] = 0.0
    return st._replace(sigma=st.sigma_spare, sigma_spare=st.sigma, sigma_scale=1.0, p_scale=1.0,
                       c=float(c0), since_refactor=0, panc=np.arange(N), sanc=np.arange(N), nhist=0,
                       pkf=None)


_LANES = 16
"""Matrices inverted side by side by :func:`_spd_inverse` (the innermost axis of its
scratch, a multiple of the SIMD width)."""


@numba.njit(cache=True)
def _rebuild(sigma, sanc, hist, hanc, hcoef, n, sigma_scale, c0, out, pinv):  # pragma: no cover
    """``out[i] = sigma_scale sym(sigma[sanc[i]] + sum_j hcoef_j h h^T)`` (``h = hist[j,
    hanc[j, i]]``, :func:`_folded`) and ``pinv[i] = (out[i] + c0 I)^{-1}``
    (:func:`_spd_inverse`, ``_LANES`` matrices at a time), with scratch allocated once per
    call."""
    N, G, m, _ = out.shape
    H = np.zeros((max(n, 1), m))
    S = np.empty((m, m))
    T = np.empty((m, m, _LANES))
    W = np.empty((m, m, _LANES))
    NG = N * G
    for b0 in range(0, NG, _LANES):
        nl = min(_LANES, NG - b0)
        for ln in range(nl):
            i, g = divmod(b0 + ln, G)
            _folded(sigma, sanc, hist, hanc, hcoef, n, i, g, H, S)
            Sig = out[i, g]
            for a in range(m):
                for b in range(a + 1):
                    v = 0.5 * sigma_scale * (S[a, b] + S[b, a])
                    Sig[a, b] = v
                    Sig[b, a] = v
                    T[a, b, ln] = v
                T[a, a, ln] += c0
        for ln in range(nl, _LANES):  # unused lanes: the identity
            for a in range(m):
                for b in range(a + 1):
                    T[a, b, ln] = 1.0 if a == b else 0.0
        _spd_inverse(T, W)
        for ln in range(nl):
            i, g = divmod(b0 + ln, G)
            P = pinv[i, g]
            for a in range(m):
                for b in range(a + 1):
                    v = T[a, b, ln]
                    P[a, b] = v
                    P[b, a] = v


@numba.njit(cache=True, fastmath=True)
def _spd_inverse(T, W):  # pragma: no cover - compiled
    """Inverses of ``L`` SPD matrices side by side, in place: ``T`` (m, m, L) holds their
    lower triangles (``T[:, :, l]`` one matrix) and gets their inverses' lower triangles;
    ``W`` (m, m, L) scratch.

    The Cholesky factor ``C`` (in ``T``), ``W = C^{-1}`` by forward substitution and the
    inverse ``W^T W`` as a sum of outer products of the rows of ``W``: about ``m³ / 6``
    multiply-adds each, every one over the ``L`` matrices at once (the innermost loop,
    which the compiler vectorises: a 20 x 20 matrix is too small for the vector units
    alone).

    Raises ``ValueError`` when a pivot is not positive (a matrix not positive definite,
    or not finite).
    """
    m, _, L = T.shape
    bad = False
    for i in range(m):
        for j in range(i + 1):
            for k in range(j):
                for ln in range(L):
                    T[i, j, ln] -= T[i, k, ln] * T[j, k, ln]
            if j < i:
                for ln in range(L):
                    T[i, j, ln] *= W[j, j, ln]
            else:
                for ln in range(L):
                    s = T[i, i, ln]
                    bad |= not s > 0.0
                    r = math.sqrt(max(s, 1e-300))
                    T[i, i, ln] = r
                    W[i, i, ln] = 1.0 / r
    if bad:
        raise ValueError("information matrix not positive definite at the refactorisation")
    for i in range(m):
        for j in range(i):
            for ln in range(L):
                W[i, j, ln] = 0.0
        for k in range(i):
            for j in range(k + 1):
                for ln in range(L):
                    W[i, j, ln] -= T[i, k, ln] * W[k, j, ln]
        for j in range(i):
            for ln in range(L):
                W[i, j, ln] *= W[i, i, ln]
    for a in range(m):
        for b in range(a + 1):
            for ln in range(L):
                T[a, b, ln] = 0.0
    for k in range(m):
        for a in range(k + 1):
            for b in range(a + 1):
                for ln in range(L):
                    T[a, b, ln] += W[k, a, ln] * W[k, b, ln]


def settle(st: LinAlgState) -> LinAlgState:
    """Write the ancestors' matrices and the pending rank-1 terms out, in place: afterwards
    ``pinv[i]`` is particle ``i``'s own ``P_B / p_scale`` (``panc`` the identity), and the
    carried ``P_B f`` of the peak features (``pkw``) likewise."""
    if st.mode == "direct" or _settled_pinv(st) is st.pinv:
        return st
    N = st.pinv.shape[0]
    if st.pkw is not None and st.pkf is not None:
        pe = st.pend[st.panc]                                              # (N, G, m)
        c = np.einsum("ngm,gmp->ngp", pe, st.pkf) * st.pgain[st.panc][..., None]
        st.pkw[...] = st.pkw[st.panc] - c[..., None] * pe[:, :, None, :]
    st.pinv[...] = st.spare  # where _settled_pinv wrote the settled matrices
    st.panc[:] = np.arange(N)
    st.pgain[:] = 0.0
    return st


def _settled_pinv(st: LinAlgState) -> NDArray:
    """Every particle's own ``P_B / p_scale`` without changing ``st`` (written to the spare
    buffer, which is free between steps, when anything is pending)."""
    N = st.pinv.shape[0]
    if np.array_equal(st.panc, np.arange(N)) and not st.pgain.any():
        return st.pinv
    _settle(st.pinv, st.spare, st.panc, st.pend, st.pgain)
    return st.spare


@numba.njit(cache=True, fastmath=True)
def _settle(pinv, out, panc, pend, pgain):  # pragma: no cover - compiled
    N, G, m, _ = out.shape
    for i in range(N):
        k = panc[i]
        for g in range(G):
            gk = pgain[k, g]
            for a in range(m):
                ua = pend[k, g, a] * gk
                for b in range(m):
                    out[i, g, a, b] = pinv[k, g, a, b] - ua * pend[k, g, b]


def inverse(st: LinAlgState) -> NDArray:
    """``P_B`` of every particle, shape (N, G, m, m) (``'exact'``, ``'fast'``; for checks)."""
    return settle(st).pinv * st.p_scale


def solve(st: LinAlgState, R: NDArray, n_exact: int | None = None) -> tuple[NDArray, NDArray | None]:
    """``H^{-1} R`` for ``R`` of shape (N, G, m, nr), ``H = Sigma + I`` (``'fast'``:
    ``B^{-1} R``, ``B = Sigma + c I``).

    With ``n_exact`` only the first ``n_exact`` columns are solved to rounding precision
    by ``'exact'``; the rest to ``O((1 - c)²)`` relative (used for the band of the peak).

    Returns
    -------
    X : ndarray, shape (N, G, m, nr)
    pb_phi : ndarray, shape (N, G, m) or None
        ``P_B R[..., 0]``, needed by :func:`update` (``None`` for ``'direct'``).
    """
    N, G, m, nr = R.shape
    if st.mode == "direct":
        H = st.sigma + np.eye(m)
        return np.linalg.solve(H, R), None
    pinv = _settled_pinv(st)
    delta = 1.0 - st.c
    if st.mode == "fast":
        tol, max_terms = 1.0, 0  # H taken as B = Sigma + c I
    else:
        tol, max_terms = EXACT_TOL, 60
    n_exact = nr if n_exact is None else n_exact
    Rt = np.ascontiguousarray(np.swapaxes(R, -1, -2).reshape(N * G, nr, m))
    Xt, pb = _neumann(pinv.reshape(N * G, m, m), st.p_scale, delta, Rt, n_exact, tol, max_terms)
    return np.swapaxes(Xt.reshape(N, G, nr, m), -1, -2), pb.reshape(N, G, m)


@numba.njit(cache=True, fastmath=True)
def _neumann(pinv, p_scale, delta, Rt, n_exact, tol, max_terms):  # pragma: no cover - compiled
    """Per batch element: X = sum_n (-delta)^n P_B^{n+1} R, with ``Rt = R^T`` (B, nr, m),
    by the compiled step's :func:`roadgrip.estimators.gpssm.kernel_ops.neumann_solve` (the first
    ``n_exact`` right-hand sides to ``tol``, the others one correction term). Also returns
    ``P_B R[:, 0]``."""
    B, nr, m = Rt.shape
    Xt = np.zeros((B, nr, m))
    PB0 = np.zeros((B, m))
    cur = np.empty((nr, m))
    nxt = np.empty((nr, m))
    for b in range(B):
        neumann_solve(pinv[b], p_scale, delta, Rt[b], nr, n_exact, tol, max_terms, Xt[b], PB0[b], cur, nxt)
    return Xt, PB0


@numba.njit(cache=True, fastmath=True)
def _rank1(pinv, phi, pb_phi, p_scale):  # pragma: no cover - compiled
    """P_B <- P_B - (P_B phi)(P_B phi)^T / (1 + phi^T P_B phi) (Sherman-Morrison)."""
    B, m = phi.shape
    for b in range(B):
        s = 0.0
        for i in range(m):
            s += phi[b, i] * pb_phi[b, i]
        g = 1.0 / ((1.0 + s) * p_scale)
        P = pinv[b]
        pb = pb_phi[b]
        for i in range(m):
            ui = pb[i] * g
            Pr = P[i]
            for j in range(m):
                Pr[j] -= ui * pb[j]


def update(st: LinAlgState, phi: NDArray, pb_phi: NDArray | None) -> LinAlgState:
    """Data update ``Sigma <- Sigma + phi phi^T`` (eq. 28b); ``phi`` (N, G, m)."""
    N, G, m = phi.shape
    if st.mode == "direct":
        sig = st.sigma
        sig += phi[..., :, None] * phi[..., None, :]
        return st
    st = reserve(settle(st))
    st.hist[st.nhist] = phi
    st.hanc[st.nhist] = np.arange(N)
    st.hcoef[st.nhist] = 1.0 / st.sigma_scale
    _rank1(
        st.pinv.reshape(N * G, m, m),
        np.ascontiguousarray(phi.reshape(N * G, m)), pb_phi.reshape(N * G, m), st.p_scale,
    )
    return st._replace(nhist=st.nhist + 1)


def take(st: LinAlgState, idx: NDArray) -> LinAlgState:
    """Particles ``idx`` (resampling): each keeps its ancestor's matrices.

    ``'direct'`` copies rows (in place for sorted ``idx``); the other modes only compose
    the ancestor indices.
    """
    if st.mode == "direct":
        return st._replace(sigma=take_rows(st.sigma, idx))
    idx = np.asarray(idx, dtype=np.int64)
    hanc = st.hanc
    hanc[:st.nhist] = hanc[:st.nhist, idx]
    return st._replace(panc=st.panc[idx], sanc=st.sanc[idx])


def take_rows(a: NDArray, idx: NDArray) -> NDArray:
    """``a[idx]`` along the first axis; in place (``a`` is overwritten and returned) when
    ``idx`` is non-decreasing, as systematic resampling produces, else a new array.

    In place, only the rows that change are copied, without a temporary of the size of ``a``.
    """
    idx = np.asarray(idx, dtype=np.int64)
    if len(idx) != a.shape[0] or not a.flags.c_contiguous or np.any(np.diff(idx) < 0):
        return a[idx]
    _gather_sorted(a.reshape(a.shape[0], -1), idx)
    return a


@numba.njit(cache=True)
def _gather_sorted(a, idx):  # pragma: no cover - compiled
    """In place ``a <- a[idx]`` for non-decreasing ``idx``.

    Rows with ``idx[i] >= i`` are filled in increasing ``i`` (they read rows not yet
    written), then rows with ``idx[i] < i`` in decreasing ``i`` (a source row ``q =
    idx[i] < i`` was either untouched or had ``idx[q] = q``, by monotonicity).
    """
    n = a.shape[0]
    for i in range(n):
        j = idx[i]
        if j > i:
            a[i, :] = a[j, :]
    for i in range(n - 1, -1, -1):
        j = idx[i]
        if j < i:
            a[i, :] = a[j, :]


def copy(st: LinAlgState) -> LinAlgState:
    """A deep copy. ``sigma`` and ``sigma_spare`` are copied into the two halves of one
    (2, ...) buffer, and ``pend``, ``pgain``, ``pkw`` into the first half of one each,
    the layout the compiled step (:mod:`roadgrip.estimators.gpssm.compiled`) works in."""
    if st.sigma_spare.shape == st.sigma.shape:
        sigma, sigma_spare = _in_pair(st.sigma, st.sigma_spare)
    else:  # 'direct' keeps no spare
        sigma, sigma_spare = st.sigma.copy(), st.sigma_spare.copy()
    pend, pgain = _in_pair(st.pend)[0], _in_pair(st.pgain)[0]
    return st._replace(sigma=sigma, pinv=st.pinv.copy(), hist=st.hist.copy(),
                       hcoef=st.hcoef.copy(), spare=st.spare.copy(), sigma_spare=sigma_spare,
                       pend=pend, pgain=pgain, panc=st.panc.copy(),
                       sanc=st.sanc.copy(), hanc=st.hanc.copy(),
                       pkw=None if st.pkw is None else _in_pair(st.pkw)[0],
                       pkf=None if st.pkf is None else st.pkf.copy())


def _in_pair(a: NDArray, b: NDArray | None = None) -> tuple[NDArray, NDArray]:
    """Copies of ``a`` (and ``b``, else nothing) as the halves of one (2, ...) buffer."""
    pair = np.empty((2, *a.shape), a.dtype)
    pair[0] = a
    if b is not None:
        pair[1] = b
    return pair[0], pair[1]


def information(st: LinAlgState) -> NDArray:
    """``H = Sigma + I`` of every particle in double precision, shape (N, G, m, m) (checks)."""
    m = st.sigma.shape[-1]
    S = st.sigma[st.sanc].astype(np.float64)
    if st.mode != "direct" and st.nhist:
        N = len(st.sanc)
        h = np.stack([st.hist[j, st.hanc[j]] for j in range(st.nhist)], axis=2).astype(np.float64)
        S = S + np.einsum("ngjm,j,ngjk->ngmk", h, st.hcoef[:st.nhist], h)
        assert S.shape[0] == N
    return S * st.sigma_scale + np.eye(m)
