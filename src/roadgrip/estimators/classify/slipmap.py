r"""Nonlinear friction-state classification on the slip-acceleration maps (paper 002, Sec. V).

Given the friction-independent slips (:mod:`roadgrip.inference.kinematic`,
through :mod:`roadgrip.estimators.classify.frontend`),
reference accelerations follow from a *mid-friction* Magic Formula tire
(longitudinal and lateral curves, computed independently: zero lateral slip
for the longitudinal one and vice versa)::

    ax_ref = g s_x mu_mid,x(kappa)
    ay_ref = g (lr / L mu_mid,y(alpha_f) cos(delta) + lf / L mu_mid,y(alpha_r))

``kappa`` is the mean slip of the driven wheels when accelerating (``ax >= 0``)
and of all measured wheels when braking; ``s_x`` is the share of the weight
they carry (driven axle with longitudinal load transfer ``h ax / (g L)``
when accelerating, 1 when braking). A measured acceleration above the
reference (in magnitude) is high-friction evidence, below it low-friction
evidence, with the reliability weight (eq. 9)::

    W_i = 1 - exp(-(a_i - a_i,ref)^2 / sigma_i^2),    i = x, y

Exclusions (the paper's Fig. 8-9): a channel gets ``W = 0`` in its
low-slip-low-acceleration box (``|slip| < slip_min`` and ``|a| < accel_min``)
and in the quadrants where acceleration and slip disagree in sign (noise and
estimation error: the 2nd/4th quadrants of the longitudinal map and, with
roadgrip's slip-angle sign, the same for the lateral map).

Probabilities per channel (eq. 10-15): ``p^H = W`` above the reference, else 0;
``p^L = W`` below it, else 0; ``p^O = 1 - W``; each of ``p^H, p^L, p^O`` is the
mean over the two channels. Recursive estimate (eq. 16) with ``v^H = 1``,
``v^L = 0``::

    F(k) = p^O F(k-1) + p^H v^H + p^L v^L

followed by a first-order low-pass filter (time constant ``lowpass_tau_s``).
``grip_index`` is the filtered ``F``. ``grip_class`` is 'unknown' until the
accumulated weight ``sum W`` (both channels) reaches ``info_min``, then
'high'/'low' by the filtered ``F`` with a hysteresis band of ``hysteresis``
around 1/2. A sample is ``excited`` when some channel is outside its
exclusions with ``W >= w_excited``.

The default (``SlipMapConfig.model == 'saturation'``, also the uncalibrated
default) takes the references from the saturation model
(:mod:`roadgrip.estimators.classify.grip_model`): halfway between the two
classes' predicted accelerations, with weights from their separation
(:func:`roadgrip.estimators.classify.slipmap_evidence.saturation_evidence`),
and claims that expire.

Modules: settings :mod:`~roadgrip.estimators.classify.slipmap_config`,
evidence :mod:`~roadgrip.estimators.classify.slipmap_evidence`, compiled
recursion :mod:`~roadgrip.estimators.classify.slipmap_kernel`; this module
holds the estimator record :data:`SLIPMAP` (protocol of
:mod:`roadgrip.estimators.protocol`) and :func:`calibrate_section`, which picks
the mid-friction curves' peak and slope per channel that best separate the
labelled high and low samples (used by :func:`roadgrip.estimators.classify.calibrate`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult, ProgressCallback, conform, timed
from roadgrip.estimators.classify.calibration import ClassifierConfig
from roadgrip.estimators.classify.common import (
    CLASS_SWITCH_PENALTY,
    classifier_diagnostics,
    extra_switches,
    prior_band,
    settled,
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
from roadgrip.estimators.classify.slipmap_config import (
    SlipMapConfig,
    default_config,
    saturation_config,
)
from roadgrip.estimators.classify.slipmap_evidence import (
    PREFILTER_SIZE,
    SlipMapEvidence,
    evidence_from_kinematics,
    prefilter,
)
from roadgrip.estimators.classify.slipmap_kernel import (
    SlipMapState,
    slipmap_batch,
    slipmap_init,
    slipmap_step,
)
from roadgrip.estimators.protocol import DriveInfo, Estimator, Prepared
from roadgrip.inference.kinematic import (
    KinematicConfig,
    KinematicInput,
    KinematicOutput,
    drive_lateral_acceleration,
)

__all__ = ["SLIPMAP", "SlipMapEstimatorConfig", "SlipMapRunState", "calibrate_section", "slipmap_block",
           "slipmap_table"]


@dataclass(frozen=True)
class SlipMapEstimatorConfig(ClassifierConfig):
    """Configuration of the slip-map classifier (``calibration``: its ``slipmap`` settings)."""

    method = "slipmap"

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.calibration is not None and self.calibration.slipmap is None:
            raise ValueError("calibration has no slip-map settings (its 'slipmap' section is empty)")

    @property
    def settings(self) -> SlipMapConfig:
        """The slip-map settings: the calibration's, else the uncalibrated saturation model
        (:func:`~roadgrip.estimators.classify.slipmap_config.saturation_config`)."""
        return self.calibration.slipmap if self.calibration is not None else saturation_config()


class SlipMapRunState(NamedTuple):
    """State of the online classifier (:func:`step`).

    Attributes
    ----------
    front : Front
        Vehicle, kinematic tuning and velocity aid (constant over a drive).
    settings : SlipMapConfig
    kin : FrontState
        Kinematic stage.
    filtered : tuple of float
        Prefilter state (:data:`~roadgrip.estimators.classify.slipmap_evidence.PREFILTER_SIZE` values).
    core : SlipMapState
        Recursion of eq. 16.
    """

    front: Front
    settings: SlipMapConfig
    kin: FrontState
    filtered: tuple[float, ...]
    core: SlipMapState


def _filtered_evidence(
    drive: Drive, kin: KinematicOutput, config: SlipMapConfig, kin_cfg: KinematicConfig = KINEMATIC
) -> SlipMapEvidence:
    """Evidence of a whole drive after the prefilter (equals stepping); ``kin`` from ``kin_cfg``."""
    ay = drive_lateral_acceleration(drive, kin, config.lateral_acceleration, kin_cfg)
    kin_f, ax_f, ay_f, braking, _ = prefilter(kin, drive.col("ax"), ay, drive.t, config.prefilter_tau_s,
                                              FIRST_STEP_S, np.zeros(PREFILTER_SIZE))
    return evidence_from_kinematics(kin_f, ax_f, ay_f, drive.col("steer"), drive.vehicle, config, braking)


def slipmap_table(drive: Drive, config: SlipMapConfig, kin_cfg: KinematicConfig = KINEMATIC) -> pd.DataFrame:
    """The classifier over a whole drive (batch; equals stepping): one row per sample.

    Columns: ``t``, ``grip_class``, ``grip_index``, ``excited``, ``theta_long`` and
    ``theta_lat`` (NaN: no stiffness estimate), the weights ``w_x``, ``w_y``
    (eq. 9), ``p_high``, ``p_low`` (eq. 10-15), the reference accelerations
    ``ax_ref``, ``ay_ref`` [m/s²], the slip on the longitudinal map
    ``kappa_used`` [-], the lateral acceleration used ``ay_used`` [m/s²] and
    the kinematic stage's ``alpha_f_hat``, ``alpha_r_hat`` [rad], ``vx_hat``
    [m/s], ``beta_hat`` [rad].
    """
    front = Front.for_drive(drive, config.lateral_acceleration, kin_cfg, wheel_latency(config))
    start = SlipMapRunState(front, config, front_init(), (0.0,) * PREFILTER_SIZE, slipmap_init())
    return slipmap_block(drive, start)[0]


def slipmap_block(drive: Drive, state: SlipMapRunState) -> tuple[pd.DataFrame, SlipMapRunState]:
    """The classifier over a block of samples from ``state`` (batch; equals stepping).

    A whole drive is one block from :func:`init`'s state; a long drive in chunks
    gives, chunk by chunk, the rows of the whole drive (the kinematic stage, the
    prefilter and the recursion of eq. 16 continue from ``state``; the evidence
    is per sample).

    Parameters
    ----------
    drive : Drive
        The block's samples, later than ``state``'s.
    state : SlipMapRunState

    Returns
    -------
    table : DataFrame
        One row per sample (columns of :func:`slipmap_table`).
    state : SlipMapRunState
        After the block's last sample.
    """
    config, front = state.settings, state.front
    (kin, ay, ax), front_state = front_batch(drive, front, state.kin)
    dt0 = first_step(state.kin, drive.t[0])
    kin_f, ax_f, ay_f, braking, filtered = prefilter(kin, ax, ay, drive.t, config.prefilter_tau_s,
                                                     dt0, np.asarray(state.filtered, float))
    ev = evidence_from_kinematics(kin_f, ax_f, ay_f, drive.col("steer"), front.params, config, braking)
    core, out = slipmap_batch(drive.t, ev, config, state.core, dt0=dt0)
    table = pd.DataFrame({
        "t": drive.t,
        "grip_class": out.grip_class,
        "grip_index": out.grip_index,
        "excited": out.excited,
        "theta_long": np.nan,
        "theta_lat": np.nan,
        "w_x": ev.w_x,
        "w_y": ev.w_y,
        "p_high": ev.p_high,
        "p_low": ev.p_low,
        "ax_ref": ev.ax_ref,
        "ay_ref": ev.ay_ref,
        "kappa_used": ev.kappa,
        "ay_used": ay,
        "alpha_f_hat": kin.alpha_f,
        "alpha_r_hat": kin.alpha_r,
        "vx_hat": kin.vx,
        "beta_hat": kin.beta,
    })
    return table, SlipMapRunState(front, config, front_state, tuple(float(v) for v in filtered), core)


# ---------------------------------------------------------------------------------------
# estimator protocol


def prepare(drive: Drive, config: SlipMapEstimatorConfig) -> Prepared:
    """The drive\'s info (velocity aid in ``derived[\'aid\']``) and its kinematic samples."""
    return prepare_classifier(drive, config.settings.lateral_acceleration)


