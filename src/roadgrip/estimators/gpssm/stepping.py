"""One step of the GP-SSM filter (Algorithm 1 of paper 000) through the compiled kernel.

:func:`step` dispatches on ``GPSSMConfig.linalg``: ``'exact'`` and ``'fast'`` run the
compiled per-particle pass (:mod:`roadgrip.estimators.gpssm.kernel`) and the peak
summary; ``'direct'`` runs the NumPy reference
(:mod:`roadgrip.estimators.gpssm.reference`).

BLAS runs one thread during the step (:mod:`roadgrip.blas_threads`): faster for these
small products, and the result does not depend on the number of cores (a threaded
product sums in another order, and the filter's paths part at the first resampling that
such a difference changes).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from roadgrip.blas_threads import one_blas_thread
from roadgrip.constants import Z95
from roadgrip.estimators.gpssm import kernel as gk
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.guard import guard_step
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.kernel_ops import (
    PEAK,
    PeakGrid,
    PeakParams,
    PeakPosterior,
    peak_summary,
    slot_plan,
)
from roadgrip.estimators.gpssm.model import Input
from roadgrip.estimators.gpssm.posterior import axle_rows, peak_cols, peak_grid, peak_rhs
from roadgrip.estimators.gpssm.reference import step_reference
from roadgrip.estimators.gpssm.state import (
    Context,
    GPSSMEstimate,
    GPSSMState,
    check_sample,
    init_state,
    manifold_ratio,
    resample,
    slip_statistics,
    systematic,
    visited_range,
)

__all__ = ["step", "step_unthreaded"]


def step(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """One step of Algorithm 1 at ``sample.t``.

    The returned state reuses (and overwrites) the arrays of ``state`` (a donated
    buffer); keep :func:`~roadgrip.estimators.gpssm.state.copy_state` of it if the old
    state is still needed. ``state=None`` initialises from ``sample`` with ``seed``.

    The ``'exact'`` and ``'fast'`` modes run the compiled per-particle kernel
    (:mod:`roadgrip.estimators.gpssm.kernel`); ``'direct'`` runs the NumPy reference
    implementation (:func:`~roadgrip.estimators.gpssm.reference.step_reference`). Both
    draw the same random numbers.

    BLAS runs one thread during the step (:mod:`roadgrip.blas_threads`): faster for these
    small products, and the result does not depend on the number of cores (a threaded
    product sums in another order, and the filter's paths part at the first resampling
    that such a difference changes).

    Returns
    -------
    state : GPSSMState
    estimate : GPSSMEstimate
    """
    with one_blas_thread():
        return step_unthreaded(ctx, state, sample, seed)


def step_unthreaded(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` without setting the BLAS threads (for loops that set them once)."""
    if ctx.config.linalg == "direct":
        return step_reference(ctx, state, sample, seed)
    return _step_compiled(ctx, state, sample, seed)



def _kernel_constants(ctx: Context) -> dict[str, Any]:
    """Packed constants of :mod:`roadgrip.estimators.gpssm.kernel` for a context, built
    once and kept in it."""
    kc = ctx.kernel
    if "basis" not in kc:
        config = ctx.config
        pt = config.prior_tire
        exact = config.linalg == "exact"
        kc.update(
            mf=np.array([pt.B, pt.C, pt.D, pt.E], float),
            basis=gk.basis_tables(config.basis, config.alpha_limit),
            Lambda0=np.ascontiguousarray(config.Lambda0),
            tol=la.EXACT_TOL if exact else 1.0, max_terms=60 if exact else 0,
            where=axle_rows(config), col=peak_cols(config),
        )
    return kc


