"""State of the GP-SSM filter, its set-up for a drive, and the particle bookkeeping.

Notation: ``N`` particles, ``G`` basis groups (1 tensor, 2 separable), ``d`` outputs per
group (2 tensor, 1 separable), ``m`` features per group.
"""

from __future__ import annotations

import copy
import math
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY
from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.gpssm.config import GPSSMConfig
from roadgrip.estimators.gpssm.guard import Guard
from roadgrip.estimators.gpssm.inputs import Sample
from roadgrip.estimators.gpssm.model import State, VehicleConstants, vehicle_constants
from roadgrip.vehicle.params import VehicleParams, axle_loads

GAIN_MIN, GAIN_MAX = 0.5, 2.0
"""Range of the accelerometer gain [-] (``State.AY_GAIN``)."""

__all__ = ["GAIN_MAX", "GAIN_MIN", "Context", "GPSSMEstimate", "GPSSMState", "copy_state", "init_state", "resample"]


class Context:
    """What a filter run fixes: configuration, vehicle and the measurement noise.

    With ``substeps = k`` interpolated steps per recorded sample
    (:func:`~roadgrip.estimators.gpssm.inputs.upsample_inputs`) each recorded sample is
    processed ``k`` times, so its information is spread over them: the noise levels are
    ``sigma * sqrt(k)``. The configuration itself is left as given. The context also
    caches the packed constants of the compiled step (:attr:`kernel`).

    Parameters
    ----------
    config : GPSSMConfig
    vehicle : VehicleParams
    substeps : int
    """

    __slots__ = ("config", "gain_mean", "gain_sigma", "gain_walk", "kernel", "noise_scale", "sigma_ay", "sigma_yaw_rate", "substeps",
                 "veh", "vehicle")

    def __init__(self, config: GPSSMConfig, vehicle: VehicleParams, substeps: int = 1) -> None:
        if int(substeps) != substeps or substeps < 1:
            raise ValueError(f"substeps must be an integer >= 1, got {substeps!r}")
        self.config = config
        self.vehicle = vehicle
        self.substeps = int(substeps)
        self.veh: VehicleConstants = vehicle_constants(vehicle)
        self.sigma_ay = config.sigma_ay
        self.sigma_yaw_rate = config.sigma_yaw_rate
        if substeps > 1:
            self.sigma_ay *= math.sqrt(substeps)
            self.sigma_yaw_rate *= math.sqrt(substeps)
        # the accelerometer gain is learned from an accelerometer only (not from r vx + dvy/dt)
        imu = config.ay_source == "imu"
        self.gain_sigma = config.ay_gain_sigma if imu else 0.0
        self.gain_walk = config.ay_gain_walk if (imu and config.ay_gain_sigma > 0.0) else 0.0
        # the gain's prior mean: 1, or the vehicle's 1 + g roll_gradient (a fitted file's gain)
        self.gain_mean = 1.0
        if imu and config.ay_gain_prior == "vehicle":
            self.gain_mean = float(np.clip(1.0 + GRAVITY * vehicle.roll_gradient, GAIN_MIN, GAIN_MAX))
        # the accelerometer's running noise level (guard.step_sigma_ay), over the sub-steps
        self.noise_scale = math.sqrt(self.substeps) if (imu and config.ay_noise == "running") else 0.0
        self.kernel: dict[str, Any] = {}

    def step_vehicle(self, sample: Sample) -> VehicleConstants:
        """The vehicle constants of a step: the axle loads with the longitudinal load
        transfer of the measured ``sample.ax`` (``GPSSMConfig.axle_loads = 'dynamic'``,
        :func:`roadgrip.vehicle.params.axle_loads`), else the static ones."""
        if self.config.axle_loads != "dynamic" or not math.isfinite(sample.ax):
            return self.veh
        fzf, fzr = axle_loads(self.vehicle, float(sample.ax))
        return self.veh._replace(fz_front=float(fzf), fz_rear=float(fzr))

    def gain_steps(self, rng: np.random.Generator, dt: float) -> NDArray:
        """Random-walk increments of the particles' accelerometer gains over ``dt`` [s],
        shape (N,) (zeros, and no draw, when the gain is fixed)."""
        N = self.config.particles
        if self.gain_walk == 0.0:
            return np.zeros(N)
        return self.gain_walk * math.sqrt(dt) * rng.standard_normal(N)

    def __repr__(self) -> str:
        return f"Context({self.config!r}, {self.vehicle.name!r}, substeps={self.substeps})"