def prepare_rows(drive: Drive, config: Any, info: DriveInfo) -> list[KinematicInput]:
    """The kinematic samples of a piece of a drive after its start (what the drive's info
    is, :func:`prepare` derived from its first samples)."""
    return kinematic_samples(drive)


def init(info: DriveInfo, config: SlipMapEstimatorConfig, seed: int = 0) -> SlipMapRunState:
    """State before the first sample (deterministic: ``seed`` is not used)."""
    cfg = config.settings
    front = Front(info.vehicle, KINEMATIC, info.derived["aid"], cfg.lateral_acceleration, wheel_latency(cfg))
    return SlipMapRunState(front, cfg, front_init(), (0.0,) * PREFILTER_SIZE, slipmap_init())


def step(state: SlipMapRunState, sample: KinematicInput) -> tuple[SlipMapRunState, dict[str, Any]]:
    """One sample: kinematic stage, prefilter, evidence (eq. 9-15), recursion (eq. 16)."""
    cfg, front = state.settings, state.front
    fst, kin, dt, ay, ax = front_step(state.kin, sample, front)
    kin_f, ax_f, ay_f, braking, filtered = prefilter(kin, ax, ay, np.array([float(sample.t)]),
                                                     cfg.prefilter_tau_s, dt, np.array(state.filtered))
    ev = evidence_from_kinematics(kin_f, ax_f, ay_f, sample.steer, front.params, cfg, braking)
    core, out = slipmap_step(state.core, dt, ev, cfg)
    row = {
        "t": float(sample.t), "grip_class": out.grip_class, "grip_index": out.grip_index,
        "excited": out.excited, "theta_long": np.nan, "theta_lat": np.nan,
        "w_x": out.w_x, "w_y": out.w_y, "p_high": float(ev.p_high[0]), "p_low": float(ev.p_low[0]),
        "ax_ref": float(ev.ax_ref[0]), "ay_ref": float(ev.ay_ref[0]),
        "kappa_used": float(ev.kappa[0]), "ay_used": ay, "alpha_f_hat": float(kin.alpha_f),
        "alpha_r_hat": float(kin.alpha_r), "vx_hat": float(kin.vx), "beta_hat": float(kin.beta),
    }
    return SlipMapRunState(front, cfg, fst, tuple(float(v) for v in filtered), core), row


