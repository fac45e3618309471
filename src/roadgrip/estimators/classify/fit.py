"""Calibration of the saturation model from drives labelled 'high' / 'low'.

A handful of physical parameters, each fitted where the data determine it, so that a
calibration transfers to other drives of the same car (no grid search over classifier
settings scored on the labelled drives themselves):

0. the latency of the wheel speeds behind the accelerometer
   (:func:`roadgrip.estimators.classify.latency.fit_wheel_latency`), with which the drives
   are aligned before the other steps, as the classifiers' front end aligns them;
   the zero errors of the kinematic stage's slip angles (steering offset, a yawed pose
   frame), from the intercept of slip angle against lateral acceleration in the linear
   range, pooled over all drives (:func:`fit_slip_angle_offsets`); the later steps see
   the slip angles less these offsets, as the classifiers do;
1. per channel the normalised stiffness and the accelerometer gain (and longitudinally the
   road load ``r0 + r2 vx^2``, linear least squares inside), by least squares of the
   measured acceleration against the model at each drive's class friction, over the
   samples the channel uses (:func:`roadgrip.estimators.classify.grip_model.channels`),
   with a prior on the stiffness (the vehicle's parameters, 20 % in log) that holds it
   where the drives do not saturate;
2. per channel the relative model error from the fit's residuals averaged over about a
   second (their systematic part; bounded to 5-25 %);
3. each channel's switch: on when, over the informed samples of each class's drives
   (pooled), the median class position (bRLS ``theta``) lies on the class's side of
   the threshold, and both classes are informed (on the multi-body drives the lateral channel fails this: the
   kinematic stage's slip angles drift with the accelerometer's roll leak).

The claim times of a calibrated classifier are :data:`CALIBRATED_HOLD_HIGH_S` for 'high'
and held for 'low', :data:`BRAKING_ONLY_HOLD_LOW_S` on an all-wheel drive
(:func:`low_claim_hold`; see :mod:`roadgrip.estimators.classify.brls_config`); a 'low'
older than :data:`~roadgrip.estimators.classify.brls_config.CALIBRATED_REDECIDE_LOW_S`
is decided afresh by the next evidence (``redecide_low_s``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d

from roadgrip.constants import GRAVITY, GRIP_CLASS_SPLIT
from roadgrip.drive import Drive
from roadgrip.estimators.classify.brls import model_regressors
from roadgrip.estimators.classify.brls_config import (
    BRAKING_ONLY_HOLD_LOW_S,
    CALIBRATED_HOLD_HIGH_S,
    CALIBRATED_REDECIDE_LOW_S,
    BRLSConfig,
    saturation_config,
)
from roadgrip.estimators.classify.brls_kernel import brls_batch
from roadgrip.estimators.classify.common import DEFAULT_FRICTION, mirrored_friction, settled
from roadgrip.estimators.classify.frontend import FIRST_STEP_S
from roadgrip.estimators.classify.grip_model import (
    ALPHA_OFFSET_MAX,
    KAPPA_OFFSET_MAX,
    LONG_LATERAL_GATE,
    UNCALIBRATED_MODEL_ERROR,
    GripModel,
    default_grip_model,
    predict_accelerations,
    traction_slips,
)
from roadgrip.estimators.classify.latency import aligned_drive, fit_wheel_latency
from roadgrip.estimators.classify.slipmap_config import SlipMapConfig
from roadgrip.estimators.classify.slipmap_config import saturation_config as slipmap_saturation
from roadgrip.estimators.classify.slipmap_evidence import (
    BRAKING_MEMORY_MAX,
    PREFILTER_SIZE,
    prefilter,
)
from roadgrip.inference.kinematic import (
    KinematicConfig,
    KinematicOutput,
    drive_lateral_acceleration,
    estimate_kinematics,
)
from roadgrip.signals import undriven_wheels

__all__ = ["AWD_REFUSAL", "fit_class_friction", "fit_grip_model", "fit_slip_angle_offsets", "fit_slip_offset",
           "low_claim_hold", "saturation_calibration"]

STIFFNESS_PRIOR = 0.2
"""Standard deviation of the log stiffness around the vehicle's parameters."""

