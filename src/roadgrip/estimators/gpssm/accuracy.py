"""Accuracy of the GP-SSM posterior curves against a simulated drive's true curves.

An evaluation helper (it compares with the truth): it belongs in
:mod:`roadgrip.evaluate` and stays here, outside the estimator's import path, until it
moves there.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRAVITY, Z95
from roadgrip.estimators.gpssm.config import AXLES
from roadgrip.estimators.gpssm.inputs import drive_vx
from roadgrip.estimators.gpssm.posterior import CurvePosterior
from roadgrip.truth import binned_truth_curve, has_parametric_truth, true_curve

__all__ = ["bands_overlap", "curve_accuracy", "honesty_figures", "sustained_lateral", "true_peak"]


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


def sustained_lateral(t: NDArray, ay: NDArray, window: float = 1.0) -> NDArray:
    """The largest ``|a_y| / g`` sustained for ``window`` [s] up to each sample, shape (n,).

    The mean of the measured lateral acceleration over the ``window`` before each sample
    (a trailing window; shorter at the start), its absolute value over ``g``, and its
    running maximum: the friction the car demonstrably used by that time, a floor for any
    upper bound that needs no truth.
    """
    t = np.asarray(t, float)
    ay = np.asarray(ay, float)
    c = np.concatenate([[0.0], np.cumsum(ay)])
    lo = np.searchsorted(t, t - window + 1e-9, side="left")
    hi = np.arange(1, len(t) + 1)
    full = (t - t[lo]) >= window - 1.5 * float(np.median(np.diff(t))) if len(t) > 1 else np.zeros(len(t), bool)
    mean = (c[hi] - c[lo]) / np.maximum(hi - lo, 1)
    s = np.where(full, np.abs(mean), 0.0) / GRAVITY
    return np.maximum.accumulate(s)


def true_peak(drive: Any, axle: str) -> float:
    """The true peak of an axle's lateral friction curve [-]: the parametric tire's, or
    the larger of the binned truth's largest bin (:func:`roadgrip.truth.true_curve`) and
    the drive's median ``mu_true``."""
    if has_parametric_truth(drive, axle):
        return float(drive.true_tire(axle).peak()[1])
    # the binned curve shows the peak only where the drive went past it; the surface's
    # peak friction (mu_true, both pure-slip peaks on the multi-body engine) otherwise
    top = float(np.max(binned_truth_curve(drive, axle).mu_mean))
    return max(top, float(np.median(drive.col("mu_true")))) if drive.has("mu_true") else top


def honesty_figures(
    drive: Any, table: Any, curve: CurvePosterior | None = None, *, vy_ref: NDArray | None = None,
    ay: NDArray | None = None,
) -> dict[str, Any]:
    """Accuracy and honesty figures of one run (the acceptance of ``docs/gpssm.md``).

    Parameters
    ----------
    drive : Drive
    table : DataFrame
        The run's rows (one per drive sample).
    curve : CurvePosterior, optional
        Curves at the end of the drive (needs the drive's truth).
    vy_ref : ndarray, shape (n,), optional
        Reference lateral velocity [m/s] (the truth, or the pose-derived one); default
        ``vy_true`` when the drive has it.
    ay : ndarray, shape (n,), optional
        The lateral acceleration of the floor [m/s²]: the filter's input (e.g. the
        kinematic one of the DART options); default the drive's ``ay`` column.

    Returns
    -------
    dict
        Per axle (``'front'``, ``'rear'``): ``mae``, ``coverage`` (:func:`curve_accuracy`,
        when ``curve`` is given), ``true_peak``, ``saturated`` (the true utilisation above
        0.95 for at least 50 samples), ``observed`` / ``mu`` / ``lower`` / ``upper`` at the
        end, ``lower_excess`` (largest ``mu_lower - true_peak`` over the drive),
        ``upper_below_floor``, ``observed_below_floor`` (samples whose upper bound, or
        observed peak, lies below the sustained ``|a_y|/g`` as measured); and ``vy_runaway`` (samples with ``|vy| > 0.5 vx`` not
        flagged ``diverged``), ``vy_coverage`` (share of samples with ``|vy - vy_ref| <=
        Z95 vy_std``), ``floor`` (final sustained ``|a_y|/g``).
    """
    out: dict[str, Any] = {}
    has_truth = bool(getattr(drive, "has_truth", False)) and drive.has("alpha_f_true")
    acc = curve_accuracy(curve, drive) if (curve is not None and has_truth) else None
    floor = sustained_lateral(drive.t, drive.col("ay") if ay is None else ay)
    last = table.iloc[-1]
    for axle in AXLES:
        a = axle[0]
        f: dict[str, Any] = {}
        if acc is not None:
            f.update(mae=acc[axle]["mae"], coverage=acc[axle]["coverage"], bins=acc[axle]["bins"])
        if has_truth:
            tp = true_peak(drive, axle)
            util = drive.col(f"util_{a}_true") if drive.has(f"util_{a}_true") else None
            f["true_peak"] = tp
            f["saturated"] = bool(util is not None and int(np.sum(util > 0.95)) >= 50)
            f["lower_excess"] = float(np.max(table[f"mu_{axle}_lower"].to_numpy() - tp))
        f["observed"] = bool(last[f"peak_observed_{axle}"])
        f["mu"], f["lower"], f["upper"] = (float(last[f"mu_{axle}{s}"]) for s in ("", "_lower", "_upper"))
        obs = table[f"peak_observed_{axle}"].to_numpy(bool)
        up = table[f"mu_{axle}_upper"].to_numpy()
        mu = table[f"mu_{axle}"].to_numpy()
        f["upper_below_floor"] = int(np.sum(up < floor - 1e-9))
        f["observed_below_floor"] = int(np.sum(obs & (mu < floor - 1e-9)))
        out[axle] = f
    vx = drive_vx(drive)
    vy = table["vy"].to_numpy()
    flagged = table["diverged"].to_numpy(bool) if "diverged" in table else np.zeros(len(vy), bool)
    out["vy_runaway"] = int(np.sum((np.abs(vy) > 0.5 * np.abs(vx)) & ~flagged))
    if vy_ref is None and drive.has("vy_true"):
        vy_ref = drive.col("vy_true")
    if vy_ref is not None:
        ok = np.isfinite(vy_ref)
        err = np.abs(vy - vy_ref)[ok]
        out["vy_coverage"] = float(np.mean(err <= Z95 * table["vy_std"].to_numpy()[ok] + 1e-9))
        out["vy_rmse"] = float(np.sqrt(np.mean(err**2)))
    out["floor"] = float(floor[-1])
    return out


def bands_overlap(bands: list[tuple[float, float]]) -> bool:
    """Whether intervals ``(lower, upper)`` overlap pairwise (for intervals on a line, the
    largest lower end at most the smallest upper end)."""
    return max(lo for lo, _ in bands) <= min(hi for _, hi in bands)