def run(
    drive: Drive, config: SlipMapEstimatorConfig | None = None, seed: int = 0,
    progress: ProgressCallback | None = None,
) -> EstimateResult:
    """The whole drive in batch (compiled; gives the rows of :func:`step`)."""
    config = config if config is not None else SlipMapEstimatorConfig()
    cfg = config.settings
    meta: dict[str, Any] = {}
    with timed(meta, drive.n, drive.duration):
        table = slipmap_table(drive, cfg)
    if progress is not None:
        progress(drive.n)
    meta["summary"] = summary_meta(table, config.friction)
    meta["diagnostics"] = classifier_diagnostics(table, config.calibration is not None, "mid friction 0.8, dry-asphalt shapes")
    meta["config"] = cfg.to_dict()
    meta["seed"] = int(seed)
    return EstimateResult("slipmap", conform(table), meta)


SLIPMAP = Estimator(
    name="slipmap",
    paper="002",
    summary="Friction-state classification on the slip-acceleration maps (Sec. V).",
    Config=SlipMapEstimatorConfig,
    prepare=prepare,
    prepare_rows=prepare_rows,
    init=init,
    step=step,
    run=run,
    prior_band=lambda config: prior_band(config.friction),
)
"""The slip-map classifier as an :class:`~roadgrip.estimators.protocol.Estimator` record."""