MODEL_ERROR_MIN = 0.05
"""Smallest relative model error a calibration assigns [-]."""

EFFECTIVE_SAMPLES = 0.1
"""Fraction of the samples counted as independent in the fit (neighbouring samples at
100 Hz share their errors)."""

ZERO_SLIP_ACCEL = 1.5
"""Lateral acceleration [m/s²] below which the slip-angle zero errors are fitted: about
0.15 g, inside the linear range of every surface the classes cover (the slip angles
there are small and proportional to the lateral acceleration whatever the friction)."""

ZERO_SLIP_MIN_SAMPLES = 50
"""Fewest samples below :data:`ZERO_SLIP_ACCEL` (and moving) for a zero-error fit."""

ZERO_SLIP_MIN_SPREAD = 0.3
"""Smallest standard deviation of the lateral acceleration over those samples [m/s²]:
below it the intercept is not separated from the slope."""

_SCALES = np.geomspace(0.6, 1.6, 25)
_GAINS = np.linspace(0.85, 1.3, 19)


def _channel_data(drive: Drive, kin: KinematicOutput, ay: NDArray, axis: str, min_speed: float,
                  tau: float, kappa_offset: float = 0.0):
    """Slips, measured acceleration and the samples a channel uses (arrays), the slips and
    accelerations low-passed over ``tau`` [s] as the classifiers do."""
    kin, ax, ay, braking, _ = prefilter(kin, drive.col("ax"), ay, drive.t, tau, FIRST_STEP_S,
                                        np.zeros(PREFILTER_SIZE))
    kf, kr, on_x = traction_slips(kin.kappa, kin.wheels_valid, ax, drive.vehicle, kappa_offset)
    moving = np.abs(kin.vx) >= min_speed
    if axis == "x":
        settled = braking.memory < BRAKING_MEMORY_MAX
        use = moving & on_x & settled & (np.abs(ay) < LONG_LATERAL_GATE * GRAVITY) & (ax > 0.3)
        zero = np.zeros(drive.n)
        return (kf, kr, zero, zero, drive.col("steer"), ax), ax, use, kin.vx
    use = moving & (np.abs(ay) > 1.0)
    return (kf, kr, kin.alpha_f, kin.alpha_r, drive.col("steer"), ax), ay, use, kin.vx


def _with_road_load(model: GripModel, rows, params, axis: str) -> tuple[GripModel, float]:
    """The road load ``r0 + r2 vx^2`` by least squares of the residuals (longitudinal
    channel; bounded to be non-negative), and the remaining sum of squares."""
    res, pred_v = [], []
    for (args, meas, use, vx), mu in rows:
        if use.any():
            sel = tuple(a[use] for a in args)
            m0 = replace(model, resistance_0=0.0, resistance_2=0.0)
            pred = predict_accelerations(*sel, params, m0, mu, vx[use])[0 if axis == "x" else 1]
            res.append(meas[use] - pred)
            pred_v.append(vx[use] ** 2)
    if not res:
        return model, 0.0
    r, v2 = np.concatenate(res), np.concatenate(pred_v)
    if axis != "x":
        return model, float(np.sum(r**2))
    a = np.column_stack([-np.ones_like(v2), -v2])
    coef, *_ = np.linalg.lstsq(a, r, rcond=None)
    coef = np.maximum(coef, 0.0)
    fitted = replace(model, resistance_0=float(coef[0]), resistance_2=float(coef[1]))
    return fitted, float(np.sum((r - a @ coef) ** 2))