class GPSSMState(NamedTuple):
    """Filter state after a step. Arrays are owned by the state and reused (overwritten)
    by the next :func:`~roadgrip.estimators.gpssm.stepping.step`; :func:`copy_state` keeps one.

    Attributes
    ----------
    k : int
        Steps taken.
    t : float
        Time of the last sample [s].
    u : ndarray, shape (Input.SIZE,)
        Last input ``[steer, vx]`` (:class:`~roadgrip.estimators.gpssm.model.Input`).
    x : ndarray, shape (N, State.SIZE)
        Particle states ``[vy, yaw_rate, ay_gain]`` at ``t`` (:class:`~roadgrip.estimators.gpssm.model.State`).
    mu : ndarray, shape (N, 2)
        Each particle's friction sample at ``t`` (drives the next propagation).
    logw : ndarray, shape (N,)
        Normalised log weights.
    lin : LinAlgState
        Information matrices ``Sigma + I`` (eq. 28b).
    Psi : ndarray, shape (N, G, d, m)
    Phi : ndarray, shape (N, G, d, d)
    nu : float
        Common degrees of freedom (eq. 28f, 29d).
    visits : ndarray, shape (2, n_bins)
        Histogram of ``|alpha|`` of the state estimate, per axle.
    slip_moments : ndarray, shape (2,)
        ``[sum alpha_f², sum alpha_f alpha_r]`` (tensor-basis manifold ratio).
    peak_alpha : ndarray, shape (2, 2)
        Row 0: argmax of the last posterior mean curve, per axle [rad]; row 1: the slip
        angle of the reported peak (the argmax inside the visited range while the peak is
        not observed). The peak band uses the function variance at both (the lower band
        of an unobserved peak the larger one).
    rng : numpy.random.Generator
        The filter's random stream (advanced in place by :func:`step`, like the other
        buffers).
    M, Lam : ndarray, shape (N, G, d, m) and (N, G, d, d), or None
        ``'fast'`` mode: each particle's posterior ``M = Psi P_B`` and ``Lambda = Lambda0
        + Phi - M Psi^T`` (eq. 28 with ``Sigma + c I`` for ``Sigma + I``,
        :mod:`roadgrip.estimators.gpssm.linalg`), carried by the compiled step instead of
        solved for; None in the other modes.
    guard : Guard
        Bookkeeping of the honesty checks (:mod:`roadgrip.estimators.gpssm.guard`).
    """

    k: int
    t: float
    u: NDArray
    x: NDArray
    mu: NDArray
    logw: NDArray
    lin: la.LinAlgState
    Psi: NDArray
    Phi: NDArray
    nu: float
    visits: NDArray
    slip_moments: NDArray
    peak_alpha: NDArray
    rng: np.random.Generator
    M: NDArray | None = None
    Lam: NDArray | None = None
    guard: Guard | None = None


class GPSSMEstimate(NamedTuple):
    """Estimates after one step (scalars unless noted)."""

    t: float
    vy: float
    vy_std: float
    yaw_rate: float
    yaw_rate_std: float
    ay_gain: float
    alpha_f: float
    alpha_r: float
    mu_now_front: float
    mu_now_rear: float
    mu_front: float
    mu_rear: float
    mu_front_lower: float
    mu_front_upper: float
    mu_rear_lower: float
    mu_rear_upper: float
    peak_alpha_front: float
    peak_alpha_rear: float
    peak_observed_front: bool
    peak_observed_rear: bool
    excited: bool
    ess: float
    resampled: bool
    diverged: bool = False
    floor: float = 0.0
    collapsed: bool = False



def n_bins(config: GPSSMConfig) -> int:
    return math.ceil(config.basis.L / config.bin_width)


def manifold_ratio(state: GPSSMState) -> float:
    sxx, sxy = state.slip_moments
    if sxx <= 1e-10:
        return 1.0
    return float(np.clip(sxy / sxx, 0.2, 5.0))



def systematic(rng: np.random.Generator, w: NDArray) -> NDArray:
    n = len(w)
    pos = (rng.random() + np.arange(n)) / n
    c = np.cumsum(w)
    c[-1] = 1.0
    return np.searchsorted(c, pos)



def sym_pd(S: NDArray, floor: float) -> NDArray:
    """Symmetrise a (..., d, d) stack and keep its diagonal above ``floor``."""
    S = 0.5 * (S + np.swapaxes(S, -1, -2))
    d = S.shape[-1]
    idx = np.arange(d)
    S[..., idx, idx] = np.maximum(S[..., idx, idx], floor)
    if d == 2:
        # 2x2 PD: |off| < sqrt(a b)
        lim = np.sqrt(S[..., 0, 0] * S[..., 1, 1]) * (1.0 - 1e-9)
        off = np.clip(S[..., 0, 1], -lim, lim)
        S[..., 0, 1] = off
        S[..., 1, 0] = off
    return S