# ---------------------------------------------------------------------------------------
# calibration


def calibrate_section(
    data: list[tuple[Drive, str, KinematicOutput]], base: SlipMapConfig | None = None,
    kinematic: KinematicConfig = KinematicConfig(),
) -> tuple[SlipMapConfig, dict[str, Any]]:
    """Choose each channel's mid-friction curve from labelled drives.

    For each channel a grid of peaks ``D`` (0.1-1.5 times the base peak) and
    slopes ``B`` (0.25-2 times the base) is searched for the curve whose
    per-sample decision ``|a| > |a_ref| -> high`` has the best balanced
    accuracy on the labelled samples outside the exclusions, each sample
    weighted by its eq. 9 reliability.

    Then the prefilter (0, 0.5 or 1 s), the output low-pass time constant
    (0.5-4 s) and the hysteresis (0.1-0.3) are chosen by running the
    classifier over each labelled drive and scoring the fraction of its moving
    time after the settling period
    (:data:`~roadgrip.estimators.classify.common.CALIBRATION_SETTLING_S`, counted
    from the first moving sample, :func:`~roadgrip.estimators.classify.common.settled`) spent in the
    labelled class, minus ``SWITCH_PENALTY`` per class switch beyond the first.

    The lateral acceleration is ``base.lateral_acceleration``'s.

    Returns
    -------
    config : SlipMapConfig
    fit : dict
        The balanced accuracies and the final score.
    """
    base = base or default_config()
    fit: dict[str, float] = {}
    ays = [drive_lateral_acceleration(drive, kin, base.lateral_acceleration, kinematic)
           for drive, _, kin in data]
    curves = {"long_curve": base.long_curve, "lat_curve": base.lat_curve}
    for chan, key in (("x", "long_curve"), ("y", "lat_curve")):
        c0 = curves[key]
        best = (-1.0, c0)
        for dscale in np.geomspace(0.1, 1.5, 25):
            for bscale in np.geomspace(0.25, 2.0, 10):
                cur = replace(c0, D=c0.D * dscale, B=c0.B * bscale)
                cfg = replace(base, **{key: cur})
                acc_hi, acc_lo, n_hi, n_lo = 0.0, 0.0, 0.0, 0.0
                for (drive, lab, kin), ay in zip(data, ays, strict=True):
                    ev = evidence_from_kinematics(kin, drive.col("ax"), ay,
                                            drive.col("steer"), drive.vehicle, cfg)
                    w = ev.w_x if chan == "x" else ev.w_y
                    a = drive.col("ax") if chan == "x" else ay
                    ref = ev.ax_ref if chan == "x" else ev.ay_ref
                    above = np.abs(a) > np.abs(ref)
                    if lab == "high":
                        acc_hi += float((w * above).sum())
                        n_hi += float(w.sum())
                    else:
                        acc_lo += float((w * ~above).sum())
                        n_lo += float(w.sum())
                if n_hi < 1.0 or n_lo < 1.0:
                    continue
                bal = 0.5 * (acc_hi / n_hi + acc_lo / n_lo)
                if bal > best[0]:
                    best = (bal, cur)
        curves[key] = best[1]
        fit[f"balanced_accuracy_{'long' if chan == 'x' else 'lat'}"] = float(best[0])
    cfg = replace(base, **curves)
    # prefilter and output dynamics, scored on the full recursion over the settled
    # moving samples (as the bRLS calibration)
    masks = [settled(drive.t, np.abs(kin.vx) >= cfg.min_speed) for drive, _lab, kin in data]
    best = None
    for pf in (0.0, 0.5, 1.0):
        cpf = replace(cfg, prefilter_tau_s=pf)
        evs = [(drive, lab, _filtered_evidence(drive, kin, cpf, kinematic))
               for drive, lab, kin in data]
        for tau in (0.5, 1.0, 2.0, 4.0):
            for hyst in (0.1, 0.2, 0.3):
                c = replace(cpf, lowpass_tau_s=tau, hysteresis=hyst)
                accs, extra = [], 0
                for (drive, lab, ev), judged in zip(evs, masks, strict=True):
                    _, out = slipmap_batch(drive.t, ev, c, dt0=0.01)
                    cls = out.grip_class
                    accs.append(float((cls[judged] == lab).mean()))
                    extra += extra_switches(cls)
                key = float(np.mean(accs)) - CLASS_SWITCH_PENALTY * extra
                if best is None or key > best[0] + 1e-9:
                    best = (key, c, float(np.mean(accs)), extra)
    fit["fraction_in_labelled_class"] = best[2]
    fit["extra_switches"] = best[3]
    return best[1], fit