def fit_grip_model(
    data: Sequence[tuple[Drive, str, KinematicOutput, NDArray]], friction: dict[str, float],
    min_speed: float = 0.5, tau: float = 0.3, kappa_offset: float = 0.0,
) -> tuple[GripModel, dict[str, Any]]:
    """Stiffnesses, gains and model error of the saturation model (steps 1-2 of the module).

    Parameters
    ----------
    data : sequence of (drive, label, kinematics, lateral acceleration used)
    friction : dict
        Peak friction of each class (the model's ``mu_high``, ``mu_low``).
    min_speed, tau : float
        Slowest speed used [m/s]; the input filter's time constant [s].
    kappa_offset : float
        Zero error of the driven slip [-] (:func:`fit_slip_offset`), kept in the model.

    Returns
    -------
    model : GripModel
    fit : dict
        Per channel the fitted stiffness, gain, residual and sample count.
    """
    params = data[0][0].vehicle
    base = replace(default_grip_model(params, friction["high"], friction["low"]), kappa_offset=kappa_offset)
    fitted: dict[str, Any] = {}
    for axis, c_name, g_name in (("x", "c_long", "gain_x"), ("y", "c_lat", "gain_y")):
        rows = [(_channel_data(d, kin, ay, axis, min_speed, tau, kappa_offset), friction[lab])
                for d, lab, kin, ay in data]
        base = replace(base, resistance_0=0.0, resistance_2=0.0) if axis == "x" else base
        n = sum(int(r[0][2].sum()) for r in rows)
        c0 = getattr(base, c_name)
        if n < 50:
            fitted[axis] = {"samples": n, "fitted": False}
            continue
        best = (np.inf, c0, 1.0)
        for sc in _SCALES:
            for g in _GAINS:
                model = replace(base, **{c_name: c0 * sc, g_name: float(g)})
                model, sse = _with_road_load(model, rows, params, axis)
                cost = EFFECTIVE_SAMPLES * sse / base.accel_noise**2 + (np.log(sc) / STIFFNESS_PRIOR) ** 2
                if cost < best[0]:
                    best = (cost, c0 * sc, float(g))
        _, c, g = best
        model, _ = _with_road_load(replace(base, **{c_name: float(c), g_name: g}), rows, params, axis)
        res, mag = [], []
        for ((args, meas, use, vx), mu), (drive, *_rest) in zip(rows, data, strict=True):
            if use.any():
                sel = tuple(a[use] for a in args)
                pred = predict_accelerations(*sel, params, model, mu, vx[use])[0 if axis == "x" else 1]
                # the systematic part: residuals averaged over about a second of used samples
                per_s = 1.0 / (float(np.median(np.diff(drive.t))) if drive.n > 1 else 0.01)
                k = max(1, round(per_s))
                r_lp = uniform_filter1d(meas[use] - pred, size=k, mode="nearest")
                big = np.abs(pred) > 1.0
                res.append(r_lp[big])
                mag.append(np.abs(pred[big]))
        r, m = np.concatenate(res), np.concatenate(mag)
        rel = float(np.sqrt(np.mean(r**2)) / np.mean(m)) if m.size else np.nan
        err = float(np.clip(rel, MODEL_ERROR_MIN, UNCALIBRATED_MODEL_ERROR)) if np.isfinite(rel) \
            else UNCALIBRATED_MODEL_ERROR
        base = replace(model, **{f"model_error_{axis}": err})
        fitted[axis] = {"samples": n, "fitted": True, "stiffness": float(c), "gain": g,
                        "road_load": [base.resistance_0, base.resistance_2],
                        "stiffness_over_parameters": float(c / c0), "relative_residual": rel,
                        "model_error": err}
    return base, fitted


