r"""Friction-state classification with two bistable RLS instances and a state machine.

Paper 002 (Selmanaj, Corno, Savaresi), Sections III-IV. The vehicle behaves as
one equivalent tire (eq. 4)::

    ax = theta_long * phi_long,   phi_long = kappa_fl + kappa_fr + kappa_rl + kappa_rr
    ay = theta_lat  * phi_lat,    phi_lat  = alpha_f cos(delta) + alpha_r

with ``theta_long = C_k / M`` [m/s²] and ``theta_lat = 2 C_alpha / M``
[m/s²/rad] (roadgrip slip-angle sign, so ``theta_lat > 0``; the paper's
opposite sign flips its eq. 8 inequalities for the lateral channel). The slips
come from the friction-independent :mod:`roadgrip.inference.kinematic`
stage (through :mod:`roadgrip.estimators.classify.frontend`). Wheels without
a speed sensor contribute zero slip.

Each channel runs bRLS (eq. 6, :mod:`roadgrip.inference.rls`) whose reference
is the stiffness of the *current* friction state (Fig. 5 and 7): unexcited
data pull the estimate to the state's reference, excited data move it towards
the measured stiffness. The state machine (eq. 8, roadgrip sign)::

    high -> low  when  theta_lat < thr_lat  or  theta_long < thr_long
    low -> high  when  theta_lat > thr_lat  or  theta_long > thr_long

Implementation choices the paper leaves open, written down here:

* A channel takes part in eq. 8 only while it is *informed*: the low-passed
  measurement weight ``e = LP(1 - exp(-|phi| / gamma))`` (time constant
  ``excitation_tau_s``) is at least ``excitation_min``. Otherwise an unexcited
  channel, still sitting at the previous state's reference, would flip the
  state straight back after every switch. An informed channel that contradicts
  the switch vetoes it (no chatter when the two channels disagree).
* On a switch, a channel that is not informed is reset to the new state's
  reference (its estimate was the old reference, not data).
* Forgetting is given as a memory time: ``mu = exp(-dt / memory_s)`` per sample.
* ``gamma`` (the excitation scale of each regressor, see
  :mod:`roadgrip.inference.rls` on its form) defaults to the regressor value at
  which the two classes' predicted accelerations differ by twice the
  acceleration noise: ``gamma ln 2 = 2 sigma_a / (theta_high - theta_low)``.
  A sample is **sufficiently excited** for a channel when its measurement
  weight is at least 1/2, i.e. ``|phi| >= gamma ln 2``; the output ``excited``
  flags such samples.
* Options, off by default (the paper's algorithm): a first-order prefilter
  applied alike to regressor and output (``prefilter_tau_s``), a bound on the
  prediction error (``error_clip``, Huber-type robust RLS), and the rear-axle
  lateral regressor ``2 alpha_r`` (``lateral_regressor='rear'``, independent of
  the steering angle; see :func:`regressors`). Regressors are zeroed below
  ``min_speed``.

Outputs per sample: ``grip_class`` ('unknown' until some channel has been
informed, then the state), ``grip_index`` in [0, 1] (each channel's estimate
placed between its low (0) and high (1) references, weighted by the channels'
information ``e``; the state itself when no channel is informed), ``excited``,
``theta_long``, ``theta_lat``.

The default regressions (``BRLSConfig.model == 'saturation'``, also the
uncalibrated default) replace eq. 4 by the class position between the two
classes' predicted accelerations of the saturation model
(:mod:`roadgrip.estimators.classify.grip_model`, :func:`model_regressors`):
the equivalent stiffness does not separate surfaces whose tires share a
stiffness, their saturation does. Claims then expire (``hold_high_s``,
``hold_low_s`` in :mod:`roadgrip.estimators.classify.brls_config`).

Calibration (:func:`roadgrip.estimators.classify.calibrate`) learns per-channel
references, thresholds, gamma, the on/off switch of each channel and the
options above from drives labelled 'high' / 'low'.

Modules: settings :mod:`~roadgrip.estimators.classify.brls_config`, compiled
kernel :mod:`~roadgrip.estimators.classify.brls_kernel`; this module holds the
regressors of eq. 4 and the estimator record :data:`BRLS` (protocol of
:mod:`roadgrip.estimators.protocol`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, ProgressCallback, conform, timed
from roadgrip.estimators.classify.brls_config import BRLSConfig, saturation_config
from roadgrip.estimators.classify.brls_kernel import BRLSState, brls_batch, brls_init, brls_step
from roadgrip.estimators.classify.calibration import ClassifierConfig
from roadgrip.estimators.classify.common import (
    DEFAULT_FRICTION,
    classifier_diagnostics,
    prior_band,
    summary_meta,
)
from roadgrip.estimators.classify.frontend import (
    FIRST_STEP_S,
    KINEMATIC,
    Front,
    FrontState,
    first_step,
    front_batch,
    front_init,
    front_step,
    kinematic_samples,
    prepare_classifier,
    wheel_latency,
)
from roadgrip.estimators.classify.grip_model import (
    GripModel,
    braking_samples,
    channels,
    default_grip_model,
)
from roadgrip.estimators.classify.slipmap_evidence import (
    BRAKING_MEMORY_MAX,
    PREFILTER_SIZE,
    prefilter,
)
from roadgrip.estimators.protocol import DriveInfo, Estimator, Prepared
from roadgrip.inference.kinematic import KinematicConfig, KinematicInput, KinematicOutput
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "BRLS",
    "BRLSEstimatorConfig",
    "BRLSRunState",
    "brls_block",
    "brls_table",
    "grip_of",
    "model_regressors",
    "regressors",
    "rolling_ratio",
]


def rolling_ratio(kappa: NDArray) -> NDArray[np.float64]:
    """``vx / (R omega)`` of a wheel from its slip (eq. 2's definition).

    Eq. 2 divides by the larger of the two speeds, so ``vx / (R omega) = 1 - kappa``
    when driving (``kappa >= 0``) and ``1 / (1 + kappa)`` when braking; braking
    slip is bounded at -0.5 (a locking wheel has no rolling speed).
    """
    k = np.clip(np.asarray(kappa, float), -0.5, 1.0)
    return np.where(k >= 0.0, 1.0 - k, 1.0 / (1.0 + k))


def _axle_rolling_ratio(kin: KinematicOutput, axle: slice) -> NDArray[np.float64]:
    """Mean :func:`rolling_ratio` of an axle's measured wheels (1 where none is measured)."""
    kappa = np.asarray(kin.kappa, float)[..., axle]
    valid = np.asarray(kin.wheels_valid, bool)[..., axle]
    n = valid.sum(axis=-1)
    k = np.where(n > 0, (kappa * valid).sum(axis=-1) / np.maximum(n, 1), 0.0)
    return rolling_ratio(k)


def regressors(
    kin: KinematicOutput, steer: NDArray, min_speed: float = 0.0, lateral: str = "axles",
    params: VehicleParams | None = None, theoretical_slip: bool = False,
) -> tuple[NDArray, NDArray]:
    """The two regressors of eq. 4.

    ``phi_long`` is the sum of the wheel slips. ``phi_lat`` is
    ``alpha_f cos(delta) + alpha_r`` (``lateral='axles'``, the paper's), or
    ``2 alpha_r`` (``lateral='rear'``): in quasi-steady cornering the rear axle
    carries ``lf / L`` of the lateral force whatever the front does, so the
    rear slip angle alone is a regressor of ``ay`` that does not depend on the
    steering angle. It is the better choice when the road-wheel angle is only
    known through a fitted steering map. The factor 2 keeps the scale of the
    paper's regressor in symmetric driving. Both are set to 0 (no information)
    where ``|vx| < min_speed`` [m/s]: near standstill the slips are dominated
    by the low-speed regularisation.

    ``theoretical_slip=True`` replaces each axle's slip angle by the brush
    model's theoretical lateral slip ``sigma_y = tan(alpha) vx / (R omega)``
    (Pacejka, *Tire and Vehicle Dynamics*, Sec. 3.2): the tread deflection
    builds up over the contact length at the wheel's rolling speed
    ``R omega``, not at the travel speed, so a spinning wheel (``kappa > 0``)
    needs a larger slip angle for the same lateral force (the combined-slip
    reduction in the linear range). The ratio comes from the axle's measured
    wheels (:func:`rolling_ratio`); an axle without wheel speeds keeps ``tan(alpha)``.
    """
    kappa = np.asarray(kin.kappa, float)
    slow = np.abs(np.asarray(kin.vx, float)) < min_speed
    phi_long = np.where(slow, 0.0, kappa.sum(axis=-1))
    a_f = np.asarray(kin.alpha_f, float)
    a_r = np.asarray(kin.alpha_r, float)
    if theoretical_slip:
        a_f = np.tan(a_f) * _axle_rolling_ratio(kin, slice(0, 2))
        a_r = np.tan(a_r) * _axle_rolling_ratio(kin, slice(2, 4))
    if lateral == "axles":
        lat = a_f * np.cos(steer) + a_r
    elif lateral == "rear":
        lat = 2.0 * a_r
    else:
        raise ValueError(f"lateral regressor must be 'axles' or 'rear', got {lateral!r}")
    phi_lat = np.where(slow, 0.0, lat)
    return phi_long, phi_lat


def grip_of(config: BRLSConfig, params: VehicleParams) -> GripModel:
    """The saturation model of ``config``, or the vehicle's default one (class friction
    :data:`~roadgrip.estimators.classify.common.DEFAULT_FRICTION`)."""
    if config.grip is not None:
        return config.grip
    return default_grip_model(params, DEFAULT_FRICTION["high"], DEFAULT_FRICTION["low"])


def model_regressors(
    kin: KinematicOutput, ax: NDArray, ay: NDArray, steer: NDArray, params: VehicleParams,
    config: BRLSConfig, t: NDArray | None = None, dt0: float = FIRST_STEP_S,
    filtered: NDArray | None = None,
) -> tuple[tuple[NDArray, NDArray, NDArray, NDArray], NDArray]:
    """``(phi_long, y_long, phi_lat, y_lat)`` of the configured model, shapes (T,), and
    the input filter's state after the last sample.

    ``'stiffness'``: eq. 4 (:func:`regressors`) with the accelerations as outputs;
    ``'saturation'``: the whitened class positions of
    :func:`roadgrip.estimators.classify.grip_model.channels` on the slips and
    accelerations low-passed over ``config.slip_filter_tau_s`` (the slip noise
    enters both the regressor and the output through the model: unfiltered it
    biases the position towards the low class where the classes differ little),
    the longitudinal channel waiting after braking
    (:data:`~roadgrip.estimators.classify.slipmap_evidence.BRAKING_MEMORY_MAX`) except,
    with a fitted model (``config.grip``), on the braking samples themselves
    (:func:`~roadgrip.estimators.classify.grip_model.braking_samples`) at the onset of a
    stop (:meth:`~roadgrip.estimators.classify.slipmap_evidence.Braking.onset`).
    ``t`` [s] (shape (T,)), ``dt0`` and ``filtered`` (shape (PREFILTER_SIZE,),
    default zeros) drive that filter.
    """
    state = np.zeros(PREFILTER_SIZE) if filtered is None else np.asarray(filtered, float)
    if config.model == "saturation":
        tt = np.zeros(np.shape(np.atleast_1d(ax))) if t is None else np.atleast_1d(t)
        kin_f, ax_f, ay_f, braking, state = prefilter(kin, ax, ay, tt, config.slip_filter_tau_s, dt0, state)
        # braking slips only with a fitted model: the vehicle's default takes the slip
        # stiffness from the cornering stiffness, and its braking residuals called the dry
        # asphalt after a wet patch 'low' for 3.7 s on the multi-body figure-eight
        fitted = config.grip is not None and config.grip.braking_evidence
        ch, _ = channels(kin_f, ax_f, ay_f, steer, params, grip_of(config, params), config.min_speed,
                         braking=fitted)
        settled = braking.memory < BRAKING_MEMORY_MAX
        if fitted:
            # the onset of a stop only, as the slip map (slipmap_evidence.BRAKING_ONSET_S): later
            # the coasting speed's bias exceeds the class separation and reads as high grip
            settled = settled | (braking_samples(kin_f, ax_f) & np.atleast_1d(braking.onset()))
        return (np.where(settled, ch.phi_long, 0.0), np.where(settled, ch.y_long, 0.0),
                ch.phi_lat, ch.y_lat), state
    phi_long, phi_lat = regressors(kin, np.asarray(steer), config.min_speed, config.lateral_regressor,
                                   theoretical_slip=config.theoretical_slip)
    return (phi_long, np.asarray(ax, float), phi_lat, np.asarray(ay, float)), state


@dataclass(frozen=True)
class BRLSEstimatorConfig(ClassifierConfig):
    """Configuration of the bRLS classifier (``calibration``: its ``brls`` settings)."""

    method = "brls"

    @property
    def settings(self) -> BRLSConfig:
        """The bRLS settings: the calibration's, else the uncalibrated saturation model
        (:func:`~roadgrip.estimators.classify.brls_config.saturation_config`: the
        vehicle's parameters, large model error, claims that expire)."""
        return self.calibration.brls if self.calibration is not None else saturation_config()


class BRLSRunState(NamedTuple):
    """State of the online classifier (:func:`step`).

    Attributes
    ----------
    front : Front
        Vehicle, kinematic tuning and velocity aid (constant over a drive).
    settings : BRLSConfig
    kin : FrontState
        Kinematic stage.
    core : BRLSState
        The two bRLS channels and the state machine.
    filtered : tuple of float
        Input filter of the saturation model (:func:`model_regressors`).
    """

    front: Front
    settings: BRLSConfig
    kin: FrontState
    core: BRLSState
    filtered: tuple[float, ...] = (0.0,) * PREFILTER_SIZE


def brls_table(
    drive: Drive, config: BRLSConfig, kin_cfg: KinematicConfig = KINEMATIC
) -> tuple[pd.DataFrame, KinematicOutput]:
    """The classifier over a whole drive (batch; equals stepping): one row per sample.

    Columns: ``t``, ``grip_class``, ``grip_index``, ``excited``, the stiffness
    estimates ``theta_long`` [m/s²], ``theta_lat`` [m/s²/rad], the regressors
    ``phi_long`` [-], ``phi_lat`` [rad], the measurement weights ``w_long``,
    ``w_lat``, the lateral acceleration used ``ay_used`` [m/s²] and the
    kinematic stage's ``vx_hat`` [m/s] and ``beta_hat`` [rad]. Also returns
    the kinematic stage's output.
    """
    front = Front.for_drive(drive, config.lateral_acceleration, kin_cfg, wheel_latency(config))
    table, kin, _ = brls_block(drive, BRLSRunState(front, config, front_init(), brls_init(config)))
    return table, kin


def brls_block(drive: Drive, state: BRLSRunState) -> tuple[pd.DataFrame, KinematicOutput, BRLSRunState]:
    """The classifier over a block of samples from ``state`` (batch; equals stepping).

    A whole drive is one block from :func:`init`'s state; a long drive in chunks
    gives, chunk by chunk, the rows of the whole drive (the kinematic stage, both
    prefilters, the bRLS channels and the state machine continue from ``state``).

    Parameters
    ----------
    drive : Drive
        The block's samples, later than ``state``'s.
    state : BRLSRunState

    Returns
    -------
    table : DataFrame
        One row per sample (columns of :func:`brls_table`).
    kin : KinematicOutput
        The kinematic stage's output, arrays of shape (T,).
    state : BRLSRunState
        After the block's last sample.
    """
    config = state.settings
    (kin, ay, ax), front_state = front_batch(drive, state.front, state.kin)
    dt0 = first_step(state.kin, drive.t[0])
    (phi_long, y_long, phi_lat, y_lat), filtered = model_regressors(
        kin, ax, ay, drive.col("steer"), state.front.params, config, drive.t, dt0,
        np.asarray(state.filtered, float))
    core, out = brls_batch(drive.t, phi_long, y_long, phi_lat, y_lat, config, state.core, dt0=dt0)
    table = pd.DataFrame({
        "t": drive.t,
        "grip_class": out.grip_class,
        "grip_index": out.grip_index,
        "excited": out.excited,
        "theta_long": out.theta_long,
        "theta_lat": out.theta_lat,
        "phi_long": phi_long,
        "phi_lat": phi_lat,
        "w_long": out.w_long,
        "w_lat": out.w_lat,
        "ay_used": ay,
        "vx_hat": kin.vx,
        "beta_hat": kin.beta,
    })
    new = BRLSRunState(state.front, config, front_state, core, tuple(float(v) for v in filtered))
    return table, kin, new


# ---------------------------------------------------------------------------------------
# estimator protocol


def prepare(drive: Drive, config: BRLSEstimatorConfig) -> Prepared:
    """The drive\'s info (velocity aid in ``derived[\'aid\']``) and its kinematic samples."""
    return prepare_classifier(drive, config.settings.lateral_acceleration)


def prepare_rows(drive: Drive, config: Any, info: DriveInfo) -> list[KinematicInput]:
    """The kinematic samples of a piece of a drive after its start (what the drive's info
    is, :func:`prepare` derived from its first samples)."""
    return kinematic_samples(drive)


def init(info: DriveInfo, config: BRLSEstimatorConfig, seed: int = 0) -> BRLSRunState:
    """State before the first sample (deterministic: ``seed`` is not used)."""
    cfg = config.settings
    front = Front(info.vehicle, KINEMATIC, info.derived["aid"], cfg.lateral_acceleration, wheel_latency(cfg))
    return BRLSRunState(front, cfg, front_init(), brls_init(cfg))


def step(state: BRLSRunState, sample: KinematicInput) -> tuple[BRLSRunState, dict[str, Any]]:
    """One sample: kinematic stage, regressors (eq. 4), both bRLS channels and eq. 8."""
    cfg = state.settings
    fst, kin, dt, ay, ax = front_step(state.kin, sample, state.front)
    (phi_long, y_long, phi_lat, y_lat), filtered = model_regressors(
        kin, np.atleast_1d(ax), np.atleast_1d(ay), np.atleast_1d(float(sample.steer)),
        state.front.params, cfg, np.array([float(sample.t)]), dt, np.array(state.filtered))
    phi_long, phi_lat = float(np.ravel(phi_long)[0]), float(np.ravel(phi_lat)[0])
    core, out = brls_step(state.core, dt, phi_long, float(np.ravel(y_long)[0]), phi_lat,
                          float(np.ravel(y_lat)[0]), cfg)
    row = {
        "t": float(sample.t), "grip_class": out.grip_class, "grip_index": out.grip_index,
        "excited": out.excited, "theta_long": out.theta_long, "theta_lat": out.theta_lat,
        "phi_long": float(phi_long), "phi_lat": float(phi_lat), "w_long": float(out.w_long),
        "w_lat": float(out.w_lat), "ay_used": ay, "vx_hat": float(kin.vx), "beta_hat": float(kin.beta),
    }
    return BRLSRunState(state.front, cfg, fst, core, tuple(float(v) for v in filtered)), row


def run(
    drive: Drive, config: BRLSEstimatorConfig | None = None, seed: int = 0,
    progress: ProgressCallback | None = None,
) -> EstimateResult:
    """The whole drive in batch (compiled; gives the rows of :func:`step`)."""
    config = config if config is not None else BRLSEstimatorConfig()
    cfg = config.settings
    meta: dict[str, Any] = {}
    with timed(meta, drive.n, drive.duration):
        table, _ = brls_table(drive, cfg)
    if progress is not None:
        progress(drive.n)
    meta["summary"] = summary_meta(table, config.friction)
    meta["diagnostics"] = {
        **classifier_diagnostics(table, config.calibration is not None, "dry asphalt / gravel presets"),
        "long_channel": "on" if cfg.long.enabled else "off",
        "lat_channel": "on" if cfg.lat.enabled else "off",
    }
    meta["config"] = cfg.to_dict()
    meta["seed"] = int(seed)
    return EstimateResult("brls", conform(table), meta)


BRLS = Estimator(
    name="brls",
    paper="002",
    summary="Friction-state classification with two bistable RLS channels and a state machine.",
    Config=BRLSEstimatorConfig,
    prepare=prepare,
    prepare_rows=prepare_rows,
    init=init,
    step=step,
    run=run,
    prior_band=lambda config: prior_band(config.friction),
)
"""The bRLS classifier as an :class:`~roadgrip.estimators.protocol.Estimator` record."""
