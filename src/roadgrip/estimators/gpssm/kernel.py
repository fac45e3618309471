r"""Compiled step of the GP-SSM filter (:mod:`roadgrip.estimators.gpssm`).

One call of :func:`particle_pass` does, for every particle and basis group, everything of
Algorithm 1 that is per particle: the propagation of eq. 7 with the forgetting of eq. 29,
the slip angles and features, the solves with ``H = Sigma + I`` (the deferred-prior
Neumann series of :mod:`roadgrip.estimators.gpssm_linalg`, whose ``P_B`` stays in cache
for the whole particle), the predictive of eq. 32 and the friction sample, the weight
factor of eq. 21-22, the data update of eq. 28 (``P_B`` by Sherman-Morrison, the feature
vector into the history of ``Sigma``, ``Psi``, ``Phi``) and the posterior quantities that
the estimates need. It then normalises the weights and forms the weighted estimates
(Algorithm 1, lines 6-7 and 11-12). :func:`peak_summary` computes the peak friction per
axle from the particles' posterior mean curves.

Random numbers are drawn by the caller with NumPy (same order as the reference
implementation in :func:`roadgrip.estimators.gpssm.step`) and passed in, so a seed gives
the same particles whichever implementation runs.

The NumPy reference path (``GPSSMConfig.linalg = 'direct'``) computes the same quantities
with array operations over the particles; the tests hold the two to each other.

Layouts
-------
``x`` (N, 2) ``[vy, yaw_rate]``; ``mu`` (N, 2) front/rear; ``pinv`` (N·G, m, m);
``hist`` (N·G, J, m); ``Psi`` (N, G, d, m); ``Phi`` (N, G, d, d); basis tables ``fidx``,
``ridx`` (G, m) index the 1-D eigenfunctions of the front and rear slip angle (-1: not a
factor), ``wgt`` (G, m) the square roots of the spectral density. ``VEH`` and ``OUT``
below name the slots of the packed scalar arrays.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["EST", "VEH", "basis_tables", "neumann_solve", "particle_pass", "peak_summary", "slot_plan"]


class VEH:
    """Slots of the packed vehicle array."""

    MASS, FZF, FZR, LF, LR, IZZ, V_EPS, SIZE = range(8)


class EST:
    """Slots of the packed estimate array returned by :func:`particle_pass`."""

    ESS, VY, YAW_RATE, VY_STD, YAW_RATE_STD, ALPHA_F, ALPHA_R, MU_NOW_F, MU_NOW_R, SIZE = range(10)


# the same slots as module constants (compiled code reads globals, not class attributes)
_MASS, _FZF, _FZR, _LF, _LR, _IZZ, _V_EPS = range(7)
_ESS, _VY, _YR, _VY_STD, _YR_STD, _AF, _AR, _MU_F, _MU_R, _EST_SIZE = range(10)


def basis_tables(basis) -> tuple[bool, int, np.ndarray, np.ndarray, np.ndarray]:
    """``(tensor, nf, fidx, ridx, wgt)`` of a basis (module docstring)."""
    if basis.kind == "tensor":
        n = basis.n
        j1, j2 = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        keep = basis._keep
        fidx = j1.ravel()[keep][None].astype(np.int64)
        ridx = j2.ravel()[keep][None].astype(np.int64)
        wgt = np.asarray(basis.sqrt_s, float)[None]
        return True, n, fidx, ridx, np.ascontiguousarray(wgt)
    j = np.asarray(basis._j, np.int64) - 1
    nf = int(j.max()) + 1
    none = np.full_like(j, -1)
    fidx = np.stack([j, none])
    ridx = np.stack([none, j])
    w = np.asarray(basis.sqrt_s, float)
    return False, nf, fidx, ridx, np.ascontiguousarray(np.stack([w, w]))


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
def particle_pass(
    x, mu, logw, pinv, panc, pdst, order, pend, pgain, pend_new, pgain_new, hist, hslot, Psi, Phi,
    propagate, dt, steer_prev, vx_prev, steer, vx, ay, yaw_rate, has_vy, vy_meas, learn,
    veh, mf, lam, nu, Lambda0, sigma_ay, sigma_r, vy_max,
    p_scale, delta, tol, max_terms,
    tensor, nf, fidx, ridx, wgt, L, a_lim, fpk, wold, wnew, fresh,
    gdraw, zdraw, conditional, carry,
    out_alpha, out_M, out_Lam, out_vpk, out_munow, est,
):  # pragma: no cover - compiled
    """All per-particle work of one step, in place (module docstring).

    Parameters (shapes; ``d`` outputs, ``np`` peak columns)
    ----------------------------------------------------------
    x, mu : (N, 2) in/out (state; friction sample, front/rear)
    logw : (N,) in/out (normalised log weights)
    pinv : (N·G, m, m) slots of ``P_B / p_scale``, particle ``n`` reads slot ``panc[n]``
        minus that slot's pending term ``pgain pend pend^T`` (``pend`` (N, G, m), ``pgain``
        (N, G), by slot) and writes the result to slot ``pdst[n]``, in place when ``pdst[n]
        == panc[n]``; particles are processed in the order ``order`` (:func:`slot_plan`:
        the copies before the slot they read is overwritten). Its own update of this step
        is left pending in ``pend_new``, ``pgain_new``, by slot ``pdst[n]``
        (:mod:`roadgrip.estimators.gpssm_linalg`)
    hist : (J, N, G, m), row ``hslot`` written when ``learn``
    Psi : (N, G, d, m), Phi : (N, G, d, d) in/out (forgotten when ``propagate``, then
        updated when ``learn``)
    veh : (VEH.SIZE,);  mf : (4,) prior Magic Formula ``B, C, D, E``
    L, a_lim : basis half-width and the slip angle past which the friction model is held
        flat [rad] (``GPSSMConfig.alpha_limit``)
    has_vy, vy_meas : a measured lateral velocity [m/s] that replaces every particle's
    vy_max : float, negative for no bound
    gdraw : (N, G) chi-square draws with ``nu - d + 1`` degrees of freedom
    zdraw : (N, 1, 2) standard normals (conditional proposal) or (N, G, d) (bootstrap)
    carry : ``'fast'`` mode: ``H`` is taken as ``B`` (pass ``delta = 0``, ``max_terms =
        0``); ``out_M`` and ``out_Lam`` hold each particle's posterior ``M = Psi P_B`` and
        ``Lambda`` of the last step on entry, carried and updated in place, so only
        ``phi`` is solved for and ``Lambda`` is not formed by cancellation
        (:mod:`roadgrip.estimators.gpssm_linalg`)
    fpk : (G, m, np) odd-part features ``f`` at the peak slip angles
    wold, wnew : (N, G, np, m) ``P_B f / p_scale`` per ``pinv`` slot, before (read through
        ``panc`` and corrected by the pending term, like ``pinv``) and after this step
        (written through ``pdst``);
        ``fresh`` (G, np) marks the columns recomputed with a product (their ``f`` moved,
        or ``P_B`` was refactorised).
        The peak band needs ``f^T H^{-1} f = f^T P_B f - (1 - c) |P_B f|² + O((1 - c)²)``
        (eq. 25), so ``f`` never enters the Neumann series.
    out_alpha : (N, 2) slip angles;  out_M : (N, G, d, m) posterior mean ``M`` (eq. 28a);
    out_Lam : (N, G, d, d) posterior ``Lambda``;  out_vpk : (N, G, np) ``f^T H^{-1} f``
    of the peak features after the update;  out_munow : (N, 2) ``mu_prior + M phi``;
    est : (EST.SIZE,) weighted estimates
    """
    N = x.shape[0]
    G = Psi.shape[1]
    d = Psi.shape[2]
    m = Psi.shape[3]
    npk = fpk.shape[2]
    nr = 1 if carry else 1 + d
    R = np.zeros((nr, m))
    X = np.zeros((nr, m))
    cur = np.zeros((nr, m))
    nxt = np.zeros((nr, m))
    pbv = np.zeros(m)
    phi = np.zeros((G, m))
    U = np.zeros((G, m))
    PB = np.zeros((G, m))
    Y = np.zeros((G, d, m))
    FT = np.empty((G, npk, m))
    for g in range(G):
        for p in range(npk):
            for k in range(m):
                FT[g, p, k] = fpk[g, k, p]
    Wt = np.zeros((max(npk, 1), m))
    vpk0 = np.zeros((G, npk))
    ef = np.empty(nf)
    er = np.empty(nf)
    loc = np.zeros((G, d))
    zeta = np.zeros((G, d))
    lam_star = np.zeros((G, d, d))
    s_g = np.zeros(G)
    loglik = np.empty(N)
    mu_pr = np.zeros(2)
    S2 = np.zeros((2, 2))
    m0 = np.zeros(2)
    mass = veh[_MASS]
    fzf = veh[_FZF]
    fzr = veh[_FZR]
    lf = veh[_LF]
    lr = veh[_LR]
    izz = veh[_IZZ]
    v_eps = veh[_V_EPS]
    dof = nu - d + 1.0
    fl = lam if propagate else 1.0
    cp = math.cos(steer_prev)
    c0 = fzf * math.cos(steer) / mass  # d ay / d mu_f
    c1 = fzr / mass                    # d ay / d mu_r
    ureg = math.sqrt(vx * vx + v_eps * v_eps)
    if vx < 0.0:
        ureg = -ureg
    for ii in range(N):
        n = order[ii]
        # 1. propagate (eq. 7), forget (eq. 29)
        vy = x[n, 0]
        r = x[n, 1]
        if propagate:
            vy_new = vy - dt * vx_prev * r + dt * (fzf * cp * mu[n, 0] + fzr * mu[n, 1]) / mass
            r = r + dt * (lf * fzf * cp * mu[n, 0] - lr * fzr * mu[n, 1]) / izz
            vy = vy_new
            for g in range(G):
                for a in range(d):
                    for k in range(m):
                        Psi[n, g, a, k] *= lam
                    for b in range(d):
                        Phi[n, g, a, b] *= lam
        if vy_max >= 0.0:
            vy = min(max(vy, -vy_max), vy_max)
        if has_vy:
            vy = vy_meas
        if not learn:
            vy = 0.0
        x[n, 0] = vy
        x[n, 1] = r
        # 2. slip angles, prior mean, features
        af = steer - math.atan((vy + lf * r) / ureg)
        ar = -math.atan((vy - lr * r) / ureg)
        out_alpha[n, 0] = af
        out_alpha[n, 1] = ar
        # the friction model is held flat beyond +-a_lim (GPSSMConfig.slip_limit)
        afh = min(max(af, -a_lim), a_lim)
        arh = min(max(ar, -a_lim), a_lim)
        mu_pr[0] = _mf(afh, mf[0], mf[1], mf[2], mf[3])
        mu_pr[1] = _mf(arh, mf[0], mf[1], mf[2], mf[3])
        _sines(afh, L, nf, ef)
        _sines(arh, L, nf, er)
        for g in range(G):
            for k in range(m):
                v = wgt[g, k]
                if fidx[g, k] >= 0:
                    v *= ef[fidx[g, k]]
                if ridx[g, k] >= 0:
                    v *= er[ridx[g, k]]
                phi[g, k] = v
        # 3. solves and the predictive (eq. 32)
        for g in range(G):
            b = n * G + g
            for k in range(m):
                R[0, k] = phi[g, k]
                for a in range(nr - 1):
                    R[1 + a, k] = Psi[n, g, a, k]
            # this particle's P_B: its ancestor's slot minus the pending rank-1 term
            kb = panc[n] * G + g
            src = pinv[kb]
            dst = pinv[pdst[n] * G + g]
            gain = pgain[panc[n], g]
            if pdst[n] == panc[n]:
                if gain != 0.0:
                    pv = pend[panc[n], g]
                    for i in range(m):
                        ui = pv[i] * gain
                        for j in range(m):
                            dst[i, j] -= ui * pv[j]
            elif gain != 0.0:
                pv = pend[panc[n], g]
                for i in range(m):
                    ui = pv[i] * gain
                    for j in range(m):
                        dst[i, j] = src[i, j] - ui * pv[j]
            else:
                for i in range(m):
                    for j in range(m):
                        dst[i, j] = src[i, j]
            neumann_solve(dst, p_scale, delta, R, nr, nr, tol, max_terms, X, pbv, cur, nxt)
            s = 0.0
            for k in range(m):
                U[g, k] = X[0, k]
                PB[g, k] = pbv[k]
                s += phi[g, k] * U[g, k]
                for a in range(d):
                    Y[g, a, k] = out_M[n, g, a, k] if carry else X[1 + a, k]
            s_g[g] = s
            # P_B f of the peak features (stored units) and f^T H^{-1} f to first order
            for p in range(npk):
                if fresh[g, p]:
                    _mv1(dst, FT[g], p, Wt, 1.0)
                else:
                    c = 0.0
                    for k in range(m):
                        c += pend[panc[n], g, k] * fpk[g, k, p]
                    c *= gain
                    for k in range(m):
                        Wt[p, k] = wold[panc[n], g, p, k] - c * pend[panc[n], g, k]
            for p in range(npk):
                fw = 0.0
                ww = 0.0
                for k in range(m):
                    wk = Wt[p, k]
                    wnew[pdst[n], g, p, k] = wk
                    fw += fpk[g, k, p] * wk
                    ww += wk * wk
                vpk0[g, p] = p_scale * fw - delta * p_scale * p_scale * ww
            if carry:
                # loc = M phi; Lambda0 + lam (Lambda - Lambda0) = Lambda0 + Phi - Psi M^T
                # after the forgetting, without the cancellation
                for a in range(d):
                    acc = 0.0
                    for k in range(m):
                        acc += Y[g, a, k] * phi[g, k]
                    loc[g, a] = acc
                    for c in range(d):
                        lam_star[g, a, c] = Lambda0[a, c] + fl * (out_Lam[n, g, a, c] - Lambda0[a, c])
            else:
                for a in range(d):
                    acc = 0.0
                    for k in range(m):
                        acc += Psi[n, g, a, k] * U[g, k]
                    loc[g, a] = acc
                    for c in range(d):
                        acc = 0.0
                        for k in range(m):
                            acc += Psi[n, g, a, k] * Y[g, c, k]
                        lam_star[g, a, c] = Lambda0[a, c] + Phi[n, g, a, c] - acc
            _sym_pd(lam_star[g], 1e-12)
        # 4. friction sample and weight factor (eq. 21-22)
        ll = 0.0
        if conditional:
            # the t predictive as a scale mixture; given the scale, ay is linear in zeta
            if tensor:
                sc = (1.0 + s_g[0]) / gdraw[n, 0]
                for a in range(2):
                    m0[a] = loc[0, a]
                    for c in range(2):
                        S2[a, c] = lam_star[0, a, c] * sc
            else:
                for a in range(2):
                    m0[a] = loc[a, 0]
                    S2[a, a] = lam_star[a, 0, 0] * (1.0 + s_g[a]) / gdraw[n, a]
                S2[0, 1] = 0.0
                S2[1, 0] = 0.0
            v = ay - c0 * (mu_pr[0] + m0[0]) - c1 * (mu_pr[1] + m0[1])
            sc0 = S2[0, 0] * c0 + S2[0, 1] * c1
            sc1 = S2[1, 0] * c0 + S2[1, 1] * c1
            sy = c0 * sc0 + c1 * sc1 + sigma_ay * sigma_ay
            k0 = sc0 / sy
            k1 = sc1 / sy
            mean0 = m0[0] + k0 * v
            mean1 = m0[1] + k1 * v
            S2[0, 0] -= k0 * sc0
            S2[0, 1] -= k0 * sc1
            S2[1, 0] -= k1 * sc0
            S2[1, 1] -= k1 * sc1
            _sym_pd(S2, 1e-18)
            l00 = math.sqrt(max(S2[0, 0], 0.0))
            l10 = S2[1, 0] / l00 if l00 > 0.0 else 0.0
            l11 = math.sqrt(max(S2[1, 1] - l10 * l10, 0.0))
            z0 = mean0 + l00 * zdraw[n, 0, 0]
            z1 = mean1 + l10 * zdraw[n, 0, 0] + l11 * zdraw[n, 0, 1]
            ll = -0.5 * v * v / sy - 0.5 * math.log(sy)
            if tensor:
                zeta[0, 0] = z0
                zeta[0, 1] = z1
            else:
                zeta[0, 0] = z0
                zeta[1, 0] = z1
        else:
            for g in range(G):
                f = math.sqrt(dof / gdraw[n, g])
                sc = (1.0 + s_g[g]) / dof
                if d == 1:
                    zeta[g, 0] = loc[g, 0] + math.sqrt(lam_star[g, 0, 0] * sc) * zdraw[n, g, 0] * f
                else:
                    a00 = lam_star[g, 0, 0] * sc
                    a10 = lam_star[g, 1, 0] * sc
                    a11 = lam_star[g, 1, 1] * sc
                    l00 = math.sqrt(a00)
                    l10 = a10 / l00
                    l11 = math.sqrt(max(a11 - l10 * l10, 0.0))
                    zeta[g, 0] = loc[g, 0] + l00 * zdraw[n, g, 0] * f
                    zeta[g, 1] = loc[g, 1] + (l10 * zdraw[n, g, 0] + l11 * zdraw[n, g, 1]) * f
            if tensor:
                z0, z1 = zeta[0, 0], zeta[0, 1]
            else:
                z0, z1 = zeta[0, 0], zeta[1, 0]
            v = ay - c0 * (mu_pr[0] + z0) - c1 * (mu_pr[1] + z1)
            ll = -0.5 * (v / sigma_ay) ** 2
        mu[n, 0] = mu_pr[0] + z0
        mu[n, 1] = mu_pr[1] + z1
        v = (yaw_rate - r) / sigma_r
        loglik[n] = ll - 0.5 * v * v
        # 5. data update (eq. 28) and posterior quantities (Sherman-Morrison on eq. 32)
        for g in range(G):
            b = n * G + g
            s = s_g[g]
            if learn:
                inv1s = 1.0 / (1.0 + s)
                # Sherman-Morrison on P_B (eq. 28b), left pending for the next step
                sB = 0.0
                for k in range(m):
                    sB += phi[g, k] * PB[g, k]
                pgain_new[pdst[n], g] = 1.0 / ((1.0 + sB) * p_scale)
                for k in range(m):
                    pend_new[pdst[n], g, k] = PB[g, k]
                    hist[hslot, n, g, k] = phi[g, k]
                for a in range(d):
                    za = zeta[g, a]
                    coef = (loc[g, a] + za * s) * inv1s
                    for k in range(m):
                        Psi[n, g, a, k] += za * phi[g, k]
                        out_M[n, g, a, k] = Y[g, a, k] + U[g, k] * (za - coef)
                    for c in range(d):
                        Phi[n, g, a, c] += za * zeta[g, c]
                        out_Lam[n, g, a, c] = (lam_star[g, a, c]
                                               + (za - loc[g, a]) * (zeta[g, c] - loc[g, c]) * inv1s)
                _sym_pd(out_Lam[n, g], 1e-12)
                for p in range(npk):
                    # f^T (H + phi phi^T)^{-1} f = f^T H^{-1} f - (f^T H^{-1} phi)² / (1 + s)
                    up = 0.0
                    for k in range(m):
                        up += fpk[g, k, p] * U[g, k]
                    out_vpk[n, g, p] = vpk0[g, p] - up * up * inv1s
            else:
                pgain_new[pdst[n], g] = 0.0
                for a in range(d):
                    for k in range(m):
                        out_M[n, g, a, k] = Y[g, a, k]
                    for c in range(d):
                        out_Lam[n, g, a, c] = lam_star[g, a, c]
                for p in range(npk):
                    out_vpk[n, g, p] = vpk0[g, p]
        # mu_prior + M phi at the particle's slip angles (Algorithm 1, line 12)
        for ax in range(2):
            out_munow[n, ax] = mu_pr[ax]
        for g in range(G):
            for a in range(d):
                acc = 0.0
                for k in range(m):
                    acc += out_M[n, g, a, k] * phi[g, k]
                out_munow[n, a if tensor else g] += acc
    # 6. weights (Algorithm 1, lines 3, 6-7) and estimates (lines 11-12)
    top = -np.inf
    for n in range(N):
        logw[n] += loglik[n]
        if logw[n] > top:
            top = logw[n]
    tot = 0.0
    for n in range(N):
        logw[n] = math.exp(logw[n] - top)
        tot += logw[n]
    w2 = 0.0
    for n in range(N):
        logw[n] /= tot
        w2 += logw[n] * logw[n]
    for i in range(_EST_SIZE):
        est[i] = 0.0
    est[_ESS] = 1.0 / w2
    for n in range(N):
        w = logw[n]
        est[_VY] += w * x[n, 0]
        est[_YR] += w * x[n, 1]
        est[_AF] += w * out_alpha[n, 0]
        est[_AR] += w * out_alpha[n, 1]
        est[_MU_F] += w * out_munow[n, 0]
        est[_MU_R] += w * out_munow[n, 1]
    for n in range(N):
        w = logw[n]
        est[_VY_STD] += w * (x[n, 0] - est[_VY]) ** 2
        est[_YR_STD] += w * (x[n, 1] - est[_YR]) ** 2
        # back to logs; 1e-300 keeps an underflowed weight finite
        logw[n] = math.log(max(w, 1e-300))
    est[_VY_STD] = math.sqrt(max(est[_VY_STD], 0.0))
    est[_YR_STD] = math.sqrt(max(est[_YR_STD], 0.0))


@numba.njit(cache=True, fastmath=True)
def peak_summary(M, Lam, qdof, logw, vpk, feats, prior, grid, where, col, a_vis, ell, z95, floor2, peak_max,
                 out):
    """Peak friction per axle (:func:`roadgrip.estimators.gpssm._peak_estimates`).

    Parameters
    ----------
    M : (N, G, d, m);  Lam : (N, G, d, d);  qdof : float, ``max(nu - d - 1, 1)``
    logw : (N,) normalised log weights;  vpk : (N, G, np)
    feats : (2, ng, m) odd-part features of each axle's curve on ``grid`` (ng,) [rad]
    prior : (ng,) prior mean curve;  where : (2, 2) (group, row) per axle
    col : (2, 2) columns of ``vpk`` per axle: at the unrestricted peak and at the band point
        (the lower band of an unobserved peak uses the larger of the two variances)
    a_vis : (2,) visited slip range [rad]
    floor2 : float, variance [-] added to every particle's (``curve_sigma_floor²``: the
        basis truncation error, which moves the peak of a represented curve too)
    peak_max : float, the upper band of a peak that was not observed (``GPSSMConfig.peak_max``)
    out : (2, 6) rows front/rear: ``mu, lower, upper, alpha_peak, observed, alpha_band``
    """  # pragma: no cover - compiled
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
            if grid[k] <= a_vis[ax]:
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
                if grid[k] <= a_vis[ax] and acc > best_in:
                    best_in = acc
            peaks[n] = best
            vis[n] = best_in
        jmax = 0
        for k in range(1, ng):
            if mean[k] > mean[jmax]:
                jmax = k
        a_pk = grid[jmax]
        pm = 0.0
        for n in range(N):
            pm += w[n] * peaks[n]
        pv = 0.0
        for n in range(N):
            var_in = max(vpk[n, g, col[ax, 0]], 0.0) * Lam[n, g, r, r] / qdof + floor2
            pv += w[n] * ((peaks[n] - pm) ** 2 + var_in)
        hi = pm + z95 * math.sqrt(max(pv, 0.0))
        observed = a_vis[ax] >= a_pk + ell and a_pk > 0.0 and jmax < ng - 1
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
                if grid[k] <= a_vis[ax] and mean[k] > mean[jb]:
                    jb = k
            a_band = grid[jb]
        if not observed:
            # past the visited range the curve is the prior's: the data bound the peak
            # only from below
            hi = peak_max
        out[ax, 0] = mu_hat
        out[ax, 1] = max(lo, 0.0)
        out[ax, 2] = max(hi, mu_hat)
        out[ax, 3] = a_pk
        out[ax, 4] = 1.0 if observed else 0.0
        out[ax, 5] = a_band