def fit_slip_angle_offsets(
    data: Sequence[tuple[Drive, str, KinematicOutput, NDArray]], min_speed: float = 0.5,
) -> tuple[float, float, dict[str, Any]]:
    """Zero errors of the kinematic stage's slip angles [rad], from the near-linear samples.

    Per axle the intercept of the least-squares line ``alpha = s ay + b`` over the moving
    samples (``|vx| >= min_speed``) of every labelled drive, whatever its class, with
    ``|ay| <`` :data:`ZERO_SLIP_ACCEL`: there a tire's slip angle is proportional to its
    lateral force on any surface, so the line passes through zero unless the estimated
    slip angle carries a constant error (steering offset, a yawed pose frame, a biased
    lateral velocity). Pooling turns in both directions separates the intercept from the
    slope. Without :data:`ZERO_SLIP_MIN_SAMPLES` such samples spread by
    :data:`ZERO_SLIP_MIN_SPREAD` the offsets are 0. Each is clipped to
    :data:`~roadgrip.estimators.classify.grip_model.ALPHA_OFFSET_MAX`.

    Returns
    -------
    offset_f, offset_r : float
        To subtract from the front and rear slip angles [rad].
    fit : dict
        Samples, whether fitted, the offsets [deg] and the slopes [deg/(m/s²)].
    """
    ay, af, ar = [], [], []
    for _drive, _lab, kin, a in data:
        use = (np.abs(np.asarray(kin.vx, float)) >= min_speed) & (np.abs(a) < ZERO_SLIP_ACCEL)
        use &= np.isfinite(a) & np.isfinite(kin.alpha_f) & np.isfinite(kin.alpha_r)
        ay.append(np.asarray(a, float)[use])
        af.append(np.asarray(kin.alpha_f, float)[use])
        ar.append(np.asarray(kin.alpha_r, float)[use])
    a = np.concatenate(ay)
    if a.size < ZERO_SLIP_MIN_SAMPLES or float(np.std(a)) < ZERO_SLIP_MIN_SPREAD:
        return 0.0, 0.0, {"samples": int(a.size), "fitted": False}
    x = np.column_stack([a, np.ones_like(a)])
    (sf, bf), *_ = np.linalg.lstsq(x, np.concatenate(af), rcond=None)
    (sr, br), *_ = np.linalg.lstsq(x, np.concatenate(ar), rcond=None)
    bf, br = (float(np.clip(b, -ALPHA_OFFSET_MAX, ALPHA_OFFSET_MAX)) for b in (bf, br))
    return bf, br, {"samples": int(a.size), "fitted": True,
                    "offset_deg": [float(np.degrees(bf)), float(np.degrees(br))],
                    "slope_deg_per_mps2": [float(np.degrees(sf)), float(np.degrees(sr))]}


SLIP_ZERO_ACCEL = (-0.15, 2.5)
"""Longitudinal accelerations [m/s²] over which the driven slip's zero error is fitted:
cruising and moderate traction, the linear range of every surface the classes cover."""


