r"""Compiled step of the GP-SSM filter (:mod:`roadgrip.estimators.gpssm`).

One call of :func:`particle_pass` does, for every particle and basis group, everything of
Algorithm 1 that is per particle: the propagation of eq. 7 with the forgetting of eq. 29,
the slip angles and features, the solves with ``H = Sigma + I`` (the deferred-prior
Neumann series of :mod:`roadgrip.estimators.gpssm.linalg`, whose ``P_B`` stays in cache
for the whole particle), the predictive of eq. 32 and the friction sample, the weight
factor of eq. 21-22, the data update of eq. 28 (``P_B`` by Sherman-Morrison, the feature
vector into the history of ``Sigma``, ``Psi``, ``Phi``) and the posterior quantities that
the estimates need. It then normalises the weights and forms the weighted estimates
(Algorithm 1, lines 6-7 and 11-12). The model equations are those of
:mod:`roadgrip.estimators.gpssm.model`, compiled.

Random numbers are drawn by the caller with NumPy (same order as the reference
implementation, :func:`roadgrip.estimators.gpssm.reference.step_reference`) and passed
in, so a seed gives the same particles whichever implementation runs; the tests hold the
two to each other.

Layouts
-------
``x`` (N, 2) ``[vy, yaw_rate]`` (:class:`~roadgrip.estimators.gpssm.model.State`);
``mu`` (N, 2) front/rear; ``pinv`` (N·G, m, m); ``hist`` (J, N, G, m); ``Psi`` (N, G, d,
m); ``Phi`` (N, G, d, d); basis tables ``fidx``, ``ridx`` (G, m) index the 1-D
eigenfunctions of the front and rear slip angle (-1: not a factor), ``wgt`` (G, m) the
square roots of the spectral density. :class:`EST` names the slots of the estimate array.
The arguments are grouped in the named tuples below.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.gpssm.kernel_ops import _mf, _mv1, _sines, _sym_pd, neumann_solve
from roadgrip.estimators.gpssm.model import State, ay_gains_jit, euler_step_jit, slip_angles_jit
from roadgrip.estimators.gpssm.model import regularised_speed as _regularised_speed

__all__ = [
    "EST",
    "BasisTables",
    "Draws",
    "Outputs",
    "Params",
    "Particles",
    "PeakColumns",
    "Slots",
    "StepInput",
    "basis_tables",
    "particle_pass",
]


class EST:
    """Slots of the estimate array written by :func:`particle_pass`."""

    ESS, VY, YAW_RATE, VY_STD, YAW_RATE_STD, ALPHA_F, ALPHA_R, MU_NOW_F, MU_NOW_R, AY_GAIN, SIZE = range(11)


# the same slots as module constants (compiled code reads globals, not class attributes)
_ESS, _VY_EST, _YR, _VY_STD, _YR_STD, _AF, _AR, _MU_F, _MU_R, _GAIN_EST, _EST_SIZE = range(11)
_VY, _YAW_RATE, _GAIN = State.VY, State.YAW_RATE, State.AY_GAIN
_GAIN_MIN, _GAIN_MAX = 0.5, 2.0  # state.GAIN_MIN, GAIN_MAX

regularised_speed_jit = numba.njit(cache=True, inline="always")(_regularised_speed)


class Particles(NamedTuple):
    """Per-particle arrays, in/out."""

    x: NDArray
    mu: NDArray
    logw: NDArray
    Psi: NDArray
    Phi: NDArray


class Slots(NamedTuple):
    """The ``P_B`` slots, their pending rank-1 terms and the history of ``Sigma``."""

    pinv: NDArray
    panc: NDArray
    pdst: NDArray
    order: NDArray
    pend: NDArray
    pgain: NDArray
    pend_new: NDArray
    pgain_new: NDArray
    hist: NDArray
    hslot: int


class StepInput(NamedTuple):
    """Inputs of a step (SI units); ``*_prev`` those of the previous step."""

    propagate: bool
    dt: float
    steer_prev: float
    vx_prev: float
    steer: float
    vx: float
    ay: float
    yaw_rate: float
    has_vy: bool
    vy_meas: float
    learn: bool


class Params(NamedTuple):
    """Filter constants of a step."""

    mf: NDArray
    lam: float
    nu: float
    Lambda0: NDArray
    sigma_ay: float
    sigma_r: float
    vy_max: float
    p_scale: float
    delta: float
    tol: float
    max_terms: int
    conditional: bool
    carry: bool
    gain_gate: float


class BasisTables(NamedTuple):
    """The basis as the kernel evaluates it (:func:`basis_tables`)."""

    tensor: bool
    nf: int
    fidx: NDArray
    ridx: NDArray
    wgt: NDArray
    L: float
    a_lim: float


class PeakColumns(NamedTuple):
    """Peak features and their cached products with ``P_B``."""

    fpk: NDArray
    wold: NDArray
    wnew: NDArray
    fresh: NDArray


class Draws(NamedTuple):
    """Random numbers of a step."""

    gdraw: NDArray
    zdraw: NDArray
    gwalk: NDArray


class Outputs(NamedTuple):
    """Per-particle and weighted outputs of a step."""

    alpha: NDArray
    M: NDArray
    Lam: NDArray
    vpk: NDArray
    munow: NDArray
    est: NDArray


def basis_tables(basis, a_lim: float) -> BasisTables:
    """:class:`BasisTables` of a basis (module docstring) with the slip limit ``a_lim`` [rad]."""
    if basis.kind == "tensor":
        n = basis.n
        j1, j2 = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        keep = basis._keep
        fidx = j1.ravel()[keep][None].astype(np.int64)
        ridx = j2.ravel()[keep][None].astype(np.int64)
        wgt = np.asarray(basis.sqrt_s, float)[None]
        return BasisTables(True, n, fidx, ridx, np.ascontiguousarray(wgt), float(basis.L), float(a_lim))
    j = np.asarray(basis._j, np.int64) - 1
    nf = int(j.max()) + 1
    none = np.full_like(j, -1)
    w = np.asarray(basis.sqrt_s, float)
    return BasisTables(False, nf, np.stack([j, none]), np.stack([none, j]),
                       np.ascontiguousarray(np.stack([w, w])), float(basis.L), float(a_lim))


@numba.njit(cache=True, fastmath=True)
def particle_pass(p, slots, inp, veh, prm, basis, peak, draws, out):  # pragma: no cover - compiled
    """All per-particle work of one step, in place (module docstring).

    Parameters (shapes; ``d`` outputs, ``np`` peak columns)
    ----------------------------------------------------------
    p : Particles
        ``x``, ``mu`` (N, 2) in/out (state, layout :class:`~roadgrip.estimators.gpssm.model.State`;
        friction sample, front/rear); ``logw`` (N,) in/out (normalised log weights);
        ``Psi`` (N, G, d, m), ``Phi`` (N, G, d, d) in/out (forgotten when
        ``inp.propagate``, then updated when ``inp.learn``).
    slots : Slots
        ``pinv`` (N·G, m, m) slots of ``P_B / p_scale``, particle ``n`` reads slot
        ``panc[n]`` minus that slot's pending term ``pgain pend pend^T`` (``pend`` (N, G,
        m), ``pgain`` (N, G), by slot) and writes the result to slot ``pdst[n]``, in place
        when ``pdst[n] == panc[n]``; particles are processed in the order ``order``
        (:func:`~roadgrip.estimators.gpssm.kernel_ops.slot_plan`: the copies before the
        slot they read is overwritten). Its own update of this step is left pending in
        ``pend_new``, ``pgain_new``, by slot ``pdst[n]``
        (:mod:`roadgrip.estimators.gpssm.linalg`). ``hist`` (J, N, G, m), row ``hslot``
        written when ``inp.learn``.
    inp : StepInput
        This step's and the previous step's inputs.
    veh : VehicleConstants
    prm : Params
        ``mf`` (4,) prior Magic Formula ``B, C, D, E``; ``vy_max`` negative for no bound;
        ``gain_gate``: ``|a_y|`` [m/s²] below which every particle takes the weighted mean
        accelerometer gain of ``x`` and ``logw`` on entry; ``carry``: ``'fast'`` mode:
        ``H`` is taken as ``B`` (pass ``delta = 0``, ``max_terms = 0``); ``out.M`` and
        ``out.Lam`` hold each particle's posterior ``M = Psi P_B`` and ``Lambda`` of the
        last step on entry, carried and updated in place, so only ``phi`` is solved for
        and ``Lambda`` is not formed by cancellation (:mod:`roadgrip.estimators.gpssm.linalg`).
    basis : BasisTables
        ``L``, ``a_lim``: basis half-width and the slip angle past which the friction
        model is held flat [rad] (``GPSSMConfig.alpha_limit``).
    peak : PeakColumns
        ``fpk`` (G, m, np) odd-part features ``f`` at the peak slip angles; ``wold``,
        ``wnew`` (N, G, np, m) ``P_B f / p_scale`` per ``pinv`` slot, before (read through
        ``panc`` and corrected by the pending term, like ``pinv``) and after this step
        (written through ``pdst``); ``fresh`` (G, np) marks the columns recomputed with a
        product (their ``f`` moved, or ``P_B`` was refactorised). The peak band needs
        ``f^T H^{-1} f = f^T P_B f - (1 - c) |P_B f|² + O((1 - c)²)`` (eq. 25), so ``f``
        never enters the Neumann series.
    draws : Draws
        ``gdraw`` (N, G) chi-square draws with ``nu - d + 1`` degrees of freedom;
        ``zdraw`` (N, 1, 2) standard normals (conditional proposal) or (N, G, d)
        (bootstrap); ``gwalk`` (N,) the random-walk steps of the accelerometer gains
        (``State.AY_GAIN``, applied when ``inp.propagate``).
    out : Outputs
        ``alpha`` (N, 2) slip angles; ``M`` (N, G, d, m) posterior mean (eq. 28a);
        ``Lam`` (N, G, d, d) posterior ``Lambda``; ``vpk`` (N, G, np) ``f^T H^{-1} f`` of
        the peak features after the update; ``munow`` (N, 2) ``mu_prior + M phi``;
        ``est`` (EST.SIZE,) weighted estimates.
    """
    x, mu, logw, Psi, Phi = p.x, p.mu, p.logw, p.Psi, p.Phi
    pinv, panc, pdst, order = slots.pinv, slots.panc, slots.pdst, slots.order
    pend, pgain, pend_new, pgain_new = slots.pend, slots.pgain, slots.pend_new, slots.pgain_new
    hist, hslot = slots.hist, slots.hslot
    propagate, dt, steer_prev, vx_prev = inp.propagate, inp.dt, inp.steer_prev, inp.vx_prev
    steer, vx, ay, yaw_rate = inp.steer, inp.vx, inp.ay, inp.yaw_rate
    has_vy, vy_meas, learn = inp.has_vy, inp.vy_meas, inp.learn
    mf, lam, nu, Lambda0 = prm.mf, prm.lam, prm.nu, prm.Lambda0
    sigma_ay, sigma_r, vy_max = prm.sigma_ay, prm.sigma_r, prm.vy_max
    p_scale, delta, tol, max_terms = prm.p_scale, prm.delta, prm.tol, prm.max_terms
    conditional, carry = prm.conditional, prm.carry
    tensor, nf, fidx, ridx, wgt = basis.tensor, basis.nf, basis.fidx, basis.ridx, basis.wgt
    L, a_lim = basis.L, basis.a_lim
    fpk, wold, wnew, fresh = peak.fpk, peak.wold, peak.wnew, peak.fresh
    gdraw, zdraw, gwalk = draws.gdraw, draws.zdraw, draws.gwalk
    out_alpha, out_M, out_Lam, out_vpk, out_munow, est = out.alpha, out.M, out.Lam, out.vpk, out.munow, out.est
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
    dof = nu - d + 1.0
    fl = lam if propagate else 1.0
    cp = math.cos(steer_prev)
    c0, c1 = ay_gains_jit(math.cos(steer), veh)  # d ay / d mu_f, d ay / d mu_r
    ureg = regularised_speed_jit(vx, veh.v_eps)
    # below the gate every particle takes the weighted mean gain (GPSSMConfig.ay_gain_gate)
    gain_on = abs(ay) >= prm.gain_gate
    kbar = 0.0
    if not gain_on:
        for n in range(N):
            kbar += math.exp(logw[n]) * x[n, _GAIN]
    for ii in range(N):
        n = order[ii]
        # 1. propagate (eq. 7), forget (eq. 29)
        vy = x[n, _VY]
        r = x[n, _YAW_RATE]
        kg = x[n, _GAIN]
        if propagate:
            vy, r = euler_step_jit(vy, r, cp, vx_prev, mu[n, 0], mu[n, 1], dt, veh)
            kg = min(max(kg + gwalk[n], _GAIN_MIN), _GAIN_MAX)
            x[n, _GAIN] = kg
            for g in range(G):
                for a in range(d):
                    for k in range(m):
                        Psi[n, g, a, k] *= lam
                    for b in range(d):
                        Phi[n, g, a, b] *= lam
        # this particle's accelerometer gain on eq. 8 (the mean gain below the gate)
        ke = kg if gain_on else kbar
        g0 = ke * c0
        g1 = ke * c1
        if vy_max >= 0.0:
            vy = min(max(vy, -vy_max), vy_max)
        if has_vy:
            vy = vy_meas
        if not learn:
            vy = 0.0
        x[n, _VY] = vy
        x[n, _YAW_RATE] = r
        # 2. slip angles, prior mean, features
        af, ar = slip_angles_jit(vy, r, steer, ureg, veh)
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
            v = ay - g0 * (mu_pr[0] + m0[0]) - g1 * (mu_pr[1] + m0[1])
            sc0 = S2[0, 0] * g0 + S2[0, 1] * g1
            sc1 = S2[1, 0] * g0 + S2[1, 1] * g1
            sy = g0 * sc0 + g1 * sc1 + sigma_ay * sigma_ay
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
            v = ay - g0 * (mu_pr[0] + z0) - g1 * (mu_pr[1] + z1)
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
        est[_VY_EST] += w * x[n, _VY]
        est[_YR] += w * x[n, _YAW_RATE]
        est[_AF] += w * out_alpha[n, 0]
        est[_AR] += w * out_alpha[n, 1]
        est[_GAIN_EST] += w * x[n, _GAIN]
        est[_MU_F] += w * out_munow[n, 0]
        est[_MU_R] += w * out_munow[n, 1]
    for n in range(N):
        w = logw[n]
        est[_VY_STD] += w * (x[n, _VY] - est[_VY_EST]) ** 2
        est[_YR_STD] += w * (x[n, _YAW_RATE] - est[_YR]) ** 2
        # back to logs; 1e-300 keeps an underflowed weight finite
        logw[n] = math.log(max(w, 1e-300))
    est[_VY_STD] = math.sqrt(max(est[_VY_STD], 0.0))
    est[_YR_STD] = math.sqrt(max(est[_YR_STD], 0.0))
