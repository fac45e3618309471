"""COVESA Vehicle Signal Specification (VSS) output: road friction as JSON lines.

One JSON object per output sample (estimate row), e.g.::

    {"t": 12.34, "Vehicle.ADAS.ESC.RoadFriction.MostProbable": 31.2,
     "Vehicle.ADAS.ESC.RoadFriction.LowerBound": 27.9,
     "Vehicle.ADAS.ESC.RoadFriction.UpperBound": 34.6}

``t`` is the drive's clock [s]; the three signals are in percent, the VSS unit
(range 0-100), with friction coefficient 1.0 = 100 %. A signal is **absent** from a
line where the estimator does not know it; it is never clamped nor filled in:

* nothing is written before the estimator has seen its first excited sample
  (``excited``), nor while a classifier says ``grip_class == 'unknown'``, nor at a
  sample flagged ``diverged`` (it makes no claim);
* an estimator that flags the peak (:data:`PEAK_FLAGGING_METHODS`: gpssm) gives
  ``MostProbable`` and ``UpperBound`` only once both axles' peaks are observed
  (before, ``mu_*`` is a lower bound and the upper end the physical limit); its
  ``LowerBound`` appears once it rises above the prior's;
* the other axle estimators (cascade) give all three once the band is narrower than
  the prior band, and otherwise only the ends that moved inside the prior's;
* a value outside 0-100 % (e.g. a dry-road band reaching a friction of 1.1) is left
  out, since the VSS range cannot carry it.

The road value combines the two axles as ``meta['summary']`` does
(``docs/output-contract.md``): with per-axle standard deviations (``mu_*_std``,
the cascade) the precision-weighted mean with ``+-Z95`` of its deviation, the upper
end at least ``grip_floor`` (the friction the car demonstrably used), the lower end at
least ``grip_now`` (the friction it uses on the present surface, the last second's:
a surface the car has left is no floor of this one); without (gpssm) the
smaller axle mean and the union of the axle bands. Classifiers (``grip_class``)
publish the band their class claims (:func:`roadgrip.estimators.classify.common.class_band`):
'high' ``LowerBound`` = the class split :data:`~roadgrip.constants.GRIP_CLASS_SPLIT`
and no upper bound; 'low' ``UpperBound`` = the split and ``LowerBound`` = ``grip_now``
where the table has one; ``MostProbable`` the class's reference held inside that band.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.constants import GRIP_CLASS_SPLIT, Z95

__all__ = ["PEAK_FLAGGING_METHODS", "VSS_COLUMNS", "VSS_PREFIX", "vss_records", "write_vss"]

VSS_PREFIX = "Vehicle.ADAS.ESC.RoadFriction."
"""VSS branch of the three friction signals (``MostProbable``, ``LowerBound``, ``UpperBound``)."""

PEAK_FLAGGING_METHODS = ("gpssm",)
"""Methods whose ``peak_observed_*`` flags say when ``mu_*`` estimates the peak."""

VSS_COLUMNS = (
    "t", "mu_front", "mu_rear", "mu_front_std", "mu_rear_std", "mu_front_lower", "mu_rear_lower",
    "mu_front_upper", "mu_rear_upper", "grip_floor", "grip_now", "excited", "peak_observed_front",
    "peak_observed_rear", "grip_class", "diverged",
)
"""The estimate table's columns :func:`vss_records` reads (a caller may give it only these)."""

_TOL = 1e-9  # a band end within this of the prior's has not moved


def _zero_nan(x: np.ndarray) -> np.ndarray:
    """``x`` with NaN as 0 (an infinite value stays: every rule below treats it as the largest)."""
    return np.where(np.isnan(x), 0.0, x)