def fit_slip_offset(
    data: Sequence[tuple[Drive, str, KinematicOutput, NDArray]], min_speed: float = 5.0,
) -> tuple[float, dict[str, Any]]:
    """Zero error of the driven axle's slip against the free-rolling wheels [-].

    The intercept of the least-squares line ``kappa = s a_x + b`` over the straight
    (``|a_y| < 0.5`` m/s²) samples faster than ``min_speed`` [m/s] with ``a_x`` in
    :data:`SLIP_ZERO_ACCEL`, pooled over the drives: wheel-speed scale errors between
    the axles (tire radii, encoder scales; a few per mille) shift the ratio of the axles'
    speeds by as much as a gravel road's slip at 1.5 m/s². The intercept also holds the
    slip that carries the road load at cruise, which the fit then does not see as road
    load (the same forces in the linear range). 0 without
    :data:`ZERO_SLIP_MIN_SAMPLES` samples, or for an all-wheel-drive car; clipped to
    :data:`~roadgrip.estimators.classify.grip_model.KAPPA_OFFSET_MAX`.

    Returns
    -------
    offset : float
    fit : dict
        Samples, whether fitted, the offset and the slope [1/(m/s²)].
    """
    params = data[0][0].vehicle
    xs, ks = [], []
    for drive, _lab, kin, ay in data:
        ax = drive.col("ax")
        kf, kr, _ = traction_slips(kin.kappa, kin.wheels_valid, ax, params)
        driven, valid = (kf, kin.wheels_valid[:, 0:2]) if params.drive == "fwd" else (kr, kin.wheels_valid[:, 2:4])
        use = (np.abs(np.asarray(kin.vx, float)) >= min_speed) & (np.abs(ay) < 0.5) & valid.any(-1)
        use &= (ax > SLIP_ZERO_ACCEL[0]) & (ax < SLIP_ZERO_ACCEL[1]) & np.isfinite(driven)
        xs.append(ax[use])
        ks.append(driven[use])
    a = np.concatenate(xs)
    if params.drive == "awd" or a.size < ZERO_SLIP_MIN_SAMPLES:
        return 0.0, {"samples": int(a.size), "fitted": False}
    s, b = np.polyfit(a, np.concatenate(ks), 1)
    b = float(np.clip(b, -KAPPA_OFFSET_MAX, KAPPA_OFFSET_MAX))
    return b, {"samples": int(a.size), "fitted": True, "offset": b, "slope_per_mps2": float(s)}


AWD_REFUSAL = (
    "the car is all-wheel driven: no wheel rolls freely to give the traction slips a speed "
    "reference, and its braking slips, against a speed that coasts on the accelerometer (whose "
    "bias and latency against the wheel speeds one drive does not determine), do not hold the "
    "label; the classifiers cannot be calibrated for it from these drives"
)
"""The reason :func:`saturation_calibration` gives when it refuses an all-wheel-drive car."""


FRICTION_GRID = np.round(np.arange(0.1, 1.51, 0.025), 3)
"""Peak frictions tried when a class's friction is estimated from its drives."""


def fit_class_friction(
    data: Sequence[tuple[Drive, str, KinematicOutput, NDArray]], model: GripModel,
    min_speed: float = 0.5, tau: float = 0.3,
) -> dict[str, float]:
    """Each labelled class's peak friction by least squares of both channels over its drives.

    For drives without a known friction (real data): the model with the fitted stiffness
    and gains is run at each friction of :data:`FRICTION_GRID`; a class whose drives
    never approach saturation leaves the sum of squares flat above the friction they
    used, and the smallest friction within 1 % of the best is taken (the friction the
    drives demonstrably used, not more). Only the classes of ``data`` are returned.
    """
    params = data[0][0].vehicle
    out = {}
    for lab in sorted({la for _, la, _, _ in data}):
        rows = [(*_channel_data(d, kin, ay, axis, min_speed, tau, model.kappa_offset), axis)
                for d, la, kin, ay in data if la == lab for axis in ("x", "y")]
        sse = np.zeros(FRICTION_GRID.size)
        for k, mu in enumerate(FRICTION_GRID):
            for args, meas, use, vx, axis in rows:
                if use.any():
                    sel = tuple(a[use] for a in args)
                    pred = predict_accelerations(*sel, params, model, float(mu), vx[use])[0 if axis == "x" else 1]
                    sse[k] += float(np.sum((meas[use] - pred) ** 2))
        ok = sse <= sse.min() * 1.01 + 1e-12
        out[lab] = float(FRICTION_GRID[np.argmax(ok)])
    return out


