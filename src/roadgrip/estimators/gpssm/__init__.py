r"""GP-SSM particle filter: online Bayesian learning of the tire-friction curve (paper 000).

Berntorp's Algorithm 1: a particle filter over the lateral state ``x = [vy, yaw_rate]``
in which every particle carries its own reduced-rank GP posterior of the friction
function ``mu(alpha)`` as matrix-normal inverse-Wishart (MNIW) sufficient statistics.

Model
-----
State transition (eq. 7) and measurement (eq. 8), :mod:`roadgrip.estimators.gpssm.model`::

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
   distribution of ``x_{k+1}``, ``O(m²)`` instead of ``O(m³)``).
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

Modules
-------
=============  =============================================================================
config         :class:`GPSSMConfig` (the protocol ``Config``, ``method = 'gpssm'``)
inputs         the filter's input samples from a drive, sub-steps for slow data
model          the lateral single-track equations, one copy for NumPy and the compiled kernel
state          filter state, its per-run :class:`Context`, resampling
stepping       one step (the compiled whole step, or the NumPy reference)
reference      the NumPy reference step
block          the whole step compiled, one call per block of steps (block_ops: its parts;
               compiled: the state handed to it)
kernel         the compiled per-particle pass; kernel_ops: its building blocks, the peak
linalg         per-particle solves with ``Sigma + I``
posterior      posterior curves and the peak per axle
guard          honesty checks after every step: divergence, the physics floor, the vy band
estimator      ``prepare`` / ``init`` / ``step`` / ``run``; the online :class:`GPSSM`
batch          ``run_many``: many drives, one process per core
stream         ``run_chunks``: one long drive in chunks, the state carried between them
presets        data-set options (DART)
accuracy       curve accuracy against the truth (evaluation)
=============  =============================================================================

Practicalities
--------------
``vx`` comes from the non-driven wheels, the ``vx`` column or the pose
(``GPSSMConfig.vx_source``). Below ``min_speed`` the statistics are frozen. Data slower
than ``max_dt`` are interpolated onto sub-steps. Outputs are described in
:mod:`roadgrip.estimators.gpssm.posterior`.

Notation: ``N`` particles, ``G`` basis groups (1 tensor, 2 separable), ``d`` outputs per
group (2 tensor, 1 separable), ``m`` features per group.
"""

from __future__ import annotations

from roadgrip.estimators.gpssm.batch import run_many
from roadgrip.estimators.gpssm.config import AXLES, DEFAULT_BASIS, DEFAULT_PRIOR_TIRE, GPSSMConfig
from roadgrip.estimators.gpssm.estimator import (
    GPSSM,
    FilterState,
    init,
    prepare,
    prepare_rows,
    prior_band,
    run,
    run_filter,
    step,
    step_donated,
)
from roadgrip.estimators.gpssm.inputs import (
    Sample,
    drive_inputs,
    drive_vx,
    drive_vy,
    input_lookahead,
    upsample_inputs,
)
from roadgrip.estimators.gpssm.posterior import CurvePosterior, curves_frame, posterior_curves
from roadgrip.estimators.gpssm.reference import step_reference
from roadgrip.estimators.gpssm.state import (
    Context,
    GPSSMEstimate,
    GPSSMState,
    copy_state,
    init_state,
    resample,
)
from roadgrip.estimators.gpssm.stepping import step as filter_step
from roadgrip.estimators.protocol import Estimator

__all__ = [
    "AXLES",
    "DEFAULT_BASIS",
    "DEFAULT_PRIOR_TIRE",
    "ESTIMATOR",
    "GPSSM",
    "Context",
    "CurvePosterior",
    "FilterState",
    "GPSSMConfig",
    "GPSSMEstimate",
    "GPSSMState",
    "Sample",
    "copy_state",
    "curves_frame",
    "drive_inputs",
    "drive_vx",
    "drive_vy",
    "filter_step",
    "init",
    "init_state",
    "posterior_curves",
    "prepare",
    "prepare_rows",
    "prior_band",
    "resample",
    "run",
    "run_filter",
    "run_many",
    "step",
    "step_donated",
    "step_reference",
    "upsample_inputs",
]

ESTIMATOR = Estimator(
    name="gpssm",
    paper="000",
    summary="GP-SSM particle filter: online Bayesian learning of the axle friction curves.",
    Config=GPSSMConfig,
    prepare=prepare,
    init=init,
    step=step,
    run=run,
    prior_band=prior_band,
    lookahead=input_lookahead,
    prepare_rows=prepare_rows,
    step_donated=step_donated,
)
"""The GP-SSM estimator record (:mod:`roadgrip.estimators.protocol`)."""