def init_state(ctx: Context, sample: Sample, seed: int = 0) -> GPSSMState:
    """Prior state at the first sample (Algorithm 1, 'Initialize')."""
    config = ctx.config
    b = config.basis
    N, G, d, m = config.particles, b.groups, b.outputs, b.m
    rng = np.random.default_rng(seed)
    x = np.empty((N, State.SIZE))
    x[:, State.VY] = config.sigma_vy0 * rng.standard_normal(N)
    x[:, State.YAW_RATE] = sample.yaw_rate + ctx.sigma_yaw_rate * rng.standard_normal(N)
    x[:, State.AY_GAIN] = ctx.gain_mean
    if ctx.gain_sigma > 0.0:
        x[:, State.AY_GAIN] = np.clip(ctx.gain_mean + ctx.gain_sigma * rng.standard_normal(N), GAIN_MIN, GAIN_MAX)
    return GPSSMState(
        k=0,
        t=float(sample.t),
        u=np.array([sample.steer, sample.vx], dtype=float),
        x=x,
        mu=np.zeros((N, 2)),
        logw=np.full(N, -math.log(N)),
        lin=la.init(config.linalg, N, G, m, history=config.refactor_every),
        Psi=np.zeros((N, G, d, m)),
        Phi=np.zeros((N, G, d, d)),
        nu=float(config.nu0),
        visits=np.zeros((2, n_bins(config)), dtype=np.int64),
        slip_moments=np.zeros(2),
        peak_alpha=np.full((2, 2), config.prior_tire.peak()[0]),
        rng=rng,
        M=np.zeros((N, G, d, m)) if config.linalg == "fast" else None,
        Lam=np.broadcast_to(config.Lambda0, (N, G, d, d)).copy() if config.linalg == "fast" else None,
        guard=Guard(),
    )


def check_sample(sample: Sample) -> None:
    """Raise ``ValueError`` naming the non-finite inputs of a sample (``vy``, ``ax`` may be NaN)."""
    vals = (sample.t, sample.ay, sample.yaw_rate, sample.steer, sample.vx)
    if not all(map(math.isfinite, vals)) or math.isinf(sample.vy) or math.isinf(sample.ax):
        names = [n for n, v in zip(Sample._fields[:7], [*vals, sample.vy, sample.ax], strict=True)
                 if not np.isfinite(v) and not (n in ("vy", "ax") and math.isnan(v))]
        raise ValueError(f"GP-SSM sample at t = {sample.t} has non-finite input(s) {names}")



def slip_statistics(
    config: GPSSMConfig, state: GPSSMState, af_m: float, ar_m: float, learn: bool
) -> tuple[NDArray, NDArray, bool]:
    """Histogram of ``|alpha|`` (updated in place), slip moments and the excitation flag
    after a step with estimated slip angles ``af_m``, ``ar_m`` [rad]."""
    visits = state.visits
    nb = visits.shape[1]
    if learn:
        for ax, a_ in enumerate((af_m, ar_m)):
            visits[ax, min(int(abs(a_) / config.bin_width), nb - 1)] += 1
    moments = state.slip_moments + learn * np.array([af_m * af_m, af_m * ar_m])
    excited = learn and bool(max(abs(af_m), abs(ar_m)) > config.excitation_slip)
    return visits, moments, excited


def visited_range(config: GPSSMConfig, visits: NDArray) -> float:
    """Largest ``|alpha|`` [rad] up to which the histogram of one axle has a bin with at
    least ``peak_visits`` samples (its upper edge); 0 when none has."""
    hit = visits[::-1] >= config.peak_visits
    top = int(hit.argmax())
    return float((len(visits) - top) * config.bin_width) if hit[top] else 0.0



def resample(state: GPSSMState, idx: NDArray) -> GPSSMState:
    """Particles ``idx`` with equal weights; every particle keeps its own statistics.

    The state ``x``, friction sample ``mu``, information matrix, ``Psi`` and ``Phi`` of
    new particle ``i`` are those of old particle ``idx[i]`` (Algorithm 1, line 9).
    The matrix buffers of ``state`` are reused (moved in place for sorted ``idx``); pass
    :func:`copy_state` of it if the old state is still needed.
    """
    idx = np.asarray(idx)
    n = len(state.logw)
    if idx.shape != (n,) or idx.min() < 0 or idx.max() >= n:
        raise ValueError(f"resampling indices must be {n} integers in [0, {n})")
    return state._replace(
        x=state.x[idx], mu=state.mu[idx], lin=la.take(state.lin, idx),
        Psi=la.take_rows(state.Psi, idx), Phi=la.take_rows(state.Phi, idx),
        logw=np.full(n, -math.log(n)), M=None if state.M is None else la.take_rows(state.M, idx),
        Lam=None if state.Lam is None else la.take_rows(state.Lam, idx),
    )


def copy_state(state: GPSSMState) -> GPSSMState:
    """A deep copy (``step`` reuses the arrays of its input state)."""
    return state._replace(
        u=state.u.copy(), x=state.x.copy(), mu=state.mu.copy(), logw=state.logw.copy(),
        lin=la.copy(state.lin), Psi=state.Psi.copy(), Phi=state.Phi.copy(),
        visits=state.visits.copy(), slip_moments=state.slip_moments.copy(),
        peak_alpha=state.peak_alpha.copy(), rng=copy.deepcopy(state.rng),
        M=None if state.M is None else state.M.copy(), Lam=None if state.Lam is None else state.Lam.copy(),
        guard=None if state.guard is None else state.guard.copy(),
    )