def _median_positions(cfg: BRLSConfig, data) -> tuple[list[dict[str, Any]], dict[str, dict[str, Any]]]:
    """Per drive and channel the median bRLS class position over its informed samples,
    and per channel and class the median over all of the class's informed samples."""
    out = []
    pooled: dict[str, dict[str, list]] = {"long": {"high": [], "low": []}, "lat": {"high": [], "low": []}}
    for drive, lab, kin, ay in data:
        (pl, yl, pa, ya), _ = model_regressors(kin, drive.col("ax"), ay, drive.col("steer"),
                                               drive.vehicle, cfg, drive.t)
        c = replace(cfg, hold_high_s=np.inf, hold_low_s=np.inf,
                    initial_state="low" if lab == "high" else "high")
        _, o = brls_batch(drive.t, pl, yl, pa, ya, c)
        row: dict[str, Any] = {"label": lab, "source": drive.meta.source}
        for name, w, th in (("long", o.w_long, o.theta_long), ("lat", o.w_lat, o.theta_lat)):
            inf = w >= 0.5
            row[name] = float(np.median(th[inf])) if inf.sum() >= 20 else None
            pooled[name][lab].append(th[inf])
        out.append(row)
    medians = {name: {lab: (float(np.median(np.concatenate(v))) if sum(a.size for a in v) >= 20 else None)
                      for lab, v in by.items()} for name, by in pooled.items()}
    return out, medians


def _labelled_friction(estimated: dict[str, float], labels: Sequence[str]) -> dict[str, float]:
    """Both classes' references from the friction the drives demonstrated.

    Two classes: as estimated (checked ordered). One class: the other mirrored across the
    split (:func:`~roadgrip.estimators.classify.common.mirrored_friction`); a 'high' drive
    shows only the friction it used, so its reference is at least dry asphalt's
    (:data:`~roadgrip.estimators.classify.common.DEFAULT_FRICTION`), and a 'low' drive
    that demonstrates a friction at or above the split is refused.
    """
    if len(labels) == 2:
        if not estimated["high"] > estimated["low"]:
            raise ValueError(f"calibration failed: the 'high' drives show no more friction than the "
                             f"'low' ones ({estimated}); give the friction as DRIVE:LABEL=MU")
        return dict(estimated)
    (lab,) = labels
    if lab == "high":
        return mirrored_friction("high", max(estimated["high"], DEFAULT_FRICTION["high"]))
    if not estimated["low"] < GRIP_CLASS_SPLIT:
        raise ValueError(f"calibration failed: the 'low' drives demonstrate a friction of "
                         f"{estimated['low']:.3g}, not below the class split {GRIP_CLASS_SPLIT}; "
                         "are they labelled correctly?")
    return mirrored_friction("low", estimated["low"])


