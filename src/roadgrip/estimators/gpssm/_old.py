r"""GP-SSM particle filter: online Bayesian learning of the tire-friction curve (paper 000).

Berntorp's Algorithm 1: a particle filter over the lateral state ``x = [vy, yaw_rate]``
in which every particle carries its own reduced-rank GP posterior of the friction
function ``mu(alpha)`` as matrix-normal inverse-Wishart (MNIW) sufficient statistics.

Model
-----
State transition (eq. 7) and measurement (eq. 8), :mod:`roadgrip.vehicle.lateral`::

    x[k+1] = a(x_k, u_k) + G(x_k, u_k) mu_k,     y_k = h(x_k, u_k) + D(x_k, u_k) mu_k + e_k

with ``u = [steer, vx]``, ``y = [ay, yaw_rate]``, ``e ~ N(0, R)``, ``R = diag(sigma_ay²,
sigma_yaw_rate²)`` (configuration values, not read from the data). The axle friction is

    mu_k = mu_prior(alpha_k) + A phi(alpha_k) + w_k,   w_k ~ N(0, Q)

(eq. 14 with ``zeta_{k+1} = G^{-1}(x_{k+1} - a) - mu_prior(alpha_k)``), where
``mu_prior`` is a low-friction Magic Formula (paper Sec. 4) and ``phi`` a Hilbert-space
basis (:mod:`roadgrip.inference.basis`). ``A`` and ``Q`` have the MNIW prior of eq. 24.

Sign convention: ``alpha`` is the ISO slip angle of :mod:`roadgrip.vehicle.slip`
(``alpha = -arctan(v_y,w / v_x,w)``); positive ``alpha`` gives positive (leftward) ``mu``,
as in the paper.

Kernel scale
------------
In the MNIW prior the covariance of the weights is ``Q`` (row) times ``V`` (column), so the
GP prior variance of ``A phi`` at a point is ``Q_nn * s_f`` (times the fraction of the
kernel captured by the truncated basis). ``Q`` is in friction units squared, so ``s_f`` is
a dimensionless ratio; with the paper's ``s_f = 500`` and the prior noise level
``sigma_w0 = 0.02`` the prior standard deviation of the friction deviation is about
``0.02 * sqrt(500 * 0.5) = 0.32`` for the 10 x 10 basis (which captures about half of the
SE kernel's variance at ``ell = 2 deg``): wide enough to cover every road surface from ice
to dry asphalt around the 0.05-peak prior mean.

Filter (Algorithm 1), one step at time ``t_k``
----------------------------------------------
1. Propagate ``x_k^i = a + G mu_{k-1}^i`` with ``dt = t_k - t_{k-1}`` (eq. 7) and apply
   the forgetting time update to the statistics (eq. 29).
2. Slip angles ``alpha_k^i`` and features ``phi(alpha_k^i)``.
3. Sample ``zeta^i`` from the MNIW predictive (eq. 31-32; multivariate Student-t with
   ``nu - d + 1`` degrees of freedom). ``A`` enters the step only through ``A phi``, so
   the exact marginal of ``A phi + w`` is sampled instead of the full matrix ``A`` (same
   distribution of ``x_{k+1}``, ``O(m²)`` instead of ``O(m³)``);
   :func:`roadgrip.estimators.mniw.sample_matrix_t` draws whole matrices.
4. Weights (eq. 22): ``q^i *= N(y_k; h + D mu_k^i, R)`` where ``mu_k^i = mu_prior +
   zeta^i`` is the particle's own friction sample, the same that drives ``x_{k+1}``.
5. Data update of the statistics with ``(phi, zeta)`` (eq. 28).
6. Estimates (lines 11-12) with the normalised weights; resampling (systematic) when the
   effective sample size falls below ``ess_threshold * N``; statistics travel with their
   particles.

Separable basis, kept conjugate
-------------------------------
``basis='separable:n'`` uses ``n`` functions of ``alpha_f`` for the front axle and ``n`` of
``alpha_r`` for the rear. A matrix-normal prior shares one column covariance between the
rows, so it cannot zero the cross terms while staying conjugate. Here ``Q`` is taken
diagonal and each axle gets its own MNIW model with ``d = 1`` (a normal-inverse-gamma
model): ``zeta_f = a_f^T phi(alpha_f) + w_f``, ``zeta_r = a_r^T phi(alpha_r) + w_r`` with
independent ``w_f, w_r``. Each is exactly conjugate; the two share nothing but the
particle's state trajectory.

Odd-symmetric bases
-------------------
``tensor-odd:n x n`` and ``separable-odd:n`` keep only the basis functions that are odd in
the slip angles (:func:`roadgrip.inference.basis.make_basis`): ``mu(-alpha) =
-mu(alpha)``, a left-right symmetric vehicle. The lateral velocity is observed only through
the consistency of the learned curve; with an unconstrained basis a bias in ``vy`` shifts
both turning directions the same way and is absorbed by a shifted curve, with the odd
basis it is not. On the simulated snow drive this takes the ``vy`` error from about
0.06 m/s to 0.01 m/s and the curve error from 0.01-0.04 to below 0.005.

Practicalities
--------------
``vx`` comes from the non-driven wheels, the ``vx`` column or the pose
(``GPSSMConfig.vx_source``, :func:`drive_vx`). Below ``min_speed`` the statistics are
frozen. Data slower than ``max_dt`` are interpolated onto sub-steps
(:func:`upsample_inputs`). :data:`DART_OPTIONS` holds the settings used for the DART
JetRacer recordings.

Outputs
-------
Friction curves are reported for the odd part ``(mu(alpha) - mu(-alpha)) / 2`` on
``alpha >= 0`` for the peak (so both turning directions pool), and on any slip grid for the
curves. For the tensor basis the front curve is evaluated along the data manifold
``alpha_r = c alpha_f`` with ``c`` the running least-squares ratio of the estimated slips
(and the rear curve along ``alpha_f = alpha_r / c``). Each particle's function posterior is
Student-t; the curve band is the 95 % interval of the particle mixture (quantiles of the
mixture of t's); the per-step peak band uses the mixture's mean and variance. The peak is
*observed* when the slip histogram reached at least one length scale past the argmax of the
posterior mean curve with ``peak_visits`` samples; otherwise ``mu_*`` is the highest
friction demonstrated inside the visited range, a lower bound, ``mu_*_lower`` its lower
band and ``mu_*_upper`` the upper band of the unrestricted peak.

Notation: ``N`` particles, ``G`` basis groups (1 tensor, 2 separable), ``d`` outputs per
group (2 tensor, 1 separable), ``m`` features per group.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass, field, replace
from functools import lru_cache
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.blas_threads import one_blas_thread
from roadgrip.constants import V_EPS
from roadgrip.estimators import gpssm_kernel as gk
from roadgrip.estimators import gpssm_linalg as la
from roadgrip.estimators.base import EstimateRequest, EstimateResult, conform, timed
from roadgrip.inference.basis import SeparableBasis, TensorBasis, make_basis
from roadgrip.inference.kinematic import kinematic_lateral_acceleration
from roadgrip.tire import SURFACES, MagicFormula
from roadgrip.vehicle.lateral import LateralState, lateral_discrete, lateral_measurement
from roadgrip.vehicle.params import VehicleParams
from roadgrip.vehicle.slip import slip_angles

__all__ = [
    "AXLES",
    "DART_OPTIONS",
    "GPSSM",
    "CurvePosterior",
    "GPSSMConfig",
    "GPSSMEstimate",
    "GPSSMState",
    "Sample",
    "curve_accuracy",
    "drive_inputs",
    "init",
    "posterior_curves",
    "resample",
    "run_cli",
    "step",
]

AXLES = ("front", "rear")
_Z95 = 1.959963984540054

DEFAULT_PRIOR_TIRE = SURFACES["ice"].lateral.with_peak(0.05)
"""Prior mean friction curve: the ice preset's shape scaled to a 0.05 peak (paper Sec. 4)."""


