"""Configuration of the GP-SSM filter (paper 000): :class:`GPSSMConfig`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from roadgrip.estimators.gpssm import linalg as la
from roadgrip.estimators.protocol import EstimatorConfig
from roadgrip.inference.basis import SeparableBasis, TensorBasis, make_basis
from roadgrip.tire import SURFACES, MagicFormula

__all__ = ["AXLES", "DEFAULT_BASIS", "DEFAULT_PRIOR_TIRE", "GPSSMConfig"]

AXLES = ("front", "rear")

DEFAULT_BASIS = "separable-odd:20"
"""Default basis: 20 odd functions per axle.

On the simulated snow drive it learns the curves an order of magnitude more
accurately than the paper's ``tensor:10x10`` (the odd symmetry makes the lateral
velocity identifiable) and runs about ten times faster.
"""

DEFAULT_PRIOR_TIRE = SURFACES["ice"].lateral.with_peak(0.05)
"""Prior mean friction curve: the ice preset's shape scaled to a 0.05 peak (paper Sec. 4)."""


@dataclass(frozen=True)
class GPSSMConfig(EstimatorConfig):
    """Hyperparameters of the GP-SSM filter (SI units).

    The vehicle is not part of the configuration: it comes with the drive
    (:class:`~roadgrip.estimators.protocol.DriveInfo`).

    Attributes
    ----------
    basis : TensorBasis or SeparableBasis
        Reduced-rank basis, given as an object or as its
        :func:`~roadgrip.inference.basis.make_basis` string (stored as the object);
        default :data:`DEFAULT_BASIS`, 20 odd functions per axle (SE kernel, ``s_f =
        500``, ``L = 30 deg``, ``ell = 2 deg``). The paper's basis is ``'tensor:10x10'``.
    particles : int
        ``N``.
    curve_times : tuple of float
        Times [s from the drive start] at which :func:`run` returns the posterior
        curves (:attr:`EstimateResult.curves`); a time past the end gives the curves
        at the last sample.
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
        Backend of :mod:`roadgrip.estimators.gpssm.linalg`.
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
    peak_margin : float
        A peak is *observed* when the visited slip range passes the argmax of the learned
        curve by at least this [rad] and its 95 % band half-width is at most
        ``peak_narrow`` [-]. (It was one kernel length scale, 2 deg: on the multi-body
        snow slaloms the rear axle, whose peak lies near 1.5 deg on snow, saturated but
        its estimated slip passed its learned peak by one bin only, and the peak was
        never reported observed.)
    peak_narrow : float
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
        pose derivative, or the drive's ``vy_pose`` column, :func:`drive_vy`, e.g. from
        motion capture) and every particle takes it instead of its propagated value (a
        NaN sample, e.g. at a jump of the localisation, is no measurement). The slip angles are then measured
        rather than inferred; the friction is learned from the lateral acceleration and
        the yaw dynamics against them.
    ay_source : {'imu', 'kinematic'}
        The lateral acceleration measured: the accelerometer, or ``r vx + dvy/dt`` from
        the gyro and the measured velocity (:func:`roadgrip.inference.kinematic.
        kinematic_lateral_acceleration`; needs ``vy_source='pose'``), which on a small car
        with a hobby-grade IMU and motion capture is about ten times less noisy.
    vx_source : {'auto', 'wheels', 'column', 'pose'}
        Where the longitudinal speed comes from (:func:`~roadgrip.estimators.gpssm.inputs.drive_vx`).
    max_dt : float
        Longest Euler step [s]; slower data are interpolated
        (:func:`~roadgrip.estimators.gpssm.inputs.upsample_inputs`), and the
        measurement noise is widened by ``sqrt(k)`` for ``k`` sub-steps per sample.
    slip_sigma : float
        Slip-angle uncertainty of the state estimate added to the curve band [rad]
        (:func:`posterior_curves`); about the error of the lateral-velocity estimate, or of
        its measurement (``vy_source='pose'``), over the speed (0.05 m/s at 12 m/s is
        0.24 deg on the simulated snow drive). ``slip_sigma |vx|`` is in the reported
        ``vy_std`` (:mod:`~roadgrip.estimators.gpssm.guard`).
    slip_scale_sigma : float
        Relative uncertainty [-] of the scale of the slip angles where the lateral
        velocity is not measured. From ``a_y`` and the yaw rate a learned curve stretched
        by ``k`` explains the same forces with slip angles ``k`` times larger (exactly for a
        neutral-steering car in steady cornering): only the model's transients tell them
        apart, and on a real car with a late accelerometer, an approximate yaw inertia and
        aerodynamic load they do not. On the full-size race car (``../shared/data/revs``)
        the estimated slip angles ran at about twice the INS's (median 4.0 deg against
        2.0 deg at the front) with a particle spread of 0.1-0.2 m/s. The reported ``vy_std``
        therefore holds ``slip_scale_sigma |vy - l_r r|`` in quadrature (the rear axle's
        slip velocity, ``v_x tan(alpha_r)``): 0.5 puts a lateral velocity from half to
        twice the slip inside the 95 % band. The curve band spreads over the same scale
        (``log k ~ N(0, log(1 + slip_scale_sigma)²)``, :func:`posterior_curves`). 0 for the
        particle spread alone.
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
        out stays well inside the bound (:func:`~roadgrip.io.presets.dart_options`).
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
    ay_gain_sigma : float
        Prior std [-] of the accelerometer gain ``k`` in ``a_y,meas = k (F_yf cos delta +
        F_yr) / m + e`` (a static parameter of every particle, prior ``N(1,
        ay_gain_sigma²)``), 0 for the paper's model (``k = 1``). A body-fixed accelerometer
        on a car that rolls reads ``a_y + g sin(phi)``; with the roll angle ``phi``
        proportional to ``a_y`` (6.5-8.8 deg/g on the multi-body vehicles) that is a gain of
        1.11-1.15, which the paper's model takes for friction (the learned peak 7 % high,
        the curve band covering the truth on 30-80 % of the slip bins). Used only with
        ``ay_source='imu'``. Known limit (``benchmarks/gpssm_seed_study.py``): learned per
        particle, the gain drifts with resampling and trades against the friction scale
        where the yaw dynamics do not separate them; on the 30-s ``sine-burst`` drive one
        filter seed of five settled on 1.21 and learned a front curve 0.31 off, its band
        covering no slip bin (fixed at 1, every seed within 0.039 with 100 % cover). A gain
        fixed at the vehicle's ``1 + g roll_gradient`` is no cure: on the multi-body
        Vanagon's snow slalom (drive and filter seed 3) the fixed 1.114 let the lateral
        velocity settle 0.75 m/s off (band covering 0.2 % of the samples, curve MAE 0.13 /
        0.39) where the learned gain (1.133) gives 100 % and 0.009 / 0.007.
    ay_gain_prior : {'one', 'vehicle'}
        Mean of the gain's prior: ``'one'`` (the accelerometer reads the force, the
        paper's model), or ``'vehicle'``: ``1 + g roll_gradient`` of the drive's vehicle,
        the gain ``roadgrip vehicle fit`` measures (``a_y`` against ``v_x r``: scale and
        roll together) and writes into the vehicle file as ``roll_gradient``.
    axle_loads : {'static', 'dynamic'}
        ``'static'``: the paper's static axle loads. ``'dynamic'``: the loads with the
        longitudinal load transfer of the measured ``ax`` (CG height, wheelbase,
        :func:`roadgrip.vehicle.params.axle_loads`) in eq. 7-8, where the drive has ``ax``.
    ay_noise : {'running', 'fixed'}
        ``'running'`` (with ``ay_source='imu'``): the likelihood's lateral-acceleration
        noise is the larger of ``sigma_ay`` and the accelerometer's noise measured from
        its second differences over the last second of samples
        (:func:`~roadgrip.estimators.gpssm.guard.step_sigma_ay`); ``'fixed'``: ``sigma_ay``.
        A car's accelerometer can be far noisier than the default assumes: the full-size
        race car's (``../shared/data/revs``) carries about 1.0 m/s² of vibration at 100 Hz
        against 0.15, and with ``sigma_ay`` that small the filter took the vibration for
        force (lateral velocity RMSE 1.9 m/s against the INS, 1.1 with the noise matched).
    ay_gain_walk : float
        Random-walk std of the gain [1/sqrt(s)] (artificial dynamics of a static
        parameter in a particle filter, so that resampling does not exhaust it). With
        0.003 a gain that the particles settled on wrongly in the first manoeuvres (0.92
        against 1.11 on a multi-body slalom) took the rest of the drive to walk back, and
        the friction learned meanwhile was 20 % high (6 of 30 Monte Carlo runs missed
        the curve acceptance; none with 0.01, docs/gpssm.md).
    ay_gain_gate : float
        ``|a_y|`` [m/s²] below which a step does not weigh the particles' gains: every
        particle then takes the weighted mean gain of the last step in eq. 8. Near zero
        ``a_y`` says nothing of the gain's value, but its predictive variance grows with
        the gain squared, so the weights favour the smallest gain at every step (straight
        driving took the gain from 1.0 to 0.6 in ten seconds on the sedan; the friction
        then learned was 1.7 times too high and the yaw rate ran away in the next slalom).
        0 weighs every step.
    max_sideslip_ratio : float
        ``|vy| / vx`` [-] past which a step is flagged ``diverged`` and the particles'
        lateral state is re-initialised (:mod:`roadgrip.estimators.gpssm.guard`); 0.5 is
        about 27 deg of body sideslip.
    diverge_time : float
        Seconds [s] of a yaw rate no particle explains, of collapsed weights, or of slip
        angles the measured lateral acceleration contradicts (``slide_slip``), before a
        step is flagged ``diverged``; and how long the output stays flagged after the
        re-initialisation.
    slide_slip, slide_mu : float
        Both estimated axle slip angles beyond ``slide_slip`` [rad] with one sign while
        the car's lateral acceleration over the last second (over the learned
        accelerometer gain) is below ``slide_mu g`` [-] in that direction: no tire carries
        less than ``slide_mu`` of its load at such a slip angle (ice about 0.05), so the
        lateral state is wrong, at any speed (a drift of ``vy`` to -3.9 m/s at 12.8 m/s,
        -17 deg of sideslip in straight driving, passed the ``max_sideslip_ratio`` test).
        Counted like a yaw rate no particle explains.
    reverse_slip, reverse_mu : float
        Both axles' estimated slip angles beyond ``reverse_slip`` [rad] while the learned
        frictions there (``mu_now_*``) push against the slips by more than ``reverse_mu``
        [-]: no passive tire does that, so the lateral state is wrong, and the step is
        flagged ``diverged`` and re-initialised at once (without a measured ``vy``). One
        such axle alone can be its curve, first learned at that slip (the paper's
        ``tensor-odd:10x10`` basis at a true front slip of 19 deg on snow, the state right,
        the yaw rate unexplained too), so one is not enough. On the 80-s dry-gravel-dry
        drive (seed 0) both slips ran to +15-19 deg with learned frictions of -0.2 to -0.6
        while the yaw-rate estimate left the gyro's (1.0 against 0.12 rad/s); the yaw-rate
        check waits ``diverge_time`` and was reset by the particles' return to the gyro
        half-way: the vy band was wrong on 4.6 % of the drive, 0.7 % with this check.
    relearn_time : float
        Seconds [s] after a re-initialisation during which no peak is reported observed
        and the lower bands are the physics floor: the curve learned on the wrong lateral
        state stays in the statistics until forgetting renews them (0.9998 per step is
        about 5000 steps, 200 s at 25 Hz). A drift on the dry-gravel-dry drive taught a
        front peak of 0.55 on dry asphalt of 1.0, reported observed after the recovery.
    floor_margin : float
        An observed peak more than this [-] below the sustained ``|a_y| / g`` (over the
        learned accelerometer gain) is reported as not observed.
    peak_max : float
        Largest peak friction admitted [-] (as the cascade's ``mu_bounds``): the upper band
        of a peak that was not observed. Past the visited slip range the learned curve is
        the prior's, so the data bound the peak only from below; an upper band taken from
        that curve would state the weak prior's guess (on the dry-gravel-dry drive it put
        the dry peak below 0.82-0.91 against a true 1.0).
    """

    method: ClassVar[str] = "gpssm"

    basis: TensorBasis | SeparableBasis = field(default_factory=lambda: make_basis(DEFAULT_BASIS))
    particles: int = 200
    curve_times: tuple[float, ...] = ()
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
    peak_margin: float = math.radians(0.5)
    peak_narrow: float = 0.05
    excitation_slip: float = math.radians(1.0)
    proposal: str = "conditional"
    max_dt: float = 0.04
    min_speed: float = 0.5
    vx_source: str = "auto"
    vy_source: str = "none"
    ay_source: str = "imu"
    slip_sigma: float = math.radians(0.25)
    slip_scale_sigma: float = 0.5
    curve_sigma_floor: float = 0.01
    max_sideslip: float | None = None
    slip_limit: float | None = None
    ay_gain_sigma: float = 0.1
    ay_gain_prior: str = "one"
    ay_noise: str = "running"
    ay_gain_walk: float = 0.01
    ay_gain_gate: float = 1.0
    axle_loads: str = "static"
    max_sideslip_ratio: float = 0.5
    diverge_time: float = 1.0
    slide_slip: float = math.radians(6.0)
    slide_mu: float = 0.03
    reverse_slip: float = math.radians(2.0)
    reverse_mu: float = 0.1
    relearn_time: float = 200.0
    floor_margin: float = 0.01
    peak_max: float = 2.0

    def __post_init__(self) -> None:
        if isinstance(self.basis, str):
            object.__setattr__(self, "basis", make_basis(self.basis))
        if not isinstance(self.basis, TensorBasis | SeparableBasis):
            raise ValueError(f"basis must be a basis or its string, got {self.basis!r}")
        try:
            times = tuple(float(t) for t in self.curve_times)
        except (TypeError, ValueError):
            raise ValueError(f"curve_times must be a sequence of seconds, got {self.curve_times!r}") from None
        if not all(math.isfinite(t) and t >= 0.0 for t in times):
            raise ValueError(f"curve_times must be finite and >= 0 s, got {self.curve_times!r}")
        object.__setattr__(self, "curve_times", times)
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
                     "bin_width", "slip_sigma", "curve_sigma_floor", "max_dt", "min_speed", "peak_max",
                     "max_sideslip_ratio", "diverge_time", "slide_slip", "slide_mu", "reverse_slip", "reverse_mu", "relearn_time", "floor_margin", "peak_margin",
                     "peak_narrow"):
            v = getattr(self, name)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"{name} must be positive and finite, got {v!r}")
        if not (np.isfinite(self.slip_scale_sigma) and 0.0 <= self.slip_scale_sigma <= 5.0):
            raise ValueError(f"slip_scale_sigma must be in [0, 5], got {self.slip_scale_sigma!r}")
        for name in ("ay_gain_sigma", "ay_gain_walk"):
            v = getattr(self, name)
            if not (np.isfinite(v) and 0.0 <= v < 0.5):
                raise ValueError(f"{name} must be in [0, 0.5), got {v!r}")
        if self.ay_gain_prior not in ("one", "vehicle"):
            raise ValueError(f"ay_gain_prior must be 'one' or 'vehicle', got {self.ay_gain_prior!r}")
        if not (np.isfinite(self.ay_gain_gate) and 0.0 <= self.ay_gain_gate <= 50.0):
            raise ValueError(f"ay_gain_gate must be in [0, 50] m/s², got {self.ay_gain_gate!r}")
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
        if self.ay_noise not in ("running", "fixed"):
            raise ValueError(f"ay_noise must be 'running' or 'fixed', got {self.ay_noise!r}")
        if self.axle_loads not in ("static", "dynamic"):
            raise ValueError(f"axle_loads must be 'static' or 'dynamic', got {self.axle_loads!r}")
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

    def to_meta(self) -> dict[str, Any]:
        """JSON-friendly fields; the basis as its label and kernel parameters."""
        meta = super().to_meta()
        b = self.basis
        meta["basis"] = b.label()
        meta.update(kernel=b.kernel, s_f=b.s_f, ell_rad=b.ell, L_rad=b.L)
        meta["prior_tire"] = self.prior_tire.to_dict()
        return meta
