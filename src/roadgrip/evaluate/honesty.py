r"""The honesty rule: when a published claim is wrong. One definition for the whole project.

Every estimator publishes claims, and every output path carries them: the estimate
table, ``meta['summary']`` and the VSS lines (:mod:`roadgrip.io.vss`). This module says
when a claim is **wrong**; the tests, the benchmark (``benchmarks/honesty_matrix.py``)
and the report all use it.

Claims
------
Peak-friction band
    ``[lower, upper]`` of one axle (``mu_<axle>_lower`` / ``mu_<axle>_upper``), of the
    road (the VSS ``LowerBound`` / ``UpperBound``, the summary). A missing end is no
    claim on that side; a lower end of 0 and an upper end of ``peak_max`` never exclude
    anything.
Grip class
    ``'high'`` (peak friction at least :data:`~roadgrip.constants.GRIP_CLASS_SPLIT`) or
    ``'low'`` (below it); ``'unknown'`` claims nothing.
Lateral-velocity band
    ``vy ± Z95 vy_std`` [m/s], where a method publishes ``vy_std``.

A sample flagged ``diverged`` makes no claim in the table; its VSS line must then be
empty, and a VSS value there is judged like any other.

What is known
-------------
* Drives with friction truth (the simulator, the multi-body engine): the true peak
  friction of each axle (:func:`~roadgrip.evaluate.metrics.true_peak_series`); a band
  is wrong when it excludes it by more than :func:`peak_tolerance` (0.03 or 8 %,
  whichever is larger: camber lifts an axle's peak up to about 7 % above the
  surface's). The road band is wrong when it lies wholly above both axles' truth or
  wholly below both. A class is wrong when it differs from the class of the surface's
  true peak friction (``mu_true``).
* Recordings without friction truth: the friction the car demonstrably used up to that
  sample, the largest 1-s mean ``|a_y| / g`` so far (:func:`roadgrip.signals.sustained_grip`)
  less :data:`FLOOR_MARGIN`: an upper end below it is wrong, and so is ``'low'`` when
  the floor is at least the class split.
* A lateral-velocity reference (simulator truth ``vy_true``, INS, motion capture): the
  band is wrong when it misses the reference by more than :data:`VY_MARGIN`.

Surface changes
---------------
No estimator can know of a change before the data show it. After each change of the
true friction at ``t_c``, claims are not judged until 1 s (:data:`CHANGE_GRACE_S`) after
the first sample whose true utilisation (the larger axle's) reaches
:data:`CHANGE_UTIL`, and never for longer than :data:`CHANGE_MAX_S` after ``t_c``: a
claim that outlives its evidence by more is judged.

Informative
-----------
A band narrower than :data:`INFORMATIVE_WIDTH`, or a class.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import GRIP_CLASS_SPLIT, Z95
from roadgrip.evaluate.metrics import true_peak_series, truth_at_estimates
from roadgrip.signals import sustained_grip

__all__ = [
    "CHANGE_GRACE_S",
    "CHANGE_MAX_S",
    "CHANGE_UTIL",
    "FLOOR_MARGIN",
    "INFORMATIVE_WIDTH",
    "PEAK_TOL_ABS",
    "PEAK_TOL_REL",
    "VY_MARGIN",
    "WRONG_SHARE_MAX",
    "HonestyScore",
    "Knowledge",
    "band_wrong",
    "class_wrong",
    "judged_samples",
    "knowledge",
    "peak_tolerance",
    "reference_vy",
    "score_result",
    "vy_wrong",
]

PEAK_TOL_ABS = 0.03
"""Absolute tolerance of a band against the true peak friction [-]."""
PEAK_TOL_REL = 0.08
"""Relative tolerance of a band against the true peak friction [-] (camber: up to 7 %)."""
FLOOR_MARGIN = 0.02
"""Margin below the demonstrated friction ``max 1-s mean |a_y| / g`` [-]."""
VY_MARGIN = 0.1
"""Margin of a lateral-velocity band against its reference [m/s]."""
CHANGE_UTIL = 0.6
"""True utilisation [-] from which a new surface has shown itself."""
CHANGE_GRACE_S = 1.0
"""Time after that first informative sample before claims are judged [s]."""
CHANGE_MAX_S = 10.0
"""Longest a claim is excused after a true change [s]."""
INFORMATIVE_WIDTH = 0.5
"""A band narrower than this [-] is informative."""
WRONG_SHARE_MAX = 0.001
"""Largest share of samples with a wrong claim that the project accepts (0.1 %)."""


def peak_tolerance(truth: ArrayLike) -> NDArray[np.float64]:
    """How far a band may miss the true peak friction: ``max(0.03, 0.08 truth)`` [-].

    >>> peak_tolerance([0.3, 1.0]).round(3).tolist()
    [0.03, 0.08]
    """
    return np.maximum(PEAK_TOL_ABS, PEAK_TOL_REL * np.abs(np.asarray(truth, float)))


def band_wrong(lower: ArrayLike, upper: ArrayLike, truth_low: ArrayLike, truth_high: ArrayLike,
               floor: ArrayLike) -> NDArray[np.bool_]:
    """Samples where a friction band ``[lower, upper]`` is wrong, shape (n,).

    Parameters
    ----------
    lower, upper : array_like, shape (n,)
        The band [-]; NaN is no claim on that side.
    truth_low, truth_high : array_like, shape (n,)
        The range of true peak frictions the band speaks of [-] (equal for one axle;
        the two axles' for the road); NaN where there is no truth.
    floor : array_like, shape (n,)
        The demonstrated friction [-], judged only where there is no truth; NaN or 0
        where nothing is known.

    Examples
    --------
    >>> band_wrong([0.2, 0.5, 0.0], [0.4, 0.9, 0.5], [0.45, 0.3, np.nan],
    ...            [0.45, 0.3, np.nan], [0.0, 0.0, 0.6]).tolist()
    [True, True, True]
    >>> band_wrong([0.2], [0.42], [0.45], [0.45], [0.0]).tolist()
    [False]
    """
    lo = np.asarray(lower, float)
    up = np.asarray(upper, float)
    t_lo = np.asarray(truth_low, float)
    t_hi = np.asarray(truth_high, float)
    fl = np.asarray(floor, float)
    known = np.isfinite(t_lo) & np.isfinite(t_hi)
    with np.errstate(invalid="ignore"):
        above = np.isfinite(lo) & (lo > t_hi + peak_tolerance(np.nan_to_num(t_hi)))
        below = np.isfinite(up) & (up < t_lo - peak_tolerance(np.nan_to_num(t_lo)))
        under_floor = np.isfinite(up) & np.isfinite(fl) & (up < fl)
    return np.where(known, above | below, under_floor)


def class_wrong(grip_class: ArrayLike, truth: ArrayLike, floor: ArrayLike) -> NDArray[np.bool_]:
    """Samples where a grip class is wrong, shape (n,).

    With truth (the surface's true peak friction [-]): a 'high' or 'low' that differs
    from the class of the truth. Without (NaN): a 'low' where the demonstrated friction
    ``floor`` [-] reaches the class split.

    >>> class_wrong(['high', 'low', 'unknown', 'low'], [0.6, 1.0, 0.6, np.nan],
    ...             [0.0, 0.0, 0.0, 0.75]).tolist()
    [True, True, False, True]
    """
    cls = np.asarray(grip_class).astype(str)
    tru = np.asarray(truth, float)
    fl = np.asarray(floor, float)
    known = np.isfinite(tru)
    with np.errstate(invalid="ignore"):
        true_high = tru >= GRIP_CLASS_SPLIT
        wrong_truth = ((cls == "high") & ~true_high) | ((cls == "low") & true_high)
        wrong_floor = (cls == "low") & np.isfinite(fl) & (fl >= GRIP_CLASS_SPLIT)
    return np.where(known, wrong_truth, wrong_floor)


def vy_wrong(vy: ArrayLike, vy_std: ArrayLike, vy_ref: ArrayLike) -> NDArray[np.bool_]:
    """Samples where ``vy ± Z95 vy_std`` misses the reference by more than :data:`VY_MARGIN`.

    NaN reference: not judged. A NaN estimate or std where the reference exists is wrong
    (an estimator never silently returns NaN).

    >>> vy_wrong([0.0, 0.0, 1.0], [0.1, 0.1, 0.0], [0.25, 0.35, np.nan]).tolist()
    [False, True, False]
    """
    vy = np.asarray(vy, float)
    sd = np.asarray(vy_std, float)
    ref = np.asarray(vy_ref, float)
    with np.errstate(invalid="ignore"):
        miss = ~(np.abs(vy - ref) <= Z95 * sd + VY_MARGIN)
    return np.isfinite(ref) & miss


@dataclass(frozen=True)
class Knowledge:
    """What is known at each estimate sample, arrays of shape (n,).

    Attributes
    ----------
    peak_front, peak_rear : ndarray
        True peak friction per axle [-]; NaN without truth.
    surface : ndarray
        True peak friction of the surface (``mu_true``) [-], for classes; NaN without.
    floor : ndarray
        Demonstrated friction less :data:`FLOOR_MARGIN` [-] (0 before a second of data).
    judged : ndarray of bool
        False inside the grace window after a true surface change.
    vy_ref : ndarray or None
        Reference lateral velocity [m/s], NaN where unknown.
    """

    peak_front: NDArray[np.float64]
    peak_rear: NDArray[np.float64]
    surface: NDArray[np.float64]
    floor: NDArray[np.float64]
    judged: NDArray[np.bool_]
    vy_ref: NDArray[np.float64] | None


def judged_samples(t: ArrayLike, truth: ArrayLike, util: ArrayLike) -> NDArray[np.bool_]:
    """Samples outside the grace windows of the true changes (module docstring), shape (n,).

    Parameters
    ----------
    t : array_like, shape (n,)
        Times [s].
    truth : array_like, shape (n,)
        True surface friction [-]; a change is a step larger than the peak tolerance.
    util : array_like, shape (n,)
        True utilisation of the more-used axle [-].

    >>> t = np.arange(0.0, 30.0, 1.0)
    >>> mu = np.r_[np.full(10, 1.0), np.full(20, 0.5)]
    >>> util = np.r_[np.zeros(15), np.full(15, 0.8)]
    >>> np.flatnonzero(~judged_samples(t, mu, util)).tolist()
    [10, 11, 12, 13, 14, 15]
    """
    t = np.asarray(t, float)
    mu = np.asarray(truth, float)
    u = np.asarray(util, float)
    ok = np.ones(len(t), bool)
    if len(t) < 2:
        return ok
    step = np.abs(np.diff(mu)) > peak_tolerance(np.minimum(mu[1:], mu[:-1]))
    changes = np.flatnonzero(step) + 1
    ends = np.r_[changes[1:], len(t)].astype(int)
    if changes.size == 0:
        return ok
    for i0, i1 in zip(changes, ends, strict=True):
        t_c = t[i0]
        shown = np.flatnonzero(u[i0:i1] >= CHANGE_UTIL)
        t_end = t_c + CHANGE_MAX_S
        if shown.size:
            t_end = min(t_end, t[i0 + shown[0]] + CHANGE_GRACE_S)
        ok &= ~((t >= t_c) & (t < t_end))
    return ok


def reference_vy(path: str | Path, t: ArrayLike) -> NDArray[np.float64] | None:
    """The reference lateral velocity of a recording at times ``t`` [m/s], or None.

    A recording ``NAME.csv`` may have ``NAME_reference.csv`` beside it with columns
    ``t`` [s] and ``vy_ref`` [m/s] (an INS): interpolated, NaN outside its span.
    """
    p = Path(path)
    ref = p.with_name(p.stem + "_reference.csv")
    if not ref.exists():
        return None
    tab = pd.read_csv(ref)
    if not {"t", "vy_ref"} <= set(tab.columns):
        return None
    tr, vr = tab["t"].to_numpy(float), tab["vy_ref"].to_numpy(float)
    return np.interp(np.asarray(t, float), tr, vr, left=np.nan, right=np.nan)


def knowledge(drive: Any, t_est: ArrayLike, vy_ref: ArrayLike | None = None) -> Knowledge:
    """What the honesty rule knows at the estimate times ``t_est`` [s] of a drive.

    Parameters
    ----------
    drive : Drive
        The drive the estimates were made from (its truth columns when simulated).
    t_est : array_like, shape (n,)
        Estimate times [s].
    vy_ref : array_like, shape (drive.n,), optional
        A reference lateral velocity [m/s] of a recording (e.g. :func:`reference_vy`);
        a simulated drive's ``vy_true`` is used without it.
    """
    tab = pd.DataFrame({"t": np.asarray(t_est, float)})
    n = len(tab)
    nan = np.full(n, np.nan)
    if drive.has("mu_true"):
        at = lambda v: truth_at_estimates(drive, tab, v).astype(float)  # noqa: E731
        pf, pr = at(true_peak_series(drive, "front")), at(true_peak_series(drive, "rear"))
        surface = at(drive.col("mu_true"))
        util = np.zeros(drive.n)
        for c in ("util_f_true", "util_r_true"):
            if drive.has(c):
                util = np.maximum(util, np.nan_to_num(drive.col(c)))
        judged = at(judged_samples(drive.t, drive.col("mu_true"), util).astype(float)) > 0.5
        floor = nan
    else:
        pf = pr = surface = nan
        judged = np.ones(n, bool)
        if drive.has("ay"):
            fl = np.maximum(sustained_grip(drive.t, np.nan_to_num(drive.col("ay"))) - FLOOR_MARGIN, 0.0)
            floor = truth_at_estimates(drive, tab, fl).astype(float)
        else:
            floor = nan
    ref = None
    if vy_ref is not None:
        ref = truth_at_estimates(drive, tab, np.asarray(vy_ref, float)).astype(float)
    elif drive.has("vy_true"):
        ref = truth_at_estimates(drive, tab, drive.col("vy_true")).astype(float)
    return Knowledge(pf, pr, surface, floor, judged, ref)


@dataclass(frozen=True)
class HonestyScore:
    """The honesty of one estimator run on one drive (shares of the judged samples).

    Attributes
    ----------
    n : int
        Estimate samples.
    wrong_axle, wrong_vss, wrong_class, wrong_vy : float
        Share of samples with a wrong claim in the table's per-axle bands, in the VSS
        lines, in the grip class and in the lateral-velocity band (NaN where the run
        makes no such claim or nothing can judge it).
    summary_wrong : bool
        The final ``meta['summary']`` band is wrong at the last sample.
    informative : float
        Share of samples with an informative claim (a band narrower than
        :data:`INFORMATIVE_WIDTH` on either axle, or a class).
    width : float
        Median width of the informative bands [-] (NaN for classes only).
    diverged : float
        Share of samples flagged ``diverged``.
    """

    n: int
    wrong_axle: float
    wrong_vss: float
    wrong_class: float
    wrong_vy: float
    summary_wrong: bool
    informative: float
    width: float
    diverged: float

    @property
    def wrong(self) -> float:
        """The largest share of wrong claims over the output paths (0 when none judged)."""
        shares = [s for s in (self.wrong_axle, self.wrong_vss, self.wrong_class, self.wrong_vy)
                  if np.isfinite(s)]
        return max(shares, default=0.0)

    @property
    def honest(self) -> bool:
        """At most :data:`WRONG_SHARE_MAX` wrong on every path, and the summary not wrong."""
        return self.wrong <= WRONG_SHARE_MAX and not self.summary_wrong


def _share(wrong: NDArray[np.bool_], judged: NDArray[np.bool_]) -> float:
    return float(wrong[judged].mean()) if judged.any() else float("nan")


def _vss_bands(table: pd.DataFrame, method: str, prior_band: tuple[float, float]) -> tuple[NDArray, NDArray]:
    from roadgrip.io.vss import VSS_PREFIX, vss_records

    recs = vss_records(table, method, prior_band)
    lo = np.array([r.get(VSS_PREFIX + "LowerBound", np.nan) for r in recs], float) / 100.0
    up = np.array([r.get(VSS_PREFIX + "UpperBound", np.nan) for r in recs], float) / 100.0
    return lo, up


def score_result(result: Any, drive: Any, *, prior_band: tuple[float, float] | None = None,
                 vy_ref: ArrayLike | None = None) -> HonestyScore:
    """Judge every claim of an estimator run by the rule of this module.

    Parameters
    ----------
    result : EstimateResult
        The run (its table, ``meta['summary']`` and its VSS lines are judged).
    drive : Drive
        The drive it ran on.
    prior_band : (float, float), optional
        The method's prior band for the VSS lines (default: the estimator's
        ``prior_band`` of the configuration in ``meta['config']``).
    vy_ref : array_like, shape (drive.n,), optional
        Reference lateral velocity of a recording [m/s].
    """
    table = result.table
    n = len(table)
    k = knowledge(drive, table["t"].to_numpy(float), vy_ref)
    diverged = table["diverged"].to_numpy(bool) if "diverged" in table.columns else np.zeros(n, bool)
    claims = k.judged & ~diverged
    road_lo = np.fmin(k.peak_front, k.peak_rear)
    road_hi = np.fmax(k.peak_front, k.peak_rear)
    wrong_axle = wrong_vss = wrong_class = wrong_vy = float("nan")
    informative = np.zeros(n, bool)
    widths: list[NDArray] = []
    has_bands = "mu_front_lower" in table.columns and np.isfinite(table["mu_front_lower"].to_numpy(float)).any()
    if has_bands:
        w = np.zeros(n, bool)
        for axle, truth in (("front", k.peak_front), ("rear", k.peak_rear)):
            lo = table[f"mu_{axle}_lower"].to_numpy(float)
            up = table[f"mu_{axle}_upper"].to_numpy(float)
            w |= band_wrong(lo, up, truth, truth, k.floor)
            inf = (up - lo) < INFORMATIVE_WIDTH
            informative |= inf & ~diverged
            widths.append((up - lo)[inf & ~diverged])
        wrong_axle = _share(w, claims)
    if "grip_class" in table.columns and (table["grip_class"].astype(str) != "unknown").any():
        cls = table["grip_class"].astype(str).to_numpy()
        wrong_class = _share(class_wrong(cls, k.surface, k.floor), claims)
        informative |= (cls != "unknown") & ~diverged
    if prior_band is None:
        prior_band = _prior_band(result)
    if has_bands or "grip_class" in table.columns:
        vlo, vup = _vss_bands(table, result.method, prior_band)
        wrong_vss = _share(band_wrong(vlo, vup, road_lo, road_hi, k.floor), k.judged)
    if "vy_std" in table.columns and k.vy_ref is not None and np.isfinite(k.vy_ref).any():
        wv = vy_wrong(table["vy"].to_numpy(float), table["vy_std"].to_numpy(float), k.vy_ref)
        wrong_vy = _share(wv, claims)
    summary_wrong = False
    s = result.meta.get("summary") or {}
    if n and {"LowerBound", "UpperBound"} <= set(s) and k.judged[-1] and not diverged[-1]:
        summary_wrong = bool(band_wrong([s["LowerBound"]], [s["UpperBound"]], road_lo[-1:],
                                        road_hi[-1:], k.floor[-1:])[0])
    width = np.concatenate(widths) if widths else np.zeros(0)
    return HonestyScore(
        n=n, wrong_axle=wrong_axle, wrong_vss=wrong_vss, wrong_class=wrong_class,
        wrong_vy=wrong_vy, summary_wrong=summary_wrong,
        informative=float(informative.mean()) if n else float("nan"),
        width=float(np.median(width)) if width.size else float("nan"),
        diverged=float(diverged.mean()) if n else float("nan"),
    )


def _prior_band(result: Any) -> tuple[float, float]:
    """The run's prior band from its method and the configuration in its metadata."""
    from roadgrip.estimators import get

    est = get(result.method)
    try:
        config = est.Config.from_options(result.meta.get("config") or None)
    except (TypeError, ValueError):
        config = est.Config()
    return tuple(float(v) for v in est.prior_band(config))
