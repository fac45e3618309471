"""Accuracy of the GP-SSM posterior curves against a simulated drive's true curves.

An evaluation helper (it compares with the truth): it belongs in
:mod:`roadgrip.evaluate` and stays here, outside the estimator's import path, until it
moves there.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from roadgrip.estimators.gpssm.config import AXLES
from roadgrip.estimators.gpssm.posterior import CurvePosterior
from roadgrip.truth import true_curve

__all__ = ["curve_accuracy"]


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