@dataclass(frozen=True)
class GPSSMConfig:
    """Hyperparameters of the GP-SSM filter (SI units).

    Attributes
    ----------
    vehicle : VehicleParams
    basis : TensorBasis or SeparableBasis
        Reduced-rank basis; default the paper's 10 x 10 tensor basis, SE kernel,
        ``s_f = 500``, ``L = 30 deg``, ``ell = 2 deg``.
    particles : int
        ``N``.
    forgetting : float
        ``lam`` in (0, 1] (eq. 29); memory about ``1 / (1 - lam)`` steps.
    nu0 : float
        Prior degrees of freedom of ``Q`` (eq. 24), ``> d + 1``.
    sigma_w0 : float
        Prior mean standard deviation of the friction process noise ``w`` [-]; sets
        ``Lambda_0 = sigma_w0² (nu0 - d - 1) I``.
    sigma_ay : float
        Lateral-acceleration noise std in ``R`` [m/s²].
    sigma_yaw_rate : float
        Yaw-rate noise std in ``R`` [rad/s].
    sigma_vy0 : float
        Initial lateral-velocity spread [m/s] (``vy_0 ~ N(0, sigma_vy0²)``).
    prior_tire : MagicFormula
        Prior mean ``mu_prior(alpha)`` on both axles.
    ess_threshold : float
        Resample when ``N_eff <= ess_threshold * N``.
    linalg : {'exact', 'fast', 'direct'}
        Backend of :mod:`roadgrip.estimators.gpssm_linalg`.
    refactor_every : int
        Steps between refactorisations (``'exact'``, ``'fast'``).
    peak_grid : int
        Points of the slip grid on ``[0, peak_range]`` used for the peak each step.
    peak_range : float
        Largest slip angle searched for the peak [rad]; capped at :attr:`alpha_limit`,
        past which the curve is flat by construction.
    bin_width : float
        Width of the slip-angle histogram bins [rad].
    peak_visits : int
        Samples per bin for a bin to count as visited (peak observability).
    excitation_slip : float
        ``excited`` when an estimated axle slip angle exceeds this [rad].
    proposal : {'conditional', 'prior'}
        ``'prior'``: the paper's bootstrap proposal (eq. 22). ``'conditional'``: the
        friction sample is drawn conditioned on the lateral acceleration, which is linear
        in it (the locally optimal proposal for that part of ``y``, eq. 20-21); see
        :func:`_conditional_sample`.
    min_speed : float
        Below this speed [m/s] the statistics are not updated (slip angles carry no
        friction information near standstill) and the lateral velocity is set to zero.
    vy_source : {'none', 'pose'}
        ``'pose'``: the lateral velocity is measured (the body-axis projection of the
        pose derivative, :func:`drive_vy`, e.g. from motion capture) and every particle
        takes it instead of its propagated value. The slip angles are then measured
        rather than inferred; the friction is learned from the lateral acceleration and
        the yaw dynamics against them.
    ay_source : {'imu', 'kinematic'}
        The lateral acceleration measured: the accelerometer, or ``r vx + dvy/dt`` from
        the gyro and the measured velocity (:func:`roadgrip.inference.kinematic.
        kinematic_lateral_acceleration`; needs ``vy_source='pose'``), which on a small car
        with a hobby-grade IMU and motion capture is about ten times less noisy.
    vx_source : {'auto', 'wheels', 'column', 'pose'}
        Where :meth:`GPSSM.run` takes the longitudinal speed from (:func:`drive_vx`).
    max_dt : float
        Longest Euler step [s] of :meth:`GPSSM.run`; slower data are interpolated
        (:func:`upsample_inputs`).
    slip_sigma : float
        Slip-angle uncertainty of the state estimate added to the curve band [rad]
        (:func:`posterior_curves`); about the error of the lateral-velocity estimate over
        the speed (0.05 m/s at 12 m/s is 0.24 deg on the simulated snow drive).
    curve_sigma_floor : float
        Standard deviation [-] added in quadrature to every particle's function posterior
        in the curve band and the peak band: the error of representing a tire curve with a
        truncated basis, which the posterior of the basis weights does not contain (a few
        thousandths for the Magic Formula with 20 functions per axle).
    max_sideslip : float or None
        Largest body sideslip angle ``|arctan(vy / vx)|`` [rad] a particle may take after
        the propagation; ``None`` for no bound. Where the data demand more lateral force
        than a particle's sampled curve gives (at and past the friction limit), nothing in
        eq. 7 pulls ``vy`` back: it integrates ``-vx r`` and runs away (hundreds of m/s on
        the DART recordings from the IMU alone). The other way into such a run-away, a
        slip past the basis domain, is closed by ``slip_limit``. A car that is not spinning
        out stays well inside the bound (:data:`DART_OPTIONS`).
    slip_limit : float or None
        Slip angle [rad] beyond which each axle's friction curve is held flat: the prior
        mean and the features are evaluated at ``±slip_limit`` for larger ``|alpha|``
        (:attr:`alpha_limit`). The basis functions all vanish at the domain boundary
        ``±L``, so without the limit a slip estimate past about ``L - ell`` meets the
        near-zero prior friction with no uncertainty left to sample: no particle can
        produce the measured lateral acceleration, nothing pulls ``vy`` back, and it runs
        away (5-8 m/s on the snow-slalom drives whose front slip reaches 32 deg). ``None``:
        ``L - 2 ell`` (26 deg for the paper's basis), where the prior variance of every
        basis is still that of the interior.
    peak_max : float
        Largest peak friction admitted [-] (as the cascade's ``mu_bounds``): the upper band
        of a peak that was not observed. Past the visited slip range the learned curve is
        the prior's, so the data bound the peak only from below; an upper band taken from
        that curve would state the weak prior's guess (on the dry-gravel-dry drive it put
        the dry peak below 0.82-0.91 against a true 1.0).
    """

    vehicle: VehicleParams
    basis: TensorBasis | SeparableBasis = field(default_factory=TensorBasis)
    particles: int = 200
    forgetting: float = 0.9998
    nu0: float = 10.0
    sigma_w0: float = 0.02
    sigma_ay: float = 0.15
    sigma_yaw_rate: float = 0.01
    sigma_vy0: float = 0.3
    prior_tire: MagicFormula = DEFAULT_PRIOR_TIRE
    ess_threshold: float = 0.5
    linalg: str = "exact"
    refactor_every: int = 80
    peak_grid: int = 41
    peak_range: float = math.radians(20.0)
    bin_width: float = math.radians(0.5)
    peak_visits: int = 10
    excitation_slip: float = math.radians(1.0)
    proposal: str = "conditional"
    max_dt: float = 0.04
    min_speed: float = 0.5
    vx_source: str = "auto"
    vy_source: str = "none"
    ay_source: str = "imu"
    slip_sigma: float = math.radians(0.25)
    curve_sigma_floor: float = 0.005
    max_sideslip: float | None = None
    slip_limit: float | None = None
    peak_max: float = 2.0

    def __post_init__(self) -> None:
        if not isinstance(self.vehicle, VehicleParams):
            raise ValueError("GPSSMConfig.vehicle must be a VehicleParams")
        if int(self.particles) != self.particles or self.particles < 2:
            raise ValueError(f"particles must be an integer >= 2, got {self.particles!r}")
        if not 0.0 < self.forgetting <= 1.0:
            raise ValueError(f"forgetting factor must be in (0, 1], got {self.forgetting!r}")
        d = self.basis.outputs
        if not self.nu0 > d + 1:
            raise ValueError(f"nu0 must exceed d + 1 = {d + 1}, got {self.nu0!r}")
        if self.max_sideslip is not None and not 0.0 < self.max_sideslip < math.pi / 2:
            raise ValueError(f"max_sideslip must be in (0, pi/2) rad or None, got {self.max_sideslip!r}")
        for name in ("sigma_w0", "sigma_ay", "sigma_yaw_rate", "sigma_vy0", "peak_range",
                     "bin_width", "slip_sigma", "curve_sigma_floor", "max_dt", "min_speed", "peak_max"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        if not 0.0 < self.ess_threshold <= 1.0:
            raise ValueError(f"ess_threshold must be in (0, 1], got {self.ess_threshold!r}")
        if self.linalg not in la.LINALG_MODES:
            raise ValueError(f"linalg must be one of {la.LINALG_MODES}, got {self.linalg!r}")
        if self.vy_source not in ("none", "pose"):
            raise ValueError(f"vy_source must be 'none' or 'pose', got {self.vy_source!r}")
        if self.ay_source not in ("imu", "kinematic"):
            raise ValueError(f"ay_source must be 'imu' or 'kinematic', got {self.ay_source!r}")
        if self.ay_source == "kinematic" and self.vy_source == "none":
            raise ValueError("ay_source='kinematic' needs a measured lateral velocity (vy_source='pose')")
        if self.vx_source not in ("auto", "wheels", "column", "pose"):
            raise ValueError(f"vx_source must be auto, wheels, column or pose, got {self.vx_source!r}")
        if self.proposal not in ("conditional", "prior"):
            raise ValueError(f"proposal must be 'conditional' or 'prior', got {self.proposal!r}")
        if self.refactor_every < 1 or self.peak_grid < 3 or self.peak_visits < 1:
            raise ValueError("refactor_every, peak_grid (>= 3) and peak_visits must be positive")
        if self.slip_limit is not None and not 0.0 < self.slip_limit <= self.basis.L:
            raise ValueError(f"slip_limit must be in (0, L = {self.basis.L:.4g}] rad or None, "
                             f"got {self.slip_limit!r}")

    @property
    def alpha_limit(self) -> float:
        """Slip angle [rad] beyond which the friction curve is held flat (``slip_limit``,
        default ``L - 2 ell``, at least ``L / 2``)."""
        if self.slip_limit is not None:
            return float(self.slip_limit)
        b = self.basis
        return float(max(b.L - 2.0 * b.ell, 0.5 * b.L))

    @property
    def Lambda0(self) -> NDArray[np.float64]:
        d = self.basis.outputs
        return self.sigma_w0**2 * (self.nu0 - d - 1.0) * np.eye(d)


CLI_DEFAULT_BASIS = "separable-odd:20"
"""Basis of ``roadgrip estimate --method gpssm`` without ``--basis``.

:class:`GPSSMConfig` defaults to the paper's ``tensor:10x10``; the command defaults to 20
odd functions per axle, which on the simulated snow drive learns the curves an order of
magnitude more accurately (the odd symmetry makes the lateral velocity identifiable) and
runs about ten times faster.
"""

DART_OPTIONS: dict[str, Any] = {
    "sigma_ay": 0.3,
    "sigma_yaw_rate": 0.05,
    "sigma_w0": 0.05,
    "nu0": 50.0,
    "max_dt": 0.02,
    "vx_source": "pose",
    "vy_source": "pose",
    "ay_source": "kinematic",
    "max_sideslip": math.radians(20.0),
}
"""Configuration overrides for the DART JetRacer recordings (``format='dart'``).

The recordings are steady turns in one direction at constant steering. From the IMU alone
a common shift of both axles' slip angles (the lateral velocity) is not identified by such
data, not even with an odd basis, and the learned peak then depends on the random seed
(0.23-0.65 on the rubbery floor over seeds 0-5). The motion-capture pose measures the
velocity, so these options take it:

* ``vy_source='pose'``: the lateral velocity, and with it the slip angles, is measured;
* ``ay_source='kinematic'``: the lateral acceleration ``r vx + dvy/dt`` from the gyro and
  the pose, whose noise on these files is 0.17-0.30 m/s² per sample against 2-3 m/s² for
  the hobby-grade accelerometer (``sigma_ay`` accordingly);
* ``vx_source='pose'``: the rear-driven encoder speed includes up to 30 % wheel spin.

The 10 Hz sensor rate is too slow for a forward-Euler step of this small, stiff car
(``max_dt``); a larger, firmer prior on the process noise (``sigma_w0``, ``nu0``) keeps the
filter from collapsing ``Q`` during the long standstill at the start of each file;
``max_sideslip`` (20 deg) bounds the lateral velocity of runs without a measured one (with
the low-friction prior mean, 0.05, the model's early lateral force is far below the
``m vx r`` the car produces, and ``vy`` would integrate the difference and run away).
:func:`run_cli` applies them to drives read with ``format='dart'``.
"""


class Sample(NamedTuple):
    """One time sample of the filter's inputs (SI units); ``vy`` is a measured lateral
    velocity (NaN: none, :attr:`GPSSMConfig.vy_source`)."""

    t: float
    ay: float
    yaw_rate: float
    steer: float
    vx: float
    vy: float = math.nan


class GPSSMState(NamedTuple):
    """Filter state after a step. Arrays are owned by the state and reused by :func:`step`.

    Attributes
    ----------
    k : int
        Steps taken.
    t : float
        Time of the last sample [s].
    u : ndarray, shape (2,)
        Last input ``[steer, vx]``.
    x : ndarray, shape (N, 2)
        Particle states ``[vy, yaw_rate]`` at ``t``.
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
        :mod:`roadgrip.estimators.gpssm_linalg`), carried by the compiled step instead of
        solved for; None in the other modes.
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


class GPSSMEstimate(NamedTuple):
    """Estimates after one step (scalars unless noted)."""

    t: float
    vy: float
    vy_std: float
    yaw_rate: float
    yaw_rate_std: float
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


# -------------------------------------------------------------------------------------
# helpers
# -------------------------------------------------------------------------------------
def _n_bins(config: GPSSMConfig) -> int:
    return math.ceil(config.basis.L / config.bin_width)


def _manifold_ratio(state: GPSSMState) -> float:
    sxx, sxy = state.slip_moments
    if sxx <= 1e-10:
        return 1.0
    return float(np.clip(sxy / sxx, 0.2, 5.0))


def _held(config: GPSSMConfig, alpha: ArrayLike) -> NDArray:
    """Slip angles [rad] at which the friction model is evaluated: ``alpha`` clipped to
    ``±config.alpha_limit`` (the curve is flat beyond; ``GPSSMConfig.slip_limit``)."""
    lim = config.alpha_limit
    return np.clip(np.asarray(alpha, dtype=float), -lim, lim)


def _axle_features(
    config: GPSSMConfig, ratio: float, alpha: NDArray
) -> tuple[NDArray, NDArray]:
    """Features of each axle's curve at ``alpha``: two arrays (n, m) and the (group, row).

    Returns ``feats`` of shape (2, n, m) and ``where`` of shape (2, 2) = (group, row).
    Each slip angle is held to ``±config.alpha_limit`` (:func:`_held`).
    """
    b = config.basis
    if b.kind == "tensor":
        ff = b.features(_held(config, alpha), _held(config, ratio * alpha))[..., 0, :]
        fr = b.features(_held(config, alpha / ratio), _held(config, alpha))[..., 0, :]
        return np.stack([ff, fr]), np.array([[0, 0], [0, 1]])
    alpha = _held(config, alpha)
    f = b.features(alpha, alpha)
    return np.stack([f[..., 0, :], f[..., 1, :]]), np.array([[0, 0], [1, 0]])


def _odd(config: GPSSMConfig, ratio: float, alpha: NDArray) -> tuple[NDArray, NDArray]:
    fp, where = _axle_features(config, ratio, alpha)
    fm, _ = _axle_features(config, ratio, -alpha)
    return 0.5 * (fp - fm), where


def _zeta_to_axles(config: GPSSMConfig, zeta: NDArray) -> NDArray:
    """(N, G, d) -> (N, 2) front/rear."""
    if config.basis.kind == "tensor":
        return zeta[:, 0, :]
    return zeta[:, :, 0]


def _systematic(rng: np.random.Generator, w: NDArray) -> NDArray:
    n = len(w)
    pos = (rng.random() + np.arange(n)) / n
    c = np.cumsum(w)
    c[-1] = 1.0
    return np.searchsorted(c, pos)


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


def _sym_pd(S: NDArray, floor: float) -> NDArray:
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


# -------------------------------------------------------------------------------------
# kernel
# -------------------------------------------------------------------------------------
def init(config: GPSSMConfig, sample: Sample, seed: int = 0) -> GPSSMState:
    """Prior state at the first sample (Algorithm 1, 'Initialize')."""
    b = config.basis
    N, G, d, m = config.particles, b.groups, b.outputs, b.m
    rng = np.random.default_rng(seed)
    x = np.empty((N, LateralState.SIZE))
    x[:, LateralState.VY] = config.sigma_vy0 * rng.standard_normal(N)
    x[:, LateralState.YAW_RATE] = sample.yaw_rate + config.sigma_yaw_rate * rng.standard_normal(N)
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
        visits=np.zeros((2, _n_bins(config)), dtype=np.int64),
        slip_moments=np.zeros(2),
        peak_alpha=np.full((2, 2), config.prior_tire.peak()[0]),
        rng=rng,
        M=np.zeros((N, G, d, m)) if config.linalg == "fast" else None,
        Lam=np.broadcast_to(config.Lambda0, (N, G, d, d)).copy() if config.linalg == "fast" else None,
    )


def _check_sample(sample: Sample) -> None:
    vals = (sample.t, sample.ay, sample.yaw_rate, sample.steer, sample.vx)
    if not all(map(math.isfinite, vals)) or math.isinf(sample.vy):
        names = [n for n, v in zip(Sample._fields, [*vals, sample.vy], strict=True)
                 if not np.isfinite(v) and not (n == "vy" and math.isnan(v))]
        raise ValueError(f"GP-SSM sample at t = {sample.t} has non-finite input(s) {names}")


def step(
    state: GPSSMState | None, sample: Sample, config: GPSSMConfig, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """One step of Algorithm 1 at ``sample.t``.

    Pure in the sense of a donated buffer: the returned state reuses (and overwrites) the
    arrays of ``state``; keep :func:`copy_state` of it if the old state is still needed.
    ``state=None`` initialises from ``sample`` with ``seed``.

    The ``'exact'`` and ``'fast'`` modes run the compiled per-particle kernel
    (:mod:`roadgrip.estimators.gpssm_kernel`); ``'direct'`` runs the NumPy reference
    implementation (:func:`step_reference`). Both draw the same random numbers.

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
        return _step(state, sample, config, seed)


def _step(
    state: GPSSMState | None, sample: Sample, config: GPSSMConfig, seed: int
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` without setting the BLAS threads (for loops that set them once)."""
    if config.linalg == "direct":
        return step_reference(state, sample, config, seed)
    return _step_compiled(state, sample, config, seed)


def step_reference(
    state: GPSSMState | None, sample: Sample, config: GPSSMConfig, seed: int = 0
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` with array operations over the particles (any ``linalg`` mode)."""
    _check_sample(sample)
    veh = config.vehicle
    b = config.basis
    lam = config.forgetting
    N, d = config.particles, b.outputs
    if state is None:
        state = init(config, sample, seed)
        x, lin, Psi, Phi, nu = state.x, state.lin, state.Psi, state.Phi, state.nu
    else:
        dt = sample.t - state.t
        if not dt > 0:
            raise ValueError(f"GP-SSM samples must have increasing time: {state.t} then {sample.t}")
        # 1. propagate (eq. 7) and forget (eq. 29)
        a, G = lateral_discrete(state.x, state.u, veh, dt)
        x = a + np.einsum("nij,nj->ni", G, state.mu)
        lin = la.forget(state.lin, lam, config.refactor_every)
        Psi = state.Psi
        Psi *= lam
        Phi = state.Phi
        Phi *= lam
        nu = lam * state.nu
    if config.max_sideslip is not None:
        # physical bound on the body sideslip angle (GPSSMConfig.max_sideslip)
        vy_max = math.tan(config.max_sideslip) * max(float(sample.vx), 0.0)
        np.clip(x[:, LateralState.VY], -vy_max, vy_max, out=x[:, LateralState.VY])
    rng = state.rng

    u = np.array([sample.steer, sample.vx], dtype=float)
    learn = bool(sample.vx >= config.min_speed)
    if not math.isnan(sample.vy):
        x[:, LateralState.VY] = sample.vy  # measured (GPSSMConfig.vy_source)
    if not learn:
        x[:, LateralState.VY] = 0.0  # (nearly) at rest: no lateral sliding
    # 2. slips and features
    alpha_f, alpha_r = slip_angles(sample.vx, x[:, LateralState.VY], x[:, LateralState.YAW_RATE],
                                   sample.steer, veh)
    af_h, ar_h = _held(config, alpha_f), _held(config, alpha_r)
    phi = b.features(af_h, ar_h)  # (N, G, m)
    mu_prior = np.stack([config.prior_tire.mu(af_h), config.prior_tire.mu(ar_h)], axis=1)

    ratio = _manifold_ratio(state)
    fpk_g = _peak_rhs(config, ratio, state.peak_alpha)  # (G, m, np)
    where = _axle_rows(config)
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
    Lam_star = _sym_pd(Lam_star, 1e-12)
    dof = nu - d + 1.0
    scale = Lam_star * ((1.0 + s) / dof)[..., None, None]
    h, D = lateral_measurement(x, u, veh)
    r_pred = x[:, LateralState.YAW_RATE]
    if config.proposal == "prior":
        # bootstrap proposal (eq. 22): zeta from the predictive, weight by y_k
        zeta = _student_t(rng, loc, scale, dof)
        mu = mu_prior + _zeta_to_axles(config, zeta)
        ay_pred = h[:, 0] + np.einsum("nj,nj->n", D[:, 0, :], mu)
        loglik = -0.5 * ((sample.ay - ay_pred) / config.sigma_ay) ** 2
    else:
        zeta, loglik = _conditional_sample(config, rng, loc, scale, dof, mu_prior, h, D, sample.ay)
        mu = mu_prior + _zeta_to_axles(config, zeta)
    loglik = loglik - 0.5 * ((sample.yaw_rate - r_pred) / config.sigma_yaw_rate) ** 2

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
        Lam_post = _sym_pd(Lam_star + e[..., :, None] * e[..., None, :] * inv1s[..., None, None], 1e-12)
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
    visits, moments, excited = _slip_statistics(config, state, af_m, ar_m, learn)

    peak = _peak_estimates(config, ratio, MT, Lam_post, nu, w, vpk, visits, where)

    resampled = ess <= config.ess_threshold * N
    idx = _systematic(rng, w) if resampled else None
    new = GPSSMState(
        k=state.k + 1,
        t=float(sample.t), u=u, x=x, mu=mu, logw=np.log(np.maximum(w, 1e-300)), lin=lin,
        Psi=Psi, Phi=Phi, nu=float(nu), visits=visits, slip_moments=moments,
        peak_alpha=np.array([peak["alpha"], peak["alpha_band"]]),
        rng=rng, M=None if state.M is None else np.ascontiguousarray(np.swapaxes(MT, -1, -2)),
        Lam=None if state.M is None else Lam_post,
    )
    if idx is not None:
        new = resample(new, idx)
    est = GPSSMEstimate(
        t=float(sample.t),
        vy=float(xm[LateralState.VY]), vy_std=float(xs[LateralState.VY]),
        yaw_rate=float(xm[LateralState.YAW_RATE]), yaw_rate_std=float(xs[LateralState.YAW_RATE]),
        alpha_f=af_m, alpha_r=ar_m,
        mu_now_front=float(mu_now[0]), mu_now_rear=float(mu_now[1]),
        mu_front=peak["mu"][0], mu_rear=peak["mu"][1],
        mu_front_lower=peak["lo"][0], mu_front_upper=peak["hi"][0],
        mu_rear_lower=peak["lo"][1], mu_rear_upper=peak["hi"][1],
        peak_alpha_front=peak["alpha"][0], peak_alpha_rear=peak["alpha"][1],
        peak_observed_front=peak["obs"][0], peak_observed_rear=peak["obs"][1],
        excited=excited, ess=ess, resampled=bool(resampled),
    )
    return new, est


_KERNEL_CONSTANTS: dict[int, tuple[GPSSMConfig, dict[str, Any]]] = {}


def _kernel_constants(config: GPSSMConfig) -> dict[str, Any]:
    """Packed arrays of :mod:`roadgrip.estimators.gpssm_kernel` for a configuration,
    cached by identity (hashing the configuration every step costs more than the lookup)."""
    hit = _KERNEL_CONSTANTS.get(id(config))
    if hit is not None and hit[0] is config:
        return hit[1]
    if len(_KERNEL_CONSTANTS) >= 16:
        _KERNEL_CONSTANTS.pop(next(iter(_KERNEL_CONSTANTS)))
    kc = _make_kernel_constants(config)
    _KERNEL_CONSTANTS[id(config)] = (config, kc)
    return kc


def _make_kernel_constants(config: GPSSMConfig) -> dict[str, Any]:
    veh = config.vehicle
    vp = np.zeros(gk.VEH.SIZE)
    vp[gk.VEH.MASS], vp[gk.VEH.FZF], vp[gk.VEH.FZR] = veh.mass, veh.fz_front, veh.fz_rear
    vp[gk.VEH.LF], vp[gk.VEH.LR], vp[gk.VEH.IZZ] = veh.lf, veh.lr, veh.yaw_inertia
    vp[gk.VEH.V_EPS] = V_EPS
    pt = config.prior_tire
    tensor, nf, fidx, ridx, wgt = gk.basis_tables(config.basis)
    exact = config.linalg == "exact"
    return {
        "veh": vp, "mf": np.array([pt.B, pt.C, pt.D, pt.E], float),
        "tensor": tensor, "nf": nf, "fidx": fidx, "ridx": ridx, "wgt": wgt,
        "Lambda0": np.ascontiguousarray(config.Lambda0),
        "tol": la.EXACT_TOL if exact else 1.0, "max_terms": 60 if exact else 0,
        "where": _axle_rows(config),
        "col": _peak_cols(config),
        "peak_rhs": {},  # (ratio, peak slip angles) -> features, :func:`_peak_rhs`
    }


def _step_compiled(
    state: GPSSMState | None, sample: Sample, config: GPSSMConfig, seed: int
) -> tuple[GPSSMState, GPSSMEstimate]:
    """:func:`step` through the compiled kernel (``'exact'`` and ``'fast'``)."""
    _check_sample(sample)
    kc = _kernel_constants(config)
    b = config.basis
    N, G, d, m = config.particles, b.groups, b.outputs, b.m
    lam = config.forgetting
    carry = config.linalg == "fast"
    if state is None:
        state = init(config, sample, seed)
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
    ratio = _manifold_ratio(state)
    fpk_g = _peak_rhs(config, ratio, state.peak_alpha)  # (G, m, np)
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
    pdst, order = gk.slot_plan(lin.panc)
    gk.particle_pass(
        state.x, state.mu, logw, lin.pinv.reshape(N * G, m, m), lin.panc, pdst, order,
        lin.pend, lin.pgain, pend_new, pgain_new, lin.hist, lin.nhist, state.Psi, state.Phi,
        propagate, float(dt), float(state.u[0]), float(state.u[1]), float(sample.steer),
        float(sample.vx), float(sample.ay), float(sample.yaw_rate), not math.isnan(sample.vy),
        0.0 if math.isnan(sample.vy) else float(sample.vy), learn,
        kc["veh"], kc["mf"], lam, nu, kc["Lambda0"], config.sigma_ay, config.sigma_yaw_rate, vy_max,
        lin.p_scale, 0.0 if carry else 1.0 - lin.c, kc["tol"], kc["max_terms"],
        kc["tensor"], kc["nf"], kc["fidx"], kc["ridx"], kc["wgt"], b.L, config.alpha_limit,
        fpk_g, wold, wnew, fresh,
        gdraw, zdraw, config.proposal == "conditional", carry,
        alpha, M, Lam, vpk, munow, e,
    )
    lin = lin._replace(pend=pend_new, pgain=pgain_new, panc=pdst, pkw=wnew, pkf=fpk_g)
    if learn:
        lin.hcoef[lin.nhist] = 1.0 / lin.sigma_scale
        lin.hanc[lin.nhist] = np.arange(N)
        lin = lin._replace(nhist=lin.nhist + 1)
        nu = nu + 1.0
    af_m, ar_m = float(e[gk.EST.ALPHA_F]), float(e[gk.EST.ALPHA_R])
    visits, moments, excited = _slip_statistics(config, state, af_m, ar_m, learn)
    grid, feats, prior = _peak_grid(config, round(ratio, 2))
    a_vis = np.array([_visited_range(config, visits[ax]) for ax in range(2)])
    pk = np.empty((2, 6))
    gk.peak_summary(M, Lam, max(nu - d - 1.0, 1.0), logw, vpk, feats, prior, grid, kc["where"],
                    kc["col"], a_vis, b.ell, _Z95, config.curve_sigma_floor**2, config.peak_max, pk)
    ess = float(e[gk.EST.ESS])
    resampled = ess <= config.ess_threshold * N
    new = GPSSMState(
        k=state.k + 1, t=float(sample.t), u=np.array([sample.steer, sample.vx], dtype=float),
        x=state.x, mu=state.mu, logw=logw, lin=lin, Psi=state.Psi, Phi=state.Phi, nu=float(nu),
        visits=visits, slip_moments=moments, peak_alpha=pk[:, [3, 5]].T.copy(), rng=rng,
        M=state.M, Lam=state.Lam,
    )
    if resampled:
        new = resample(new, _systematic(rng, np.exp(logw)))
    est = GPSSMEstimate(
        t=float(sample.t),
        vy=float(e[gk.EST.VY]), vy_std=float(e[gk.EST.VY_STD]),
        yaw_rate=float(e[gk.EST.YAW_RATE]), yaw_rate_std=float(e[gk.EST.YAW_RATE_STD]),
        alpha_f=af_m, alpha_r=ar_m,
        mu_now_front=float(e[gk.EST.MU_NOW_F]), mu_now_rear=float(e[gk.EST.MU_NOW_R]),
        mu_front=float(pk[0, 0]), mu_rear=float(pk[1, 0]),
        mu_front_lower=float(pk[0, 1]), mu_front_upper=float(pk[0, 2]),
        mu_rear_lower=float(pk[1, 1]), mu_rear_upper=float(pk[1, 2]),
        peak_alpha_front=float(pk[0, 3]), peak_alpha_rear=float(pk[1, 3]),
        peak_observed_front=bool(pk[0, 4]), peak_observed_rear=bool(pk[1, 4]),
        excited=excited, ess=ess, resampled=bool(resampled),
    )
    return new, est


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


def _conditional_sample(
    config: GPSSMConfig, rng: np.random.Generator, loc: NDArray, scale: NDArray, dof: float,
    mu_prior: NDArray, h: NDArray, D: NDArray, ay: float,
) -> tuple[NDArray, NDArray]:
    """Draw ``zeta`` from its predictive conditioned on the lateral acceleration.

    The Student-t predictive is the scale mixture ``zeta | g ~ N(loc, scale dof / g)``,
    ``g ~ chi²(dof)``. ``g`` is drawn from its prior and, given ``g``, ``ay = h_0 + D_0
    (mu_prior + zeta) + e`` is linear-Gaussian in ``zeta``, so ``zeta`` is drawn from its
    exact Gaussian conditional. The importance weight of this proposal (eq. 21) is the
    predictive density ``N(ay; h_0 + D_0 (mu_prior + loc), D_0 S D_0^T + sigma_ay²)``.
    (The separable basis draws one ``g`` per axle.)

    Returns ``zeta`` (N, G, d) and the log weight factor (N,).
    """
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
    c = D[:, 0, :]                                # (N, 2)
    v = ay - h[:, 0] - np.einsum("nj,nj->n", c, mu_prior + m0)
    Sc = np.einsum("nij,nj->ni", S, c)
    sy = np.einsum("ni,ni->n", c, Sc) + config.sigma_ay**2
    K = Sc / sy[:, None]
    mean = m0 + K * v[:, None]
    cov = S - K[:, :, None] * Sc[:, None, :]
    cov = _sym_pd(cov, 1e-18)
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


def _slip_statistics(
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


def _visited_range(config: GPSSMConfig, visits: NDArray) -> float:
    """Largest ``|alpha|`` [rad] up to which the histogram of one axle has a bin with at
    least ``peak_visits`` samples (its upper edge); 0 when none has."""
    hit = visits[::-1] >= config.peak_visits
    top = int(hit.argmax())
    return float((len(visits) - top) * config.bin_width) if hit[top] else 0.0


def _axle_rows(config: GPSSMConfig) -> NDArray[np.int64]:
    """(group, row) of each axle's friction, shape (2, 2)."""
    return np.array([[0, 0], [0, 1]] if config.basis.kind == "tensor" else [[0, 0], [1, 0]], np.int64)


def _peak_cols(config: GPSSMConfig) -> NDArray[np.int64]:
    """Columns of :func:`_peak_rhs` per axle, shape (2, 2): (unrestricted peak, band point)."""
    return np.array([[0, 2], [1, 3]] if config.basis.kind == "tensor" else [[0, 1], [0, 1]], np.int64)


def _peak_rhs(config: GPSSMConfig, ratio: float, peak_alpha: NDArray) -> NDArray:
    """Odd-part features at the two peak slip angles of each axle (``GPSSMState.peak_alpha``),
    by group: shape (G, m, np) with the columns of :func:`_peak_cols`."""
    # the manifold ratio to 1 %, as the peak grid (0.05 deg at 10 deg of slip, far below
    # the length scale): the features change only when the ratio or a peak point moves
    r = round(ratio, 2) if config.basis.kind == "tensor" else 1.0
    key = (r, *peak_alpha.ravel().tolist())
    cache = _kernel_constants(config)["peak_rhs"]
    hit = cache.get(key)
    if hit is not None:
        return hit
    f0, _ = _peak_features(config, r, float(peak_alpha[0, 0]), float(peak_alpha[0, 1]))
    f1, _ = _peak_features(config, r, float(peak_alpha[1, 0]), float(peak_alpha[1, 1]))
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
def _peak_features(config: GPSSMConfig, ratio: float, a_front: float, a_rear: float) -> tuple[NDArray, NDArray]:
    """Odd-part features of the front curve at ``a_front`` and the rear at ``a_rear``,
    (2, m), and the (group, row) table of :func:`_axle_features`. Cached: the peak slip
    angles are grid points and the separable bases do not depend on ``ratio``; the arrays
    are read-only."""
    fpk2, where = _odd(config, ratio, np.array([a_front, a_rear]))  # (2, 2, m)
    fpk = np.stack([fpk2[0, 0], fpk2[1, 1]])
    fpk.flags.writeable = False
    where.flags.writeable = False
    return fpk, where


@lru_cache(maxsize=64)
def _peak_grid(config: GPSSMConfig, ratio: float) -> tuple[NDArray, NDArray, NDArray]:
    """Slip grid on ``[0, min(peak_range, alpha_limit)]``, odd-part features (2, n, m) and
    prior curve."""
    grid = np.linspace(0.0, min(config.peak_range, config.alpha_limit), config.peak_grid)
    feats, _ = _odd(config, ratio, grid)
    return grid, feats, config.prior_tire.mu(_held(config, grid))


def _peak_estimates(
    config: GPSSMConfig, ratio: float, MT: NDArray, Lam: NDArray, nu: float, w: NDArray,
    vpk: NDArray, visits: NDArray, where: NDArray,
) -> dict[str, list]:
    """Peak friction per axle with band and observability (module docstring)."""
    d = config.basis.outputs
    grid, feats, prior = _peak_grid(config, round(ratio, 2))
    qdof = max(nu - d - 1.0, 1.0)
    out: dict[str, list] = {"mu": [], "lo": [], "hi": [], "alpha": [], "alpha_band": [], "obs": []}
    cols = _peak_cols(config)
    for ax in range(2):
        g, r = where[ax]
        curves = MT[:, g, :, r] @ feats[ax].T + prior  # (N, n)
        mean = w @ curves
        j = int(np.argmax(mean))
        a_pk = float(grid[j])
        # within-particle variances at the previous step's two peak slip angles
        var_in = np.maximum(vpk[:, g, cols[ax, 0]], 0.0) * Lam[:, g, r, r] / qdof + config.curve_sigma_floor**2
        # at the reported point of an unobserved peak, but never below the variance at the
        # unrestricted peak: a demonstrated maximum can carry a bias of the lateral
        # velocity (non-odd bases) that its own variance does not show
        var_band = np.maximum(np.maximum(vpk[:, g, cols[ax, 1]], 0.0) * Lam[:, g, r, r] / qdof
                              + config.curve_sigma_floor**2, var_in)
        peaks = curves.max(axis=1)
        pm = float(w @ peaks)
        pv = float(w @ ((peaks - pm) ** 2 + var_in))
        hi = pm + _Z95 * math.sqrt(max(pv, 0.0))
        a_vis = _visited_range(config, visits[ax])
        observed = bool(a_vis >= a_pk + config.basis.ell and a_pk > 0.0 and j < len(grid) - 1)
        a_band = a_pk
        if observed:
            mu_hat, lo = pm, pm - _Z95 * math.sqrt(max(pv, 0.0))
        else:
            # past the visited range the curve is the prior's: the data bound the peak
            # only from below (GPSSMConfig.peak_max)
            hi = config.peak_max
            inside = grid <= a_vis
            if inside.sum() <= 1:
                mu_hat, lo = 0.0, 0.0
            else:
                ci = curves[:, inside]
                vis_peaks = ci.max(axis=1)
                mu_hat = float(w @ vis_peaks)
                vv = float(w @ ((vis_peaks - mu_hat) ** 2 + var_band))
                lo = mu_hat - _Z95 * math.sqrt(max(vv, 0.0))
                a_band = float(grid[int(np.argmax(mean[inside]))])
        out["mu"].append(float(mu_hat))
        out["lo"].append(float(max(lo, 0.0)))
        out["hi"].append(float(max(hi, mu_hat)))
        out["alpha"].append(a_pk)
        out["alpha_band"].append(a_band)
        out["obs"].append(observed)
    return out


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
    )


def posterior_curves(
    state: GPSSMState, config: GPSSMConfig, alpha: NDArray, level: float = 0.95
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
    ``GPSSMConfig.curve_sigma_floor`` (basis truncation error).
    """
    from scipy.special import ndtr, stdtr

    alpha = np.asarray(alpha, dtype=float)
    b = config.basis
    N, d = config.particles, b.outputs
    ratio = _manifold_ratio(state)
    feats, where = _axle_features(config, ratio, alpha)  # (2, n, m)
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
    Lam = _sym_pd(config.Lambda0 + state.Phi - np.einsum("ngdm,ngme->ngde", state.Psi, MT), 1e-12)
    dof = state.nu - d + 1.0

    def cdf_fn(z: NDArray) -> NDArray:
        # Student-t CDF; its normal limit once the t is within 1e-3 of it (dof > 500)
        return ndtr(z) if dof > 500.0 else stdtr(dof, z)

    prior = config.prior_tire.mu(_held(config, alpha))
    # slip-angle spread of the particle cloud, per axle
    af, ar = slip_angles(state.u[1], state.x[:, LateralState.VY], state.x[:, LateralState.YAW_RATE],
                         state.u[0], config.vehicle)
    sig_a = [math.sqrt(float(w @ (a_ - w @ a_) ** 2) + config.slip_sigma**2) for a_ in (af, ar)]
    gh_o = np.array([-math.sqrt(3.0), 0.0, math.sqrt(3.0)])
    gh_w = np.array([1.0, 4.0, 1.0]) / 6.0
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
        for o, wo in zip(gh_o, gh_w, strict=True):
            if o == 0.0:
                locs.append(loc)
            else:
                aj = alpha + o * sig_a[ax]
                fj, _ = _axle_features(config, ratio, aj)
                locs.append(M_ax @ fj[ax].T + config.prior_tire.mu(_held(config, aj)))
            wts.append(w * wo)
        L_ = np.concatenate(locs)            # (3N, n)
        S_ = np.concatenate([sc, sc, sc])    # (3N, n)
        W_ = np.concatenate(wts)             # (3N,)
        a_lo = (L_ - 40 * S_).min(axis=0)
        a_hi = (L_ + 40 * S_).max(axis=0)
        for target, outarr in ((tail, lo), (1.0 - tail, hi)):
            left, right = a_lo.copy(), a_hi.copy()
            for _ in range(32):
                mid = 0.5 * (left + right)
                cdf = W_ @ cdf_fn((mid[None, :] - L_) / S_)
                below = cdf < target
                left = np.where(below, mid, left)
                right = np.where(below, right, mid)
            outarr[ax] = 0.5 * (left + right)
    return CurvePosterior(alpha, mean, lo, hi, np.stack([prior, prior]))


# -------------------------------------------------------------------------------------
# drive handling and the online object
# -------------------------------------------------------------------------------------
def drive_vx(drive: Any, source: str = "auto") -> NDArray[np.float64]:
    """Longitudinal speed [m/s] for the filter's input.

    ``source``:

    ``'wheels'``  mean wheel speed times radius over the non-driven axle (all four wheels
                  for all-wheel drive); driven wheels spin and are not used;
    ``'column'``  the drive's ``vx`` column;
    ``'pose'``    the body-axis projection of the pose derivative,
                  ``cos(psi) dx/dt + sin(psi) dy/dt`` (motion capture);
    ``'auto'``    ``'wheels'`` when those wheel speeds exist, else ``'column'``, else
                  ``'pose'``.
    """
    veh = drive.vehicle
    wheels = {"fwd": ("omega_rl", "omega_rr"), "rwd": ("omega_fl", "omega_fr")}.get(
        veh.drive, ("omega_fl", "omega_fr", "omega_rl", "omega_rr"))
    if source == "auto":
        if drive.has(*wheels):
            source = "wheels"
        elif drive.has("vx"):
            source = "column"
        elif drive.has("x", "y", "psi"):
            source = "pose"
        else:
            raise ValueError(
                f"drive from {drive.meta.source} has no non-driven wheel speeds, no 'vx' column "
                "and no pose: the GP-SSM filter needs the longitudinal speed"
            )
    if source == "wheels":
        drive.require(*wheels, why="vx from the non-driven wheels")
        return np.mean([drive.col(c) for c in wheels], axis=0) * veh.wheel_radius
    if source == "column":
        return drive.col("vx")
    if source == "pose":
        drive.require("x", "y", "psi", why="vx from the pose")
        t = drive.t
        psi = np.unwrap(drive.col("psi"))
        vx = np.cos(psi) * np.gradient(drive.col("x"), t) + np.sin(psi) * np.gradient(drive.col("y"), t)
        return np.maximum(vx, 0.0)
    raise ValueError(f"vx source must be 'auto', 'wheels', 'column' or 'pose', got {source!r}")


def drive_vy(drive: Any, source: str = "pose") -> NDArray[np.float64]:
    """Measured body lateral velocity [m/s] (``GPSSMConfig.vy_source``).

    ``'pose'``: ``-sin(psi) dx/dt + cos(psi) dy/dt`` (central differences of the pose);
    ``'none'``: NaN, no measurement.
    """
    if source == "none":
        return np.full(drive.n, np.nan)
    if source != "pose":
        raise ValueError(f"vy source must be 'none' or 'pose', got {source!r}")
    drive.require("x", "y", "psi", why="the lateral velocity from the pose")
    t = drive.t
    psi = np.unwrap(drive.col("psi"))
    return -np.sin(psi) * np.gradient(drive.col("x"), t) + np.cos(psi) * np.gradient(drive.col("y"), t)


def drive_inputs(
    drive: Any, vx_source: str = "auto", vy_source: str = "none", ay_source: str = "imu"
) -> NDArray[np.float64]:
    """Columns ``t, ay, yaw_rate, steer, vx, vy`` of a drive as an array (n, 6), the
    fields of :class:`Sample` (``vy`` NaN unless ``vy_source`` measures it; ``ay`` the
    accelerometer or, with ``ay_source='kinematic'``, ``r vx + dvy/dt``)."""
    drive.require("t", "yaw_rate", "steer", why="inputs of the GP-SSM filter")
    vx, vy = drive_vx(drive, vx_source), drive_vy(drive, vy_source)
    if ay_source == "kinematic":
        if np.isnan(vy).all():
            raise ValueError("the kinematic lateral acceleration needs a measured lateral velocity")
        ay = kinematic_lateral_acceleration(drive.t, vx, vy, drive.col("yaw_rate"))
    else:
        drive.require("ay", why="the lateral acceleration of the GP-SSM filter")
        ay = drive.col("ay")
    return np.column_stack([drive.col("t"), ay, drive.col("yaw_rate"), drive.col("steer"), vx, vy])


def upsample_inputs(data: NDArray, max_dt: float) -> tuple[NDArray, NDArray, int]:
    """Linear interpolation of the input rows onto ``k`` sub-steps per sample interval.

    The lateral model is integrated by forward Euler with the friction held over a step;
    for small, stiff vehicles at low sample rates (the JetRacer at 10 Hz) that step is
    unstable. With ``k = ceil(median dt / max_dt)`` the filter runs on ``k - 1``
    interpolated rows between recorded ones (and :class:`GPSSM` widens ``R`` by
    ``sqrt(k)`` so that the information per recorded sample is unchanged).

    Returns the rows (n', 5), a mask of the recorded rows and ``k``.
    """
    t = data[:, 0]
    if len(t) < 2:
        return data, np.ones(len(t), dtype=bool), 1
    k = max(1, math.ceil(float(np.median(np.diff(t))) / max_dt - 1e-9))
    if k == 1:
        return data, np.ones(len(t), dtype=bool), 1
    frac = np.arange(k) / k
    tf = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    tf = np.append(tf, t[-1])
    out = np.column_stack([tf] + [np.interp(tf, t, data[:, j]) for j in range(1, data.shape[1])])
    keep = np.zeros(len(tf), dtype=bool)
    keep[::k] = True
    return out, keep, k


class GPSSM:
    """Online GP-SSM friction learner: ``step(sample)`` or ``run(drive)``.

    Parameters
    ----------
    config : GPSSMConfig
    seed : int

    Examples
    --------
    >>> from roadgrip.vehicle import PRESETS
    >>> f = GPSSM(GPSSMConfig(PRESETS["suv"], particles=20, basis=make_basis("separable:8")))
    >>> est = f.step(Sample(t=0.0, ay=0.0, yaw_rate=0.0, steer=0.0, vx=15.0))
    >>> est.excited
    False
    """

    def __init__(self, config: GPSSMConfig, seed: int = 0) -> None:
        self.config = config
        self.seed = seed
        self.state_: GPSSMState | None = None

    def step(self, sample: Sample) -> GPSSMEstimate:
        self.state_, est = step(self.state_, sample, self.config, self.seed)
        return est

    def curves(self, alpha: NDArray, level: float = 0.95) -> CurvePosterior:
        if self.state_ is None:
            raise ValueError("no data yet: call step() first")
        with one_blas_thread():
            return posterior_curves(self.state_, self.config, alpha, level)

    def run(
        self,
        drive: Any,
        *,
        curve_times: tuple[float, ...] | None = None,
        curve_alpha: NDArray | None = None,
        progress: Any = None,
    ) -> tuple[pd.DataFrame, dict[float, CurvePosterior]]:
        """Process a whole drive.

        Returns
        -------
        table : DataFrame
            One row per sample (fields of :class:`GPSSMEstimate`).
        curves : dict
            Requested time -> :class:`CurvePosterior` at the first sample at or after it
            (the last sample for times beyond the end).
        """
        data, keep, k = upsample_inputs(
            drive_inputs(drive, self.config.vx_source, self.config.vy_source, self.config.ay_source),
            self.config.max_dt)
        if k > 1 and self.state_ is None:
            # each recorded sample is processed k times: spread its information over them
            self.config = replace(self.config, sigma_ay=self.config.sigma_ay * math.sqrt(k),
                                  sigma_yaw_rate=self.config.sigma_yaw_rate * math.sqrt(k))
        rows = []
        curves: dict[float, CurvePosterior] = {}
        pending = sorted(curve_times or ())
        if curve_alpha is None:
            curve_alpha = np.linspace(-self.config.peak_range, self.config.peak_range, 161)
        done = 0
        with one_blas_thread():
            for i, row in enumerate(data):
                self.state_, est = _step(self.state_, Sample(*row), self.config, self.seed)
                if not keep[i]:
                    continue
                rows.append(est)
                while pending and (row[0] >= pending[0] or i == len(data) - 1):
                    curves[pending.pop(0)] = posterior_curves(self.state_, self.config, curve_alpha)
                done += 1
                if progress is not None and done % 50 == 0:
                    progress(50)
        return pd.DataFrame(rows, columns=GPSSMEstimate._fields), curves


# -------------------------------------------------------------------------------------
# CLI
# -------------------------------------------------------------------------------------
def curves_frame(curves: dict[float, CurvePosterior], drive: Any = None) -> pd.DataFrame:
    """Long table ``t, axle, alpha, mu_mean, mu_lower, mu_upper, mu_prior[, mu_true]``."""
    frames = []
    for t, c in curves.items():
        for ax, axle in enumerate(AXLES):
            f = pd.DataFrame({
                "t": t, "axle": axle, "alpha": c.alpha, "mu_mean": c.mean[ax],
                "mu_lower": c.lower[ax], "mu_upper": c.upper[ax], "mu_prior": c.prior[ax],
            })
            if drive is not None and drive.has_truth:
                from roadgrip.truth import true_curve

                try:  # parametric, or binned (NaN where the drive's truth visited no bin)
                    f["mu_true"] = true_curve(drive, axle)(c.alpha)
                except Exception:
                    pass
            frames.append(f)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def curve_accuracy(
    curve: CurvePosterior,
    drive: Any,
    t_end: float | None = None,
    *,
    bin_width: float = math.radians(0.5),
    min_visits: int = 20,
) -> dict[str, dict[str, float]]:
    """Accuracy of posterior curves against a simulated drive's true tire curves.

    Slip bins of ``bin_width`` [rad] (signed) visited at least ``min_visits`` times by the
    true slip angles up to ``t_end`` form the covered range; over their centres the
    posterior mean is compared with the true curve (mean absolute error) and the 95 % band
    is checked to contain it (coverage fraction). The true curve is
    :func:`roadgrip.truth.true_curve`: on a drive with binned truth, covered bins
    its pure-lateral samples did not visit are left out.

    Returns
    -------
    dict
        ``{'front': {'mae', 'coverage', 'bins', 'alpha_min', 'alpha_max'}, 'rear': ...}``.
    """
    from roadgrip.truth import true_curve

    out: dict[str, dict[str, float]] = {}
    t = drive.t
    sel = t <= (t_end if t_end is not None else t[-1]) + 1e-9
    for ax, axle in enumerate(AXLES):
        a_true = drive.col(f"alpha_{axle[0]}_true")[sel]
        idx = np.floor(a_true / bin_width).astype(int)
        ids, counts = np.unique(idx, return_counts=True)
        centres = (ids[counts >= min_visits] + 0.5) * bin_width
        true = true_curve(drive, axle, bin_width=bin_width)(centres)
        centres, true = centres[np.isfinite(true)], true[np.isfinite(true)]
        if len(centres) == 0:
            out[axle] = {"mae": float("nan"), "coverage": float("nan"), "bins": 0,
                         "alpha_min": 0.0, "alpha_max": 0.0}
            continue
        mean = np.interp(centres, curve.alpha, curve.mean[ax])
        lo = np.interp(centres, curve.alpha, curve.lower[ax])
        hi = np.interp(centres, curve.alpha, curve.upper[ax])
        out[axle] = {
            "mae": float(np.mean(np.abs(mean - true))),
            "coverage": float(np.mean((lo <= true) & (true <= hi))),
            "bins": len(centres),
            "alpha_min": float(centres.min()),
            "alpha_max": float(centres.max()),
        }
    return out


def config_from_request(drive: Any, request: EstimateRequest) -> GPSSMConfig:
    opts = dict(request.options or {})
    basis = make_basis(request.basis or CLI_DEFAULT_BASIS)
    cfg = GPSSMConfig(drive.vehicle, basis=basis,
                      particles=request.particles or 200)
    if drive.meta.extra.get("format") == "dart":
        opts = {**DART_OPTIONS, **opts}
    if opts:
        known = {f for f in GPSSMConfig.__dataclass_fields__}
        bad = sorted(set(opts) - known)
        if bad:
            raise ValueError(f"unknown gpssm option(s) {bad}")
        cfg = replace(cfg, **opts)
    return cfg


def run_cli(drive: Any, request: EstimateRequest) -> EstimateResult:
    """``roadgrip estimate --method gpssm``: run, write curves/plot when asked."""
    request.reject("gpssm", "calibration")
    cfg = config_from_request(drive, request)
    filt = GPSSM(cfg, seed=request.seed)
    times = tuple(request.curve_times or ())
    if request.plot_path and not times:
        times = (4.0, 20.0, 40.0, 50.0)
    t0 = float(drive.t[0])
    abs_times = tuple(t0 + t for t in times)
    meta: dict[str, Any] = {"config": _config_meta(cfg)}
    progress_ctx = None
    if request.progress:
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        progress_ctx = Progress(TextColumn("gpssm"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                                TimeRemainingColumn(), transient=True)
    if progress_ctx is not None:
        with progress_ctx as prog:
            task = prog.add_task("gpssm", total=drive.n)
            with timed(meta, drive.n, drive.duration):
                table, curves = filt.run(drive, curve_times=abs_times,
                                         progress=lambda k: prog.advance(task, k))
    else:
        with timed(meta, drive.n, drive.duration):
            table, curves = filt.run(drive, curve_times=abs_times)
    curves = {t - t0: c for t, c in curves.items()}
    out = table.rename(columns={"yaw_rate": "yaw_rate_est"})
    last = out.iloc[-1]
    meta["diagnostics"] = {
        "ess_mean": float(out["ess"].mean()),
        "ess_min": float(out["ess"].min()),
        "resampling_rate": float(out["resampled"].mean()),
        "particles": cfg.particles,
        "basis": cfg.basis.label(),
        "linalg": cfg.linalg,
    }
    if not out["excited"].any():
        meta["diagnostics"]["information"] = "no excitation: posterior equals the prior"
    lo = min(last["mu_front_lower"], last["mu_rear_lower"])
    hi = max(last["mu_front_upper"], last["mu_rear_upper"])
    meta["summary"] = {
        "MostProbable": float(min(last["mu_front"], last["mu_rear"])),
        "LowerBound": float(lo), "UpperBound": float(hi),
    }
    cframe = curves_frame(curves, drive) if curves else None
    if request.curves_path and cframe is not None:
        cframe.to_parquet(request.curves_path, index=False)
    if request.plot_path:
        from roadgrip.plots.gpssm import plot_curves

        plot_curves(cframe, table, request.plot_path, title=str(drive.meta.source))
    return EstimateResult("gpssm", conform(out), meta, cframe)


def _config_meta(cfg: GPSSMConfig) -> dict[str, Any]:
    return {
        "basis": cfg.basis.label(), "kernel": cfg.basis.kernel, "s_f": cfg.basis.s_f,
        "ell_rad": cfg.basis.ell, "L_rad": cfg.basis.L, "particles": cfg.particles,
        "forgetting": cfg.forgetting, "nu0": cfg.nu0, "sigma_w0": cfg.sigma_w0,
        "sigma_ay": cfg.sigma_ay, "sigma_yaw_rate": cfg.sigma_yaw_rate,
        "prior_tire": cfg.prior_tire.to_dict(), "linalg": cfg.linalg,
    }