def saturation_calibration(
    drives: Sequence[tuple[Drive, str, KinematicOutput]], friction: dict[str, float],
    kinematic: KinematicConfig = KinematicConfig(), estimate_friction: bool = False,
) -> tuple[BRLSConfig, SlipMapConfig, dict[str, Any]]:
    """Both classifiers' settings on the fitted saturation model (module docstring).

    The drives may carry both labels or one (one-class calibration: the usual dry
    baseline lap of a car). With one label, ``friction`` must hold both references
    (the other derived, :func:`~roadgrip.estimators.classify.common.mirrored_friction`)
    and step 3 switches the longitudinal channel on when the labelled class's median
    position lies on its side and the classifier with that channel alone, run over each
    labelled drive from the other class, claims no other class after
    :data:`~roadgrip.estimators.classify.common.CALIBRATION_SETTLING_S`. One class does
    not show that the slip angles separate the classes (the kinematic stage's sideslip
    drifts with the accelerometer's roll leak on the multi-body cars, and is off by more
    than the sideslip on a car without wheel speeds or pose), so the lateral channel's
    evidence is then the lateral acceleration alone
    (:func:`~roadgrip.estimators.classify.grip_model.demonstrated_channel`, which shows
    high grip and never low), on when the drives reach it and it holds their label. A
    longitudinal channel that fails with its braking samples is tried on traction alone
    (``GripModel.braking_evidence``).

    With ``estimate_friction`` the classes' peak friction comes from the drives
    (:func:`fit_class_friction`, then the stiffness and gains are fitted again);
    ``friction`` is the start. The diagnostics give the friction used.

    Raises
    ------
    ValueError
        When no channel is informed on the labelled drives, or none places them
        on their labelled sides.
    """
    labels = sorted({lab for _, lab, _ in drives})
    # the wheel speeds' latency first: every later step sees the drives aligned, as the classifiers do
    latency, latency_fit = fit_wheel_latency([d for d, _, _ in drives])
    if latency != 0.0:
        drives = [(a, lab, estimate_kinematics(a, kinematic))
                  for a, lab in ((aligned_drive(d, latency)[0], lab) for d, lab, _ in drives)]
    base = saturation_config(lateral=True)
    data = [(d, lab, kin, drive_lateral_acceleration(d, kin, base.lateral_acceleration, kinematic))
            for d, lab, kin in drives]
    off_f, off_r, zero = fit_slip_angle_offsets(data, base.min_speed)
    # the tire fits see the slip angles as the classifiers will (less the zero errors)
    level = [(d, lab, kin._replace(alpha_f=kin.alpha_f - off_f, alpha_r=kin.alpha_r - off_r), ay)
             for d, lab, kin, ay in data]
    # one class: the driven slip's zero error (with two, the classes' own fit holds it)
    kappa_offset, slip_zero = fit_slip_offset(level) if len(labels) == 1 else (0.0, {"fitted": False})
    model, fitted = fit_grip_model(level, friction, base.min_speed, base.slip_filter_tau_s, kappa_offset)
    demonstrated = None
    if estimate_friction:
        demonstrated = fit_class_friction(level, model, base.min_speed, base.slip_filter_tau_s)
        friction = _labelled_friction(demonstrated, labels)
        model, fitted = fit_grip_model(level, friction, base.min_speed, base.slip_filter_tau_s, kappa_offset)
    model = replace(model, alpha_offset_f=off_f, alpha_offset_r=off_r, wheel_latency_s=latency)
    cfg = replace(base, grip=model)
    positions, pooled = _median_positions(cfg, data)
    on = {}
    for name in ("long", "lat"):
        hi, lo = pooled[name]["high"], pooled[name]["low"]
        if len(labels) == 2:
            on[name] = hi is not None and lo is not None and hi > 0.5 > lo
        elif labels == ["high"]:
            on[name] = hi is not None and hi > 0.5
        else:
            on[name] = lo is not None and lo < 0.5
    lateral = "slips"
    braking = True
    if len(labels) == 1:
        # the braking slips (against a speed coasting on the accelerometer, with the wheels'
        # radius errors) are the weaker evidence: where a free-rolling wheel gives the traction
        # slips they are tried first, and the braking slips only where those do not hold the
        # label; on an all-wheel drive braking is the only longitudinal evidence
        traction = replace(cfg, grip=replace(model, braking_evidence=False))
        tries = [(cfg, True), (traction, False)]
        if undriven_wheels(drives[0][0].vehicle.drive).any():
            tries.reverse()
        on["long"] = False
        for c, with_braking in tries:
            _, pooled_t = _median_positions(c, data)
            med = pooled_t["long"][labels[0]]
            if med is not None and (med > 0.5 if labels[0] == "high" else med < 0.5) \
                    and _holds_label(c, data, "long"):
                model, cfg, on["long"], braking = c.grip, c, True, with_braking
                break
        # the slip angles' lateral channel is not shown to separate the classes by one
        # class (with two it fails on the multi-body cars; on the planar dry-gravel-dry it
        # holds the dry label, yet the slip map called dry asphalt 'low' in a lane change):
        # the lateral acceleration alone demonstrates high grip (grip_model.demonstrated_channel)
        demo = replace(cfg, grip=replace(model, lateral_evidence="demonstrated"))
        _, pooled_d = _median_positions(demo, data)
        on["lat"] = pooled_d["lat"]["high"] is not None and _holds_label(demo, data, "lat")
        if on["lat"]:
            model, cfg, lateral = demo.grip, demo, "demonstrated"
    if not (on["long"] or on["lat"]):
        raise ValueError(
            "calibration failed: no channel of the saturation model holds the labels on the labelled "
            f"drives (median class positions {pooled}; with one class, a channel that claims the "
            "other class on a labelled drive is off); "
            + (AWD_REFUSAL if drives[0][0].vehicle.drive == "awd" else
               "are the drives excited and correctly labelled?")
        )
    hold_low = low_claim_hold(drives[0][0].vehicle.drive)
    cfg = replace(cfg, long=replace(cfg.long, enabled=on["long"]), lat=replace(cfg.lat, enabled=on["lat"]),
                  hold_high_s=CALIBRATED_HOLD_HIGH_S, hold_low_s=hold_low,
                  redecide_low_s=CALIBRATED_REDECIDE_LOW_S)
    sm = replace(slipmap_saturation(model, hold_high_s=CALIBRATED_HOLD_HIGH_S, hold_low_s=hold_low,
                                    lateral=on["lat"]), longitudinal=on["long"],
                 redecide_low_s=CALIBRATED_REDECIDE_LOW_S)
    diag = {"model": "saturation", "labels": "+".join(labels), "grip_fit": fitted, "slip_angle_zero": zero,
            "slip_zero": slip_zero, "wheel_latency": latency_fit,
            "friction": dict(friction), "friction_estimated": bool(estimate_friction),
            "median_positions": positions, "class_median_positions": pooled,
            "long_channel": "on" if on["long"] else "off", "lat_channel": "on" if on["lat"] else "off",
            "lateral_evidence": lateral, "braking_evidence": braking}
    if demonstrated is not None:
        diag["friction_demonstrated"] = dict(demonstrated)
    return cfg, sm, diag