def _combined(table: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Road friction (most probable, lower, upper) per row from the two axles, shape (n,) each."""
    mf, mr = table["mu_front"].to_numpy(float), table["mu_rear"].to_numpy(float)
    if {"mu_front_std", "mu_rear_std"} <= set(table.columns):
        wf = 1.0 / table["mu_front_std"].to_numpy(float) ** 2
        wr = 1.0 / table["mu_rear_std"].to_numpy(float) ** 2
        mp = (wf * mf + wr * mr) / (wf + wr)
        sd = 1.0 / np.sqrt(wf + wr)
        floor = _zero_nan(table["grip_floor"].to_numpy(float)) if "grip_floor" in table.columns else 0.0
        now = _zero_nan(table["grip_now"].to_numpy(float)) if "grip_now" in table.columns else 0.0
        lo = np.maximum(mp - Z95 * sd, now)
        return np.maximum(mp, lo), lo, np.maximum(mp + Z95 * sd, floor)
    lo = np.minimum(table["mu_front_lower"].to_numpy(float), table["mu_rear_lower"].to_numpy(float))
    up = np.maximum(table["mu_front_upper"].to_numpy(float), table["mu_rear_upper"].to_numpy(float))
    return np.minimum(mf, mr), lo, up


def vss_records(
    table: pd.DataFrame, method: str, prior_band: tuple[float, float]
) -> list[dict[str, float]]:
    """VSS friction signals per estimate row (module docstring for the rules).

    Parameters
    ----------
    table : DataFrame, shape (n, ...)
        An estimate table (the output contract's columns: ``t``, ``mu_*``,
        ``excited``, ``peak_observed_*``, ``grip_class``; ``mu_*_std`` and
        ``grip_floor`` where the method writes them).
    method : str
        The method that wrote it (:data:`PEAK_FLAGGING_METHODS` read the peak flags).
    prior_band : (float, float)
        The method's band before any friction information [-] (its ``prior_band``);
        a classifier's two friction references.

    Returns
    -------
    list of dict, length n
        ``{'t': s, VSS_PREFIX + 'MostProbable': %, ...}`` with absent keys where
        the value is not known or outside 0-100 %.
    """
    p_lo, p_up = (float(v) for v in prior_band)
    if not p_lo < p_up:
        raise ValueError(f"prior band must have lower < upper, got {prior_band}")
    n = len(table)
    t = table["t"].to_numpy(float)
    axles = "mu_front" in table.columns and bool(np.isfinite(table["mu_front"].to_numpy(float)).any())
    values: dict[str, np.ndarray] = {}
    if axles:
        mp, lo, up = _combined(table)
        informed = np.logical_or.accumulate(table["excited"].to_numpy(bool)) if n else np.zeros(0, bool)
        if method in PEAK_FLAGGING_METHODS:
            observed = table["peak_observed_front"].to_numpy(bool) & table["peak_observed_rear"].to_numpy(bool)
        else:
            observed = up - lo < (p_up - p_lo) * (1.0 - 1e-6)
        observed = observed & informed & np.isfinite(mp)
        values["MostProbable"] = np.where(observed, mp, np.nan)
        values["LowerBound"] = np.where(observed | (informed & (lo > p_lo + _TOL)), lo, np.nan)
        values["UpperBound"] = np.where(observed | (informed & (up < p_up - _TOL)), up, np.nan)
    elif "grip_class" in table.columns:
        cls = table["grip_class"].astype(str).to_numpy()
        # the floor of a 'low' claim about the present surface: the grip used now
        floor = table["grip_now"].to_numpy(float) if "grip_now" in table.columns else np.zeros(n)
        floor = np.minimum(np.maximum(_zero_nan(floor), 0.0), GRIP_CLASS_SPLIT)
        hi, low = cls == "high", cls == "low"
        values["MostProbable"] = np.where(hi, max(p_up, GRIP_CLASS_SPLIT),
                                          np.where(low, np.minimum(np.maximum(p_lo, floor), GRIP_CLASS_SPLIT), np.nan))
        values["LowerBound"] = np.where(hi, GRIP_CLASS_SPLIT, np.where(low & (floor > 0.0), floor, np.nan))
        values["UpperBound"] = np.where(low, GRIP_CLASS_SPLIT, np.nan)
    else:
        raise ValueError("an estimate table needs mu_front/mu_rear or grip_class for VSS output")
    if "diverged" in table.columns:  # a diverged sample makes no claim
        div = table["diverged"].to_numpy(bool)
        for key in values:
            values[key] = np.where(div, np.nan, values[key])
    keys = [(VSS_PREFIX + key, values[key].tolist()) for key in ("MostProbable", "LowerBound", "UpperBound")]
    records: list[dict[str, float]] = []
    for i, ti in enumerate(t.tolist()):
        rec: dict[str, float] = {"t": ti}
        for name, v in keys:
            pct = 100.0 * v[i]
            if math.isfinite(pct) and 0.0 <= pct <= 100.0:
                rec[name] = pct
        records.append(rec)
    return records


def write_vss(
    path: str | Path, table: pd.DataFrame, method: str, prior_band: tuple[float, float]
) -> dict[str, Any]:
    """Write :func:`vss_records` as JSON lines; returns how many lines hold each signal.

    Returns
    -------
    dict
        ``{'lines': n, 'MostProbable': k1, 'LowerBound': k2, 'UpperBound': k3}``.
    """
    records = vss_records(table, method, prior_band)
    with open(path, "w") as fh:
        for rec in records:
            fh.write(json.dumps(rec) + "\n")
    counts = {"lines": len(records)}
    for key in ("MostProbable", "LowerBound", "UpperBound"):
        counts[key] = sum(VSS_PREFIX + key in r for r in records)
    return counts