def _step_compiled(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` through the compiled kernel (``'exact'`` and ``'fast'``)."""
    check_sample(sample)
    config = ctx.config
    kc = _kernel_constants(ctx)
    b = config.basis
    N, G, d, m = config.particles, b.groups, b.outputs, b.m
    lam = config.forgetting
    carry = config.linalg == "fast"
    if state is None:
        state = init_state(ctx, sample, seed)
        lin, nu, propagate, dt = state.lin, state.nu, False, 0.0
    else:
        dt = sample.t - state.t
        if not dt > 0:
            raise ValueError(f"GP-SSM samples must have increasing time: {state.t} then {sample.t}")
        c_forgotten = state.lin.c * lam
        lin = la.forget(state.lin, lam, config.refactor_every)
        nu, propagate = lam * state.nu, True
        if carry and lin.since_refactor == 0:
            _refactored_posterior(state, lam, lin, lin.c - c_forgotten)
    learn = bool(sample.vx >= config.min_speed)
    if learn:
        lin = la.reserve(lin)
    rng = state.rng
    gwalk = ctx.gain_steps(rng, dt) if propagate else np.zeros(N)
    ratio = manifold_ratio(state)
    fpk_g = peak_rhs(ctx, ratio, state.peak_alpha)  # (G, m, np)
    dof = nu - d + 1.0
    if config.proposal == "conditional":
        gdraw = rng.chisquare(dof, size=(N, G))
        zdraw = rng.standard_normal((N, 2)).reshape(N, 1, 2)
    else:
        zdraw = rng.standard_normal((N, G, d))
        gdraw = rng.chisquare(dof, size=(N, G))
    vy_max = -1.0
    if config.max_sideslip is not None:
        vy_max = math.tan(config.max_sideslip) * max(float(sample.vx), 0.0)
    alpha = np.empty((N, 2))
    M = state.M if carry else np.empty((N, G, d, m))
    Lam = state.Lam if carry else np.empty((N, G, d, d))
    vpk = np.empty((N, G, fpk_g.shape[2]))
    munow = np.empty((N, 2))
    e = np.empty(gk.EST.SIZE)
    logw = state.logw
    pend_new = np.empty((N, G, m))
    pgain_new = np.empty((N, G))
    if lin.pkf is None or lin.pkf.shape != fpk_g.shape:
        fresh = np.ones((G, fpk_g.shape[2]), dtype=np.bool_)
    else:
        fresh = np.any(lin.pkf != fpk_g, axis=1)  # (G, np): columns whose features moved
    wold = lin.pkw if lin.pkw is not None else np.zeros((N, G, fpk_g.shape[2], m))
    wnew = np.empty((N, G, fpk_g.shape[2], m))
    pdst, order = slot_plan(lin.panc)
    gk.particle_pass(
        gk.Particles(state.x, state.mu, logw, state.Psi, state.Phi),
        gk.Slots(lin.pinv.reshape(N * G, m, m), lin.panc, pdst, order, lin.pend, lin.pgain,
                 pend_new, pgain_new, lin.hist, lin.nhist),
        gk.StepInput(propagate, float(dt), float(state.u[Input.STEER]), float(state.u[Input.VX]),
                     float(sample.steer), float(sample.vx), float(sample.ay), float(sample.yaw_rate),
                     not math.isnan(sample.vy), 0.0 if math.isnan(sample.vy) else float(sample.vy), learn),
        ctx.step_vehicle(sample),
        gk.Params(kc["mf"], lam, nu, kc["Lambda0"], ctx.sigma_ay, ctx.sigma_yaw_rate, vy_max,
                  lin.p_scale, 0.0 if carry else 1.0 - lin.c, kc["tol"], kc["max_terms"],
                  config.proposal == "conditional", carry),
        kc["basis"],
        gk.PeakColumns(fpk_g, wold, wnew, fresh),
        gk.Draws(gdraw, zdraw, gwalk),
        gk.Outputs(alpha, M, Lam, vpk, munow, e),
    )
    lin = lin._replace(pend=pend_new, pgain=pgain_new, panc=pdst, pkw=wnew, pkf=fpk_g)
    if learn:
        lin.hcoef[lin.nhist] = 1.0 / lin.sigma_scale
        lin.hanc[lin.nhist] = np.arange(N)
        lin = lin._replace(nhist=lin.nhist + 1)
        nu = nu + 1.0
    af_m, ar_m = float(e[gk.EST.ALPHA_F]), float(e[gk.EST.ALPHA_R])
    visits, moments, excited = slip_statistics(config, state, af_m, ar_m, learn)
    grid, feats, prior = peak_grid(config, round(ratio, 2))
    a_vis = np.array([visited_range(config, visits[ax]) for ax in range(2)])
    pk = np.empty((2, PEAK.SIZE))
    peak_summary(PeakPosterior(M, Lam, logw, vpk), PeakGrid(feats, prior, grid, kc["where"], kc["col"]), a_vis,
                 PeakParams(max(nu - d - 1.0, 1.0), config.peak_margin, Z95, config.curve_sigma_floor**2,
                            config.peak_max, config.peak_narrow), pk)
    ess = float(e[gk.EST.ESS])
    resampled = ess <= config.ess_threshold * N
    new = GPSSMState(
        k=state.k + 1, t=float(sample.t), u=np.array([sample.steer, sample.vx], dtype=float),
        x=state.x, mu=state.mu, logw=logw, lin=lin, Psi=state.Psi, Phi=state.Phi, nu=float(nu),
        visits=visits, slip_moments=moments, peak_alpha=pk[:, [PEAK.ALPHA, PEAK.ALPHA_BAND]].T.copy(), rng=rng,
        M=state.M, Lam=state.Lam, guard=state.guard,
    )
    if resampled:
        new = resample(new, systematic(rng, np.exp(logw)))
    est = GPSSMEstimate(
        t=float(sample.t),
        vy=float(e[gk.EST.VY]), vy_std=float(e[gk.EST.VY_STD]),
        yaw_rate=float(e[gk.EST.YAW_RATE]), yaw_rate_std=float(e[gk.EST.YAW_RATE_STD]),
        ay_gain=float(e[gk.EST.AY_GAIN]),
        alpha_f=af_m, alpha_r=ar_m,
        mu_now_front=float(e[gk.EST.MU_NOW_F]), mu_now_rear=float(e[gk.EST.MU_NOW_R]),
        mu_front=float(pk[0, PEAK.MU]), mu_rear=float(pk[1, PEAK.MU]),
        mu_front_lower=float(pk[0, PEAK.LOWER]), mu_front_upper=float(pk[0, PEAK.UPPER]),
        mu_rear_lower=float(pk[1, PEAK.LOWER]), mu_rear_upper=float(pk[1, PEAK.UPPER]),
        peak_alpha_front=float(pk[0, PEAK.ALPHA]), peak_alpha_rear=float(pk[1, PEAK.ALPHA]),
        peak_observed_front=bool(pk[0, PEAK.OBSERVED]), peak_observed_rear=bool(pk[1, PEAK.OBSERVED]),
        excited=excited, ess=ess, resampled=bool(resampled),
    )
    return new, guard_step(ctx, new, est, sample, dt)


def _refactored_posterior(state: GPSSMState, lam: float, lin: la.LinAlgState, eps: float) -> None:
    """``'fast'`` mode: the carried ``M`` and ``Lambda`` after a refactorisation in the time
    update moved the prior weight by ``eps`` (``B' = B + eps I``, nothing pending, every
    particle owns its slot), in place: ``B'^{-1} = B^{-1} - eps B^{-1} B'^{-1}`` gives
    ``M' = M (I - eps P_B')`` and ``Lambda' = Lambda + eps M M'^T / lam`` (the compiled step
    forgets ``Lambda - Lambda0`` by ``lam`` next). Neither is formed from ``Psi``, so
    nothing cancels."""
    M, Lam = state.M, state.Lam
    M0 = M.copy()
    np.matmul(M0, lin.pinv, out=M)
    M *= -eps * lin.p_scale
    M += M0
    Lam += (eps / lam) * np.matmul(M0, np.swapaxes(M, -1, -2))
