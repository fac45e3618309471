"""NumPy reference implementation of one GP-SSM step (Algorithm 1 of paper 000).

The same step as the compiled kernel (:mod:`roadgrip.estimators.gpssm.kernel`), written
with array operations over the particles and the linear algebra of
:mod:`roadgrip.estimators.gpssm.linalg` (any mode). It draws the same random numbers in
the same order, so a seed gives the same particles; the tests hold the two to 1e-7.
``linalg='direct'`` runs it.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.config import GPSSMConfig
from roadgrip.estimators.gpssm.guard import guard_step, step_sigma_ay
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.model import (
    Input,
    State,
    ay_gains,
    euler_step,
    regularised_speed,
    slip_angles,
)
from roadgrip.estimators.gpssm.posterior import axle_rows, held, peak_estimates, peak_rhs
from roadgrip.estimators.gpssm.state import (
    GAIN_MAX,
    GAIN_MIN,
    Context,
    GPSSMEstimate,
    GPSSMState,
    check_sample,
    init_state,
    manifold_ratio,
    resample,
    slip_statistics,
    sym_pd,
    systematic,
)

__all__ = ["step_reference"]


def step_reference(
    ctx: Context, state: GPSSMState | None, sample: Sample, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """One step of Algorithm 1 with array operations over the particles (any ``linalg``
    mode); :func:`~roadgrip.estimators.gpssm.stepping.step` documents the arguments."""
    check_sample(sample)
    config = ctx.config
    veh = ctx.step_vehicle(sample)
    b = config.basis
    lam = config.forgetting
    N, d = config.particles, b.outputs
    dt_step = 0.0 if state is None else float(sample.t - state.t)
    if state is None:
        state = init_state(ctx, sample, seed)
        x, lin, Psi, Phi, nu = state.x, state.lin, state.Psi, state.Phi, state.nu
    else:
        dt = sample.t - state.t
        if not dt > 0:
            raise ValueError(f"GP-SSM samples must have increasing time: {state.t} then {sample.t}")
        # 1. propagate (eq. 7) and forget (eq. 29)
        vy, r = euler_step(state.x[:, State.VY], state.x[:, State.YAW_RATE],
                           math.cos(state.u[Input.STEER]), state.u[Input.VX],
                           state.mu[:, 0], state.mu[:, 1], dt, veh)
        gain = np.clip(state.x[:, State.AY_GAIN] + ctx.gain_steps(state.rng, dt), GAIN_MIN, GAIN_MAX)
        x = np.stack([vy, r, gain], axis=1)
        lin = la.forget(state.lin, lam, config.refactor_every)
        Psi = state.Psi
        Psi *= lam
        Phi = state.Phi
        Phi *= lam
        nu = lam * state.nu
    if config.max_sideslip is not None:
        # physical bound on the body sideslip angle (GPSSMConfig.max_sideslip)
        vy_max = math.tan(config.max_sideslip) * max(float(sample.vx), 0.0)
        np.clip(x[:, State.VY], -vy_max, vy_max, out=x[:, State.VY])
    rng = state.rng

    u = np.array([sample.steer, sample.vx], dtype=float)
    learn = bool(sample.vx >= config.min_speed)
    if not math.isnan(sample.vy):
        x[:, State.VY] = sample.vy  # measured (GPSSMConfig.vy_source)
    if not learn:
        x[:, State.VY] = 0.0  # (nearly) at rest: no lateral sliding
    # 2. slips and features
    alpha_f, alpha_r = slip_angles(x[:, State.VY], x[:, State.YAW_RATE], sample.steer,
                                   regularised_speed(float(sample.vx), veh.v_eps), veh)
    af_h, ar_h = held(config, alpha_f), held(config, alpha_r)
    phi = b.features(af_h, ar_h)  # (N, G, m)
    mu_prior = np.stack([config.prior_tire.mu(af_h), config.prior_tire.mu(ar_h)], axis=1)

    ratio = manifold_ratio(state)
    fpk_g = peak_rhs(ctx, ratio, state.peak_alpha)  # (G, m, np)
    where = axle_rows(config)
    # right-hand sides: phi, Psi^T, peak features of the groups
    rp = np.broadcast_to(fpk_g[None], (N, *fpk_g.shape))
    R = np.concatenate([phi[..., None], np.swapaxes(Psi, -1, -2), rp], axis=-1)
    X, pb_phi = la.solve(lin, R, n_exact=1 + d)
    uvec = X[..., 0]                      # H^{-1} phi          (N, G, m)
    s = np.einsum("ngm,ngm->ng", phi, uvec)
    PPsiT = X[..., 1:1 + d]               # H^{-1} Psi^T        (N, G, m, d)
    Ppk = X[..., 1 + d:]                  # H^{-1} phi_peak     (N, G, m, np)

    # 3. predictive (eq. 32) and sample
    loc = np.einsum("ngdm,ngm->ngd", Psi, uvec)
    Lam_star = config.Lambda0 + Phi - np.einsum("ngdm,ngme->ngde", Psi, PPsiT)
    Lam_star = sym_pd(Lam_star, 1e-12)
    dof = nu - d + 1.0
    scale = Lam_star * ((1.0 + s) / dof)[..., None, None]
    # eq. 8 with each particle's accelerometer gain: ay = c_ay . mu (below the gate the
    # weighted mean gain of the step's start, GPSSMConfig.ay_gain_gate: state.x and
    # state.logw are still the previous step's)
    if abs(sample.ay) >= config.ay_gain_gate:
        k = x[:, State.AY_GAIN]
    else:
        k = np.full(N, float(np.exp(state.logw) @ state.x[:, State.AY_GAIN]))
    c_ay = k[:, None] * np.array(ay_gains(math.cos(sample.steer), veh))[None]
    r_pred = x[:, State.YAW_RATE]
    sigma_ay = step_sigma_ay(ctx, state.guard)
    if config.proposal == "prior":
        # bootstrap proposal (eq. 22): zeta from the predictive, weight by y_k
        zeta = _student_t(rng, loc, scale, dof)
        mu = mu_prior + _zeta_to_axles(config, zeta)
        ay_pred = np.einsum("nj,nj->n", mu, c_ay)
        loglik = -0.5 * ((sample.ay - ay_pred) / sigma_ay) ** 2
    else:
        zeta, loglik = _conditional_sample(ctx, rng, loc, scale, dof, mu_prior, c_ay, sample.ay, sigma_ay)
        mu = mu_prior + _zeta_to_axles(config, zeta)
    loglik = loglik - 0.5 * ((sample.yaw_rate - r_pred) / ctx.sigma_yaw_rate) ** 2

    # 4. weights (eq. 21-22)
    logw = state.logw + loglik
    logw -= logw.max()
    w = np.exp(logw)
    w /= w.sum()
    ess = float(1.0 / np.sum(w * w))

    fpk_g = rp[0]  # (G, m, np)
    if learn:
        # 5. data update (eq. 28)
        lin = la.update(lin, phi, pb_phi)
        e = zeta - loc
        Psi += zeta[..., :, None] * phi[..., None, :]
        Phi += zeta[..., :, None] * zeta[..., None, :]
        nu = nu + 1.0
        # posterior quantities by Sherman-Morrison on the predictive ones
        inv1s = 1.0 / (1.0 + s)
        MT = PPsiT + uvec[..., None] * zeta[..., None, :]
        MT -= uvec[..., None] * ((loc + zeta * s[..., None]) * inv1s[..., None])[..., None, :]
        Lam_post = sym_pd(Lam_star + e[..., :, None] * e[..., None, :] * inv1s[..., None, None], 1e-12)
        # f^T (H + phi phi^T)^{-1} f = f^T H^{-1} f - (f^T H^{-1} phi)^2 / (1 + s)
        upk = np.einsum("gmp,ngm->ngp", fpk_g, uvec)
        vpk = np.einsum("gmp,ngmp->ngp", fpk_g, Ppk) - upk**2 * inv1s[..., None]  # (N, G, np)
    else:
        # below min_speed the slip angles carry no friction information: no update
        MT, Lam_post = PPsiT.copy(), Lam_star
        vpk = np.einsum("gmp,ngmp->ngp", fpk_g, Ppk)

    # 6. estimates (Algorithm 1 lines 11-12) with the normalised weights
    xm = w @ x
    xs = np.sqrt(np.maximum(w @ (x - xm) ** 2, 0.0))
    af_m, ar_m = float(w @ alpha_f), float(w @ alpha_r)
    mu_now = w @ (mu_prior + _zeta_mean(config, MT, phi))
    visits, moments, excited = slip_statistics(config, state, af_m, ar_m, learn)

    peak = peak_estimates(config, ratio, MT, Lam_post, nu, w, vpk, visits, where)

    resampled = ess <= config.ess_threshold * N
    idx = systematic(rng, w) if resampled else None
    new = GPSSMState(
        k=state.k + 1,
        t=float(sample.t), u=u, x=x, mu=mu, logw=np.log(np.maximum(w, 1e-300)), lin=lin,
        Psi=Psi, Phi=Phi, nu=float(nu), visits=visits, slip_moments=moments,
        peak_alpha=np.array([peak["alpha"], peak["alpha_band"]]),
        rng=rng, M=None if state.M is None else np.ascontiguousarray(np.swapaxes(MT, -1, -2)),
        Lam=None if state.M is None else Lam_post, guard=state.guard,
    )
    if idx is not None:
        new = resample(new, idx)
    est = GPSSMEstimate(
        t=float(sample.t),
        vy=float(xm[State.VY]), vy_std=float(xs[State.VY]),
        yaw_rate=float(xm[State.YAW_RATE]), yaw_rate_std=float(xs[State.YAW_RATE]),
        ay_gain=float(xm[State.AY_GAIN]),
        alpha_f=af_m, alpha_r=ar_m,
        mu_now_front=float(mu_now[0]), mu_now_rear=float(mu_now[1]),
        mu_front=peak["mu"][0], mu_rear=peak["mu"][1],
        mu_front_lower=peak["lo"][0], mu_front_upper=peak["hi"][0],
        mu_rear_lower=peak["lo"][1], mu_rear_upper=peak["hi"][1],
        peak_alpha_front=peak["alpha"][0], peak_alpha_rear=peak["alpha"][1],
        peak_observed_front=peak["obs"][0], peak_observed_rear=peak["obs"][1],
        excited=excited, ess=ess, resampled=bool(resampled),
    )
    return new, guard_step(ctx, new, est, sample, dt_step)




def _conditional_sample(
    ctx: Context, rng: np.random.Generator, loc: NDArray, scale: NDArray, dof: float,
    mu_prior: NDArray, c_ay: NDArray, ay: float, sigma_ay: float,
) -> tuple[NDArray, NDArray]:
    """Draw ``zeta`` from its predictive conditioned on the lateral acceleration.

    The Student-t predictive is the scale mixture ``zeta | g ~ N(loc, scale dof / g)``,
    ``g ~ chi²(dof)``. ``g`` is drawn from its prior and, given ``g``, ``ay = c (mu_prior
    + zeta) + e`` (eq. 8, ``c = c_ay``) is linear-Gaussian in ``zeta``, so ``zeta`` is
    drawn from its exact Gaussian conditional. The importance weight of this proposal
    (eq. 21) is the predictive density ``N(ay; c (mu_prior + loc), c S c^T + sigma_ay²)``.
    (The separable basis draws one ``g`` per axle.)

    Returns ``zeta`` (N, G, d) and the log weight factor (N,).
    """
    config = ctx.config
    N = loc.shape[0]
    g = rng.chisquare(dof, size=loc.shape[:2])  # (N, G)
    Sg = scale * (dof / g)[..., None, None]      # (N, G, d, d)
    if config.basis.kind == "tensor":
        m0, S = loc[:, 0, :], Sg[:, 0]
    else:
        m0 = loc[:, :, 0]
        S = np.zeros((N, 2, 2))
        S[:, 0, 0] = Sg[:, 0, 0, 0]
        S[:, 1, 1] = Sg[:, 1, 0, 0]
    c = np.broadcast_to(c_ay, (N, 2))
    v = ay - np.einsum("nj,nj->n", c, mu_prior + m0)
    Sc = np.einsum("nij,nj->ni", S, c)
    sy = np.einsum("ni,ni->n", c, Sc) + sigma_ay**2
    K = Sc / sy[:, None]
    mean = m0 + K * v[:, None]
    cov = S - K[:, :, None] * Sc[:, None, :]
    cov = sym_pd(cov, 1e-18)
    # 2x2 Cholesky (cov is PSD of rank >= 1)
    l00 = np.sqrt(np.maximum(cov[:, 0, 0], 0.0))
    l10 = np.where(l00 > 0, cov[:, 1, 0] / np.where(l00 > 0, l00, 1.0), 0.0)
    l11 = np.sqrt(np.maximum(cov[:, 1, 1] - l10**2, 0.0))
    z = rng.standard_normal((N, 2))
    za = mean + np.stack([l00 * z[:, 0], l10 * z[:, 0] + l11 * z[:, 1]], axis=1)
    loglik = -0.5 * v**2 / sy - 0.5 * np.log(sy)
    if config.basis.kind == "tensor":
        return za[:, None, :], loglik
    return za[:, :, None], loglik


def _zeta_mean(config: GPSSMConfig, MT: NDArray, phi: NDArray) -> NDArray:
    """Posterior mean ``M phi`` per particle mapped to axles, (N, 2)."""
    z = np.einsum("ngmd,ngm->ngd", MT, phi)
    return _zeta_to_axles(config, z)



def _zeta_to_axles(config: GPSSMConfig, zeta: NDArray) -> NDArray:
    """(N, G, d) -> (N, 2) front/rear."""
    if config.basis.kind == "tensor":
        return zeta[:, 0, :]
    return zeta[:, :, 0]



def _student_t(rng: np.random.Generator, loc: NDArray, scale: NDArray, dof: float) -> NDArray:
    """Multivariate t draws; ``loc`` (..., d), ``scale`` (..., d, d) SPD."""
    d = loc.shape[-1]
    z = rng.standard_normal(loc.shape)
    g = rng.chisquare(dof, size=loc.shape[:-1])
    if d == 1:
        dev = np.sqrt(scale[..., 0, 0])[..., None] * z
    else:
        L = np.linalg.cholesky(scale)
        dev = np.einsum("...ij,...j->...i", L, z)
    return loc + dev * np.sqrt(dof / g)[..., None]