def low_claim_hold(drive: str) -> float:
    """How long a calibrated classifier holds 'low' after its last evidence [s], by the drive
    layout (``'fwd'``, ``'rwd'``, ``'awd'``): until evidence of high grip (``inf``) where a
    free-rolling wheel informs the longitudinal channel at every acceleration;
    :data:`~roadgrip.estimators.classify.brls_config.BRAKING_ONLY_HOLD_LOW_S` on an
    all-wheel drive, whose channel is informed in braking only."""
    return math.inf if undriven_wheels(drive).any() else BRAKING_ONLY_HOLD_LOW_S


def _holds_label(cfg: BRLSConfig, data, name: str) -> bool:
    """Whether the bRLS with channel ``name`` alone, started in the other class, claims
    nothing but the label on each labelled drive's settled samples
    (:func:`~roadgrip.estimators.classify.common.settled`, its settling counted from the
    channel's first informed sample: a drive that cruises before its first manoeuvre
    gives the classifier nothing to leave its start with)."""
    other = "long" if name == "lat" else "lat"
    c = replace(cfg, **{other: replace(getattr(cfg, other), enabled=False),
                        name: replace(getattr(cfg, name), enabled=True)},
                hold_high_s=CALIBRATED_HOLD_HIGH_S, hold_low_s=np.inf)
    for drive, lab, kin, ay in data:
        (pl, yl, pa, ya), _ = model_regressors(kin, drive.col("ax"), ay, drive.col("steer"),
                                               drive.vehicle, c, drive.t)
        _, o = brls_batch(drive.t, pl, yl, pa, ya,
                          replace(c, initial_state="low" if lab == "high" else "high"))
        # the settling counts from the channel's first informed sample: before it the
        # classifier holds its start (the other class) on no evidence at all
        judged = settled(drive.t, np.abs(np.asarray(kin.vx, float)) >= c.min_speed,
                         np.asarray(getattr(o, f"w_{name}")) >= 0.5)
        cls = np.asarray(o.grip_class)[judged]
        if np.any((cls != lab) & (cls != "unknown")):
            return False
    return True
