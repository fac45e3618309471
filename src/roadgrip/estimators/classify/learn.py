"""Calibration of both classifiers from drives labelled 'high' / 'low' (:func:`calibrate`).

By default the saturation model's physical parameters are fitted
(:mod:`roadgrip.estimators.classify.fit`). With ``model='stiffness'`` (the paper's
regressors): the bRLS references, thresholds, excitation scales, memory and options are
chosen by a grid search scored on the full classifier (:func:`calibrate`);
the slip-map curves and dynamics by
:func:`roadgrip.estimators.classify.slipmap.calibrate_section`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roadgrip.drive import Drive
from roadgrip.estimators.classify.brls import regressors
from roadgrip.estimators.classify.brls_config import BRLSConfig, ChannelCalibration, default_config
from roadgrip.estimators.classify.brls_kernel import brls_batch
from roadgrip.estimators.classify.calibration import Calibration
from roadgrip.estimators.classify.common import (
    CLASS_SWITCH_PENALTY,
    DEFAULT_FRICTION,
    extra_switches,
    friction_refs,
    lowpass,
    mirrored_friction,
    settled,
)
from roadgrip.estimators.classify.fit import saturation_calibration
from roadgrip.estimators.classify.slipmap import calibrate_section
from roadgrip.inference.kinematic import (
    KinematicConfig,
    drive_lateral_acceleration,
    estimate_kinematics,
)
from roadgrip.inference.rls import brls_scalar_batch

__all__ = ["SCORE_TOLERANCE", "calibrate", "sensor_calibration"]

SCORE_TOLERANCE = 0.01
"""Scores within this of the best count as equally good in :func:`calibrate`
(fraction of time); among them the largest margin wins."""


def _best_threshold(hi: NDArray, lo: NDArray) -> tuple[float, float]:
    """Threshold maximising the balanced accuracy of ``x > thr -> high``; returns (thr, acc)."""
    cand = np.unique(np.quantile(np.r_[hi, lo], np.linspace(0.01, 0.99, 197)))
    acc = np.array([0.5 * ((hi > c).mean() + (lo <= c).mean()) for c in cand])
    k = int(np.argmax(acc))
    # the middle of the plateau of best thresholds
    best = cand[acc >= acc[k] - 1e-12]
    return float(np.median(best)), float(acc[k])


def _filtered(data: list, tau: float) -> list:
    out = []
    for drive, lab, kin, regs, moving in data:
        dt = float(np.median(np.diff(drive.t))) if drive.n > 1 else 0.01
        f = {k: (lowpass(v[0], dt, tau), lowpass(v[1], dt, tau)) for k, v in regs.items()}
        out.append((drive, lab, kin, f, moving))
    return out


def _channel_candidates(
    name: str, data: list, base: BRLSConfig, quantiles: Sequence[float], memory: float
) -> list[ChannelCalibration]:
    """Candidate settings of one channel for one memory (see :func:`calibrate`)."""
    ln2 = math.log(2.0)
    pooled = {}
    for lab in ("high", "low"):
        pooled[lab] = (
            np.concatenate([d[3][name][0][d[4]] for d in data if d[1] == lab]),
            np.concatenate([d[3][name][1][d[4]] for d in data if d[1] == lab]),
        )
    phi_abs = np.abs(np.concatenate([pooled[k][0] for k in pooled]))
    out = []
    if phi_abs.size < 20:
        return out
    gammas = [getattr(base, name).gamma] + [float(np.quantile(phi_abs, q)) / ln2 for q in quantiles]
    for gamma in gammas:
        if not gamma > 0:
            continue
        refs = {}
        for lab, (phi, y) in pooled.items():
            m = np.abs(phi) >= gamma * ln2
            refs[lab] = float(phi[m] @ y[m] / (phi[m] @ phi[m])) if m.sum() >= 10 else float("nan")
        if not (np.isfinite(refs["high"]) and np.isfinite(refs["low"]) and refs["high"] > refs["low"]):
            continue
        est: dict[str, list] = {"high": [], "low": []}
        for drive, lab, _kin, regs, moving in data:
            phi, y = regs[name]
            dt = float(np.median(np.diff(drive.t))) if drive.n > 1 else 0.01
            th, _, _ = brls_scalar_batch(
                np.where(moving, phi, 0.0), y, np.full(drive.n, np.nan),
                0.5 * (refs["high"] + refs["low"]), base.s0, math.exp(-dt / memory), 0.0, base.s_max,
            )
            est[lab].append(th[(np.abs(phi) >= gamma * ln2) & settled(drive.t, moving)])
        hi, lo = np.concatenate(est["high"]), np.concatenate(est["low"])
        mid = 0.5 * (refs["high"] + refs["low"])
        thrs = {mid}
        if hi.size >= 10 and lo.size >= 10:
            thrs.add(_best_threshold(hi, lo)[0])
        # largest margin between the drives: halfway between the lowest median
        # estimate of a high drive and the highest median of a low drive
        med = {lab: [float(np.median(e)) for e in est[lab] if e.size >= 10] for lab in est}
        if med["high"] and med["low"] and min(med["high"]) > max(med["low"]):
            thrs.add(0.5 * (min(med["high"]) + max(med["low"])))
        for thr in sorted(thrs):
            thr = min(max(thr, refs["low"]), refs["high"])
            out.append(ChannelCalibration(refs["high"], refs["low"], thr, gamma, True))
    return out


def _score(cfg: BRLSConfig, data: list) -> tuple[float, int, float]:
    """Calibration score of one configuration over the labelled drives.

    Returns the mean fraction of the settled moving time (:func:`~roadgrip.estimators.classify.common.settled`) in
    the labelled class, starting in the other state; the class switches beyond
    the first; and the margin: per drive and enabled channel the median over
    the settled moving samples of the estimate's distance from the threshold
    on the labelled side, in units of ``ref_high - ref_low`` (negative on the
    wrong side), averaged over the channels, and the smallest over the drives.
    """
    accs, switches, margins = [], 0, []
    for drive, lab, _kin, regs, moving in data:
        c = replace(cfg, initial_state="low" if lab == "high" else "high")
        _, out = brls_batch(drive.t, regs["long"][0], regs["long"][1], regs["lat"][0],
                            regs["lat"][1], c)
        cls = out.grip_class
        judged = settled(drive.t, moving)
        accs.append(float((cls[judged] == lab).mean()))
        switches += extra_switches(cls)
        side = 1.0 if lab == "high" else -1.0
        m = [float(np.median(side * (th[judged] - ch.threshold) / (ch.ref_high - ch.ref_low)))
             for ch, th in ((cfg.long, out.theta_long), (cfg.lat, out.theta_lat)) if ch.enabled]
        margins.append(float(np.mean(m)))
    return float(np.mean(accs)), switches, float(min(margins))


def calibrate(
    drives: Sequence[tuple[Drive, str]],
    *,
    base: BRLSConfig | None = None,
    kinematic: KinematicConfig = KinematicConfig(),
    quantiles: Sequence[float] = (0.5, 0.7, 0.85, 0.95),
    memories: Sequence[float] = (1.0, 2.0, 4.0, 8.0),
    prefilters: Sequence[float] = (0.0, 0.5, 1.0),
    lateral_regressors: Sequence[str] = ("axles", "rear"),
    error_clips: Sequence[float] = (math.inf, 1.0),
    theoretical_slips: Sequence[bool] = (False, True),
    friction: dict[str, float] | None = None,
    model: str = "saturation",
) -> Calibration:
    """Learn both classifiers: the saturation model (default) or the paper's stiffness settings.

    With ``model='stiffness'``, the bRLS references, thresholds, gammas and memory, and
    the slip-map curves, as follows.

    On the samples where the vehicle moves, per channel and candidate:

    1. excitation level ``gamma ln 2`` = a quantile (``quantiles``) of ``|phi|``,
       or ``base``'s gamma;
       ``ref_high`` / ``ref_low`` = least squares through the origin per label on
       the samples that level calls excited (the candidate is dropped unless
       ``ref_high > ref_low``);
    2. memory = ``base.memory_s`` times one of ``memories``; plain RLS is run
       over each drive; the threshold candidates are the midpoint of the
       references, the value that maximises the balanced accuracy of
       ``theta > thr -> high`` on the excited settled samples
       (:func:`~roadgrip.estimators.classify.common.settled`), and the largest margin between the drives: halfway
       between the lowest median estimate of a 'high' drive and the highest
       median of a 'low' drive (when these are ordered).

    Both steps run on the prefiltered signals, for each prefilter time constant
    in ``prefilters`` [s] and each lateral regressor in ``lateral_regressors``
    (with slip angles or theoretical slips, ``theoretical_slips``); the
    lateral acceleration is ``base.lateral_acceleration``'s (a sensor choice,
    not learned). For every lateral regressor, prefilter, memory and error
    clip, each channel's candidates are run alone, and the best two of each
    channel together, as the full classifier over each labelled drive,
    starting in the *other* state (so that it must detect the labelled class),
    and scored over the settled moving samples (from
    :data:`~roadgrip.estimators.classify.common.CALIBRATION_SETTLING_S` after the drive first moves) by the mean
    fraction of time spent in the labelled class minus :data:`~roadgrip.estimators.classify.common.CLASS_SWITCH_PENALTY` per
    class switch beyond the first (a labelled drive has one true class, so
    every further switch is false). Among the candidates within
    :data:`SCORE_TOLERANCE` of the best score, the one with the largest margin
    wins: the median distance of the estimates from the threshold on the
    labelled side, in units of the reference gap, on the worst drive (see
    ``_score``). A few labelled drives do not rank near-equal candidates
    reliably by accuracy alone; the margin prefers the threshold that keeps
    both classes farthest from it. The calibration drives should each contain
    some excitation.

    Parameters
    ----------
    drives : sequence of (Drive, label)
        Labels 'high' or 'low'. With the saturation model one label may be all
        there is (a car's dry baseline lap, 'high'): the car's stiffness, gains and
        road load are fitted on it, and the other class's friction reference is
        mirrored across the class split
        (:func:`~roadgrip.estimators.classify.common.mirrored_friction`); see
        :func:`~roadgrip.estimators.classify.fit.saturation_calibration`.
    base : BRLSConfig, optional
        Settings kept from it (time constants, ``s0``); default :func:`default_config`.
    kinematic : KinematicConfig
    quantiles, memories, prefilters : sequence of float
        Candidate grids (see above).
    lateral_regressors : sequence of {'axles', 'rear'}
        Lateral regressors tried (:func:`regressors`).
    friction : dict, optional
        Peak-friction reference per class (``{'high': ..., 'low': ...}``; with
        one label, that class's entry is used and the other derived); by
        default the median true friction of the drives of each class where they
        all carry simulator truth (``mu_true``); else, with the saturation model,
        estimated from the drives
        (:func:`~roadgrip.estimators.classify.fit.fit_class_friction`), and with
        the stiffness model :data:`~roadgrip.estimators.classify.common.DEFAULT_FRICTION`.
    error_clips : sequence of float
        Prediction-error bounds tried [m/s²] (``BRLSConfig.error_clip``).
    theoretical_slips : sequence of bool
        Slip-angle or theoretical-slip lateral regressors tried
        (``BRLSConfig.theoretical_slip``).

    model : {'saturation', 'stiffness'}
        ``'saturation'`` (default): both classifiers on the saturation model, its
        few physical parameters fitted to the drives
        (:func:`roadgrip.estimators.classify.fit.saturation_calibration`; the
        candidate grids above are not used). ``'stiffness'``: the paper's
        stiffness regressors and curves, by the search described above.

    Returns
    -------
    Calibration
        ``diagnostics`` holds the fit (saturation) or the winning score (stiffness)
        and each channel's status.
    """
    labels = [lab for _, lab in drives]
    if not labels:
        raise ValueError("calibration needs at least one labelled drive")
    for lab in labels:
        if lab not in ("high", "low"):
            raise ValueError(f"calibration label must be 'high' or 'low', got {lab!r}")
    if model not in ("saturation", "stiffness"):
        raise ValueError(f"calibration model must be 'saturation' or 'stiffness', got {model!r}")
    one_class = len(set(labels)) == 1
    if one_class and model != "saturation":
        raise ValueError("the stiffness model needs at least one 'high' and one 'low' drive; "
                         "a single class calibrates the saturation model only")
    base = base or default_config()
    sensors = sensor_calibration([drive for drive, _ in drives])
    kins = [(drive, lab, estimate_kinematics(drive, kinematic)) for drive, lab in drives]
    veh = kins[0][0].vehicle.name
    prov = tuple({"source": d[0].meta.source, "label": d[1], "samples": int(d[0].n)} for d in kins)
    known = friction is not None or all(d.has("mu_true") for d, _, _ in kins)
    friction = _one_class_friction(kins, labels[0], friction) if one_class else _friction(kins, friction)
    if model == "saturation":
        cfg, sm, diag = saturation_calibration(kins, friction, kinematic, estimate_friction=not known)
        diag["sensor_calibration"] = sensors
        return Calibration(cfg, sm, {}, veh, prov, diag, friction_refs(diag["friction"], "calibrate"))
    scored: list[tuple[float, BRLSConfig, float, int, float]] = []
    off = {name: replace(getattr(base, name), enabled=False) for name in ("long", "lat")}
    for lateral, theoretical in itertools.product(lateral_regressors, theoretical_slips):
        data = []
        for drive, lab, kin in kins:
            pl, pa = regressors(kin, drive.col("steer"), base.min_speed, lateral,
                                theoretical_slip=theoretical)
            moving = np.abs(kin.vx) >= base.min_speed
            ay = drive_lateral_acceleration(drive, kin, base.lateral_acceleration, kinematic)
            regs = {"long": (pl, drive.col("ax")), "lat": (pa, ay)}
            data.append((drive, lab, kin, regs, moving))
        for tau in prefilters:
            fdata = _filtered(data, float(tau))
            for mfac in memories:
                mem = base.memory_s * float(mfac)
                cands = {name: _channel_candidates(name, fdata, base, quantiles, mem)
                         for name in ("long", "lat")}
                for clip in error_clips:
                    common = {"memory_s": mem, "prefilter_tau_s": float(tau),
                              "lateral_regressor": lateral, "error_clip": float(clip),
                              "theoretical_slip": bool(theoretical)}

                    def run(cl, ca, common=common, data=data):
                        cfg = replace(base, long=cl, lat=ca, **common)
                        acc, sw, margin = _score(cfg, data)
                        return acc - CLASS_SWITCH_PENALTY * sw, cfg, acc, sw, margin

                    # each channel alone, then the best two of each together
                    alone_l = sorted((run(cl, off["lat"]) for cl in cands["long"]),
                                     key=lambda r: -r[0])
                    alone_a = sorted((run(off["long"], ca) for ca in cands["lat"]),
                                     key=lambda r: -r[0])
                    results = alone_l + alone_a + [
                        run(rl[1].long, ra[1].lat) for rl in alone_l[:2] for ra in alone_a[:2]
                    ]
                    scored.extend(results)
    if not scored:
        raise ValueError(
            "calibration failed: no channel gives ordered high/low stiffness references; "
            "are the drives excited and correctly labelled?"
        )
    # within SCORE_TOLERANCE of the best score, the largest margin wins (first on ties)
    top = max(r[0] for r in scored)
    near = [r for r in scored if r[0] >= top - SCORE_TOLERANCE]
    best = max(near, key=lambda r: r[4])
    _, cfg, acc, sw, margin = best
    diag: dict[str, Any] = {
        "fraction_in_labelled_class": acc,
        "class_switches": sw,
        "margin": margin,
        "long_channel": "on" if cfg.long.enabled else "off",
        "lat_channel": "on" if cfg.lat.enabled else "off",
        "lateral_regressor": cfg.lateral_regressor,
        "prefilter_tau_s": cfg.prefilter_tau_s,
        "memory_s": cfg.memory_s,
        "error_clip": cfg.error_clip,
        "theoretical_slip": cfg.theoretical_slip,
        "lateral_acceleration": cfg.lateral_acceleration,
        "sensor_calibration": sensors,
    }
    sm, sm_fit = calibrate_section(kins, kinematic=kinematic)
    return Calibration(cfg, sm, sm_fit, veh, prov, diag, friction)


def sensor_calibration(drives: Sequence[Drive]) -> dict[str, float]:
    """The sensor calibration the labelled drives were read with: the vehicle file's
    ``calibration`` (:mod:`roadgrip.io.calibration`: delays against the gyro, steering scale
    and offset, accelerometer biases), as ``meta.extra['calibration']`` records it; empty
    for drives read as logged.

    A classifier calibrated on drives read with a fitted vehicle file must run on drives read
    with the same file (``roadgrip estimate --vehicle car.yaml``): its latency, slip zero
    errors and road load are those of the calibrated signals. The calibration's diagnostics
    keep the mapping (``sensor_calibration``) so that the file says which.

    Raises
    ------
    ValueError
        When the drives were read with different sensor calibrations (one with a vehicle
        file's, one without, or two files'): one car's classifier has one set of signals.
    """
    cals = [dict((d.meta.extra or {}).get("calibration") or {}) for d in drives]
    for d, c in zip(drives, cals, strict=True):
        if c != cals[0]:
            raise ValueError(
                "the labelled drives were read with different sensor calibrations "
                f"({drives[0].meta.source or 'drive 1'}: {cals[0] or 'none'}; {d.meta.source or 'a later drive'}: "
                f"{c or 'none'}); read them all with the same vehicle file (--vehicle car.yaml)")
    return {str(k): float(v) for k, v in cals[0].items()}


def _one_class_friction(kins: list, label: str, friction: Mapping[str, float] | None) -> dict[str, float]:
    """Both references from drives of one class: ``label``'s from ``friction`` (that class's
    entry), else the median true friction of its drives where all carry simulator truth,
    else dry asphalt's or gravel's (:data:`~roadgrip.estimators.classify.common.DEFAULT_FRICTION`,
    the start of the estimate from the drives); the other mirrored across the split
    (:func:`~roadgrip.estimators.classify.common.mirrored_friction`)."""
    if friction is not None:
        if label not in friction:
            raise ValueError(f"calibrate: 'friction' must give the labelled class {label!r}")
        mu = float(friction[label])
    elif all(d.has("mu_true") for d, _, _ in kins):
        mu = float(np.median(np.concatenate([d.col("mu_true") for d, _, _ in kins])))
    else:
        mu = DEFAULT_FRICTION[label]
    return mirrored_friction(label, mu)


def _friction(kins: list, friction: dict[str, float] | None) -> dict[str, float]:
    """The given class friction, else the median true friction of each class's simulated
    drives, else :data:`~roadgrip.estimators.classify.common.DEFAULT_FRICTION` (checked)."""
    if friction is None:
        friction = dict(DEFAULT_FRICTION)
        for lab in ("high", "low"):
            mus = [d.col("mu_true") for d, la, _ in kins if la == lab and d.has("mu_true")]
            if mus:
                friction[lab] = float(np.median(np.concatenate(mus)))
    return friction_refs(friction, "calibrate")
