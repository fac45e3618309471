r"""Accuracy metrics for friction estimators, computed against known truth.

Every function here takes plain arrays (so it can be checked on hand-made
cases with known answers) and returns a small frozen result object. The
helpers at the end (:func:`true_peak_series`, :func:`truth_grip_class`,
:func:`truth_excitation`, :func:`truth_at_estimates`) derive the truth arrays from a
simulated :class:`~roadgrip.drive.Drive`. The friction-grid metrics are in
:mod:`roadgrip.evaluate.map_metrics`.

Definitions
-----------
Covered slip range
    The slip axis is cut into bins of width ``bin_width`` [rad]; a bin is
    *covered* when the drive visited it at least ``min_visits`` times. Curve
    errors and band coverage are taken over the covered bins only (at their
    centres, or at the curve grid points inside them): a curve is not judged
    where the data never went. The benchmark uses 0.5 deg bins and 20 visits.
95 % band coverage
    Fraction of evaluation points where ``lower <= truth <= upper``.
Grip classes
    ``'high'`` / ``'low'``; the truth class of a sample is ``'high'`` when the
    true peak friction is at least ``threshold`` (default 0.7, between gravel
    0.6 and wet asphalt 0.75 of :data:`roadgrip.tire.SURFACES`).
Sufficient excitation (for detection delays)
    A sample is *sufficiently excited* when the horizontal acceleration
    ``sqrt(ax² + ay²)`` has stayed at or above ``min_accel`` [m/s²] for at least
    ``min_duration`` [s] up to and including it. This is measured on the drive's
    signals, independently of each estimator's own excitation flag.
Detection delay
    For each change of the truth class at ``t_c``: the first sufficiently
    excited time ``t_e >= t_c`` and the first time ``t_d >= t_c`` at which the
    estimate equals the new class and keeps it for ``hold`` seconds. The delay
    is reported both from the change (``t_d - t_c``) and from the first
    excitation (``max(t_d - t_e, 0)``).
Confident wrong claim
    A friction estimate is *confident* when its 95 % band is no wider than
    ``2 * tol`` (and, where the estimator says so, the peak was observed); it is
    *wrong* when ``|estimate - truth| > tol``. A class estimate is confident when
    it is ``'high'`` or ``'low'`` (not ``'unknown'``), wrong when it differs from
    the truth class. The rate is over all evaluated samples.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.constants import GRIP_CLASS_SPLIT
from roadgrip.evaluate._arrays import as_1d as _f
from roadgrip.evaluate._arrays import same_length as _same_len
from roadgrip.truth import has_parametric_truth

__all__ = [
    "ClassificationMetrics",
    "CurveMetrics",
    "DetectionEvent",
    "band_coverage",
    "classification_accuracy",
    "confident_wrong_class_rate",
    "confident_wrong_rate",
    "count_switches",
    "covered_mask",
    "curve_error",
    "detection_delays",
    "peak_error",
    "sustained",
    "true_peak_series",
    "truth_at_estimates",
    "truth_excitation",
    "truth_grip_class",
]

GRIP_THRESHOLD = GRIP_CLASS_SPLIT
"""Default true peak friction [-] that separates 'high' from 'low' grip (the project's one
class split, :data:`roadgrip.constants.GRIP_CLASS_SPLIT`)."""




# -- friction curves ------------------------------------------------------------------
@dataclass(frozen=True)
class CurveMetrics:
    """Error of one friction curve over the covered slip range.

    Attributes
    ----------
    mae : float
        Mean absolute error of the mean curve [-] over covered grid points.
    max_error : float
        Largest absolute error there [-].
    coverage : float
        Fraction of covered grid points whose truth lies in the band (NaN without band).
    slip_range : tuple of float
        Smallest and largest covered grid slip [rad].
    n_points : int
        Number of covered grid points (0: nothing covered, the other fields are NaN).
    """

    mae: float
    max_error: float
    coverage: float
    slip_range: tuple[float, float]
    n_points: int


def covered_mask(
    grid: ArrayLike, visited: ArrayLike, *, bin_width: float = 0.005, min_visits: int = 20
) -> NDArray[np.bool_]:
    """Grid points whose slip bin was visited at least ``min_visits`` times.

    Parameters
    ----------
    grid : array_like, shape (G,)
        Slip values [rad] at which a curve is evaluated.
    visited : array_like, shape (n,)
        Slip values the drive actually went through [rad].
    bin_width : float
        Bin width [rad]; bins are aligned on multiples of ``bin_width``.
    min_visits : int
        Visits a bin needs to count as covered.

    Returns
    -------
    ndarray of bool, shape (G,)

    Examples
    --------
    >>> covered_mask([0.0, 0.012], [0.001] * 20 + [0.011] * 3, bin_width=0.005).tolist()
    [True, False]
    """
    grid = _f("grid", grid)
    visited = _f("visited", visited)
    if bin_width <= 0:
        raise ValueError(f"bin_width must be positive, got {bin_width}")
    visited = visited[np.isfinite(visited)]
    vb = np.floor(visited / bin_width).astype(np.int64)
    gb = np.floor(grid / bin_width).astype(np.int64)
    if vb.size == 0:
        return np.zeros(grid.shape, bool)
    uniq, counts = np.unique(vb, return_counts=True)
    idx = np.searchsorted(uniq, gb)
    idx = np.clip(idx, 0, len(uniq) - 1)
    return (uniq[idx] == gb) & (counts[idx] >= min_visits)


def curve_error(
    grid: ArrayLike,
    mu_mean: ArrayLike,
    mu_true: ArrayLike | Callable[[NDArray[np.float64]], NDArray[np.float64]],
    visited: ArrayLike,
    *,
    mu_lower: ArrayLike | None = None,
    mu_upper: ArrayLike | None = None,
    bin_width: float = 0.005,
    min_visits: int = 20,
    at_bin_centres: bool = False,
) -> CurveMetrics:
    """Friction-curve error and band coverage over the covered slip range.

    Parameters
    ----------
    grid : array_like, shape (G,)
        Slip grid [rad].
    mu_mean : array_like, shape (G,)
        Estimated (posterior-mean) friction on the grid [-].
    mu_true : array_like, shape (G,), or callable
        True friction on the grid, or a function of slip (e.g. ``tire.mu``).
    visited : array_like, shape (n,)
        Slip values visited by the drive [rad] (e.g. ``alpha_f_true``).
    mu_lower, mu_upper : array_like, shape (G,), optional
        95 % band.
    bin_width, min_visits
        See :func:`covered_mask`.
    at_bin_centres : bool
        Evaluate at the centres of the covered bins (curves interpolated
        linearly from the grid, which must be increasing) instead of at the grid
        points that fall in covered bins. With ``bin_width = radians(0.5)`` this is
        the definition of :func:`roadgrip.estimators.gpssm.curve_accuracy`.

    Examples
    --------
    A constant estimate 0.3 against the line ``mu = alpha`` on [0.2, 0.4]:

    >>> g = np.linspace(0.2, 0.4, 201)
    >>> m = curve_error(g, np.full(201, 0.3), lambda a: a, g.repeat(50), bin_width=0.001)
    >>> round(m.mae, 3)
    0.05
    """
    grid = _f("grid", grid)
    mean = _f("mu_mean", mu_mean)
    truth = _f("mu_true", mu_true(grid) if callable(mu_true) else mu_true)
    _same_len(grid=grid, mu_mean=mean, mu_true=truth)
    if at_bin_centres:
        if np.any(np.diff(grid) <= 0):
            raise ValueError("at_bin_centres needs an increasing slip grid")
        v = _f("visited", visited)
        ids, counts = np.unique(np.floor(v[np.isfinite(v)] / bin_width).astype(np.int64),
                                return_counts=True)
        centres = (ids[counts >= min_visits] + 0.5) * bin_width
        centres = centres[(centres >= grid[0]) & (centres <= grid[-1])]
        if centres.size == 0:
            return CurveMetrics(np.nan, np.nan, np.nan, (np.nan, np.nan), 0)
        lo_hi = None
        if mu_lower is not None and mu_upper is not None:
            lo_hi = (np.interp(centres, grid, _f("mu_lower", mu_lower)),
                     np.interp(centres, grid, _f("mu_upper", mu_upper)))
        true_c = mu_true(centres) if callable(mu_true) else np.interp(centres, grid, truth)
        return curve_error(centres, np.interp(centres, grid, mean), np.asarray(true_c, float),
                           centres, mu_lower=None if lo_hi is None else lo_hi[0],
                           mu_upper=None if lo_hi is None else lo_hi[1], bin_width=bin_width,
                           min_visits=1)
    mask = covered_mask(grid, visited, bin_width=bin_width, min_visits=min_visits)
    mask &= np.isfinite(mean) & np.isfinite(truth)
    n = int(mask.sum())
    if n == 0:
        return CurveMetrics(np.nan, np.nan, np.nan, (np.nan, np.nan), 0)
    err = np.abs(mean[mask] - truth[mask])
    cov = np.nan
    if mu_lower is not None and mu_upper is not None:
        lo, hi = _f("mu_lower", mu_lower), _f("mu_upper", mu_upper)
        _same_len(grid=grid, mu_lower=lo, mu_upper=hi)
        cov = band_coverage(truth[mask], lo[mask], hi[mask])
    g = grid[mask]
    return CurveMetrics(float(err.mean()), float(err.max()), cov, (float(g.min()), float(g.max())), n)


def peak_error(estimate: float, truth: float) -> float:
    """Signed peak-friction error ``estimate - truth`` [-]; raises on non-finite input.

    >>> round(peak_error(0.32, 0.3), 6)
    0.02
    """
    if not (np.isfinite(estimate) and np.isfinite(truth)):
        raise ValueError(f"peak_error needs finite values, got estimate={estimate}, truth={truth}")
    return float(estimate) - float(truth)


def band_coverage(truth: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> float:
    """Fraction of points with ``lower <= truth <= upper``.

    Points where any of the three is NaN are left out; if none remain the
    result is NaN. Raises when ``lower > upper`` anywhere (a malformed band).

    >>> band_coverage([0.5, 0.5, 0.5, 0.5], [0.4, 0.6, 0.0, 0.5], [0.6, 0.7, 1.0, 0.5])
    0.75
    """
    truth, lower, upper = _f("truth", truth), _f("lower", lower), _f("upper", upper)
    _same_len(truth=truth, lower=lower, upper=upper)
    ok = np.isfinite(truth) & np.isfinite(lower) & np.isfinite(upper)
    if np.any(lower[ok] > upper[ok]):
        raise ValueError("band has lower > upper at some points")
    if not ok.any():
        return float("nan")
    inside = (truth[ok] >= lower[ok]) & (truth[ok] <= upper[ok])
    return float(inside.mean())


# -- classification -------------------------------------------------------------------
@dataclass(frozen=True)
class ClassificationMetrics:
    """Accuracy of a grip-class trace.

    Attributes
    ----------
    accuracy : float
        Fraction of evaluated samples whose class equals the truth class
        (``'unknown'`` counts as wrong).
    unknown_fraction : float
        Fraction of evaluated samples classified ``'unknown'``.
    n_samples : int
        Evaluated samples.
    """

    accuracy: float
    unknown_fraction: float
    n_samples: int


def classification_accuracy(
    predicted: Sequence[str] | NDArray, truth: Sequence[str] | NDArray, mask: ArrayLike | None = None
) -> ClassificationMetrics:
    """Fraction of samples (where ``mask``) classified as the truth class.

    >>> classification_accuracy(['high', 'low', 'unknown', 'low'], ['high'] * 2 + ['low'] * 2).accuracy
    0.5
    """
    pred = np.asarray(predicted).astype(str)
    tru = np.asarray(truth).astype(str)
    _same_len(predicted=pred, truth=tru)
    m = np.ones(len(pred), bool) if mask is None else np.asarray(mask, bool)
    _same_len(predicted=pred, mask=m)
    n = int(m.sum())
    if n == 0:
        return ClassificationMetrics(np.nan, np.nan, 0)
    return ClassificationMetrics(
        float((pred[m] == tru[m]).mean()), float((pred[m] == "unknown").mean()), n
    )


@dataclass(frozen=True)
class DetectionEvent:
    """One change of the true class and how the estimate followed it.

    Attributes
    ----------
    t_change : float
        Time of the true change [s].
    new_class : str
        Class after the change.
    t_excited : float
        First sufficiently excited time at or after the change [s] (NaN: none).
    t_detected : float
        First time the estimate took the new class and held it [s] (NaN: never).
    delay_from_change, delay_from_excitation : float
        ``t_detected - t_change`` and ``max(t_detected - t_excited, 0)`` [s].
    """

    t_change: float
    new_class: str
    t_excited: float
    t_detected: float
    delay_from_change: float
    delay_from_excitation: float

    @property
    def detected(self) -> bool:
        return bool(np.isfinite(self.t_detected))


def sustained(flag: ArrayLike, t: ArrayLike, min_duration: float) -> NDArray[np.bool_]:
    """``True`` where ``flag`` has been true for at least ``min_duration`` seconds.

    >>> sustained([0, 1, 1, 1, 0, 1], np.arange(6) * 0.1, 0.1).tolist()
    [False, False, True, True, False, False]
    """
    f = np.asarray(flag, bool)
    t = _f("t", t)
    _same_len(flag=f, t=t)
    # Start time of the current run of True values at every sample.
    starts = np.where(f & ~np.r_[False, f[:-1]], t, -np.inf)
    run_start = np.maximum.accumulate(starts)
    return f & (t - run_start >= min_duration - 1e-12)


def detection_delays(
    t: ArrayLike,
    predicted: Sequence[str] | NDArray,
    truth: Sequence[str] | NDArray,
    excited: ArrayLike,
    *,
    hold: float = 0.0,
) -> list[DetectionEvent]:
    """Delays with which a class estimate follows each change of the truth class.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s].
    predicted, truth : sequence of str, shape (n,)
        Estimated and true class per sample.
    excited : array_like of bool, shape (n,)
        Sufficient excitation (see :func:`truth_excitation`).
    hold : float
        The estimate must keep the new class this long [s] to count as detected.

    Examples
    --------
    Truth switches to 'low' at t = 1 s, excitation starts at 1.5 s and the
    estimate follows at 2 s:

    >>> t = np.arange(0, 4, 0.5)
    >>> ev = detection_delays(t, ['high'] * 4 + ['low'] * 4, ['high'] * 2 + ['low'] * 6,
    ...                       t >= 1.5)[0]
    >>> ev.delay_from_change, ev.delay_from_excitation
    (1.0, 0.5)
    """
    t = _f("t", t)
    pred = np.asarray(predicted).astype(str)
    tru = np.asarray(truth).astype(str)
    exc = np.asarray(excited, bool)
    _same_len(t=t, predicted=pred, truth=tru, excited=exc)
    changes = np.flatnonzero(tru[1:] != tru[:-1]) + 1
    bounds = [*changes.tolist(), len(t)]
    events = []
    for k, i in enumerate(changes):
        end = bounds[k + 1]  # the truth keeps this class until the next change
        new = tru[i]
        seg = slice(i, end)
        e_idx = np.flatnonzero(exc[seg])
        t_exc = float(t[i + e_idx[0]]) if e_idx.size else np.nan
        match = pred[seg] == new
        held = np.flatnonzero(sustained(match, t[seg], hold) if hold > 0 else match)
        t_det = np.nan
        if held.size:
            # The detection time is the start of the first run that held long enough.
            starts = np.flatnonzero(match & ~np.r_[False, match[:-1]])
            t_det = float(t[i + starts[starts <= held[0]][-1]])
        d_change = t_det - float(t[i]) if np.isfinite(t_det) else np.nan
        d_exc = max(t_det - t_exc, 0.0) if np.isfinite(t_det) and np.isfinite(t_exc) else np.nan
        events.append(DetectionEvent(float(t[i]), str(new), t_exc, t_det, d_change, d_exc))
    return events


def count_switches(classes: Sequence[str] | NDArray) -> int:
    """Number of changes between confident classes (``'unknown'`` samples are skipped).

    >>> count_switches(['high', 'unknown', 'high', 'low', 'unknown', 'high'])
    2
    """
    c = np.asarray(classes).astype(str)
    c = c[c != "unknown"]
    return int(np.sum(c[1:] != c[:-1])) if c.size else 0


def confident_wrong_class_rate(
    predicted: Sequence[str] | NDArray, truth: Sequence[str] | NDArray
) -> float:
    """Fraction of samples with a confident class ('high'/'low') that differs from the truth.

    >>> confident_wrong_class_rate(['high', 'low', 'unknown', 'low'], ['high'] * 4)
    0.5
    """
    pred = np.asarray(predicted).astype(str)
    tru = np.asarray(truth).astype(str)
    _same_len(predicted=pred, truth=tru)
    if pred.size == 0:
        return float("nan")
    return float(((pred != "unknown") & (pred != tru)).mean())


def confident_wrong_rate(
    estimate: ArrayLike,
    lower: ArrayLike,
    upper: ArrayLike,
    truth: ArrayLike,
    *,
    tol: float = 0.1,
    observed: ArrayLike | None = None,
) -> float:
    """Fraction of samples with a confident friction estimate more than ``tol`` off.

    Confident: finite band no wider than ``2 * tol`` and (when ``observed`` is
    given) the estimator reports the peak as observed. Samples with NaN truth
    are left out.

    >>> confident_wrong_rate([0.5, 0.5, 0.9], [0.45, 0.1, 0.85], [0.55, 0.9, 0.95], [0.5, 1.0, 0.5])
    0.3333333333333333
    """
    est, lo, hi, tru = (_f(n, a) for n, a in
                        (("estimate", estimate), ("lower", lower), ("upper", upper), ("truth", truth)))
    _same_len(estimate=est, lower=lo, upper=hi, truth=tru)
    ok = np.isfinite(tru)
    if not ok.any():
        return float("nan")
    width = hi - lo
    confident = np.isfinite(width) & (width <= 2.0 * tol + 1e-9) & np.isfinite(est)
    if observed is not None:
        obs = np.asarray(observed, bool)
        _same_len(estimate=est, observed=obs)
        confident &= obs
    wrong = np.abs(np.where(np.isfinite(est), est, 0.0) - np.where(ok, tru, 0.0)) > tol
    return float((confident & wrong)[ok].mean())


# -- truth from a simulated drive -----------------------------------------------------
def true_peak_series(drive, axle: str = "front", direction: str = "lateral") -> NDArray[np.float64]:
    """True peak friction of ``axle`` at every sample of a simulated drive, shape (n,).

    Uses the surface label of each sample and the drive's true tire models
    (the peak of the ``axle`` curve in ``direction``). Falls back to the
    ``mu_true`` column (the surface's peak friction) when the drive carries no
    parametric tire model for some sample's surface, in particular for drives
    whose truth is binned (surfaces given as ``{'mu': float}`` only, see
    :mod:`roadgrip.truth`). Raises ``ValueError`` when the drive carries
    neither.
    """
    truth = drive.meta.truth or {}
    surfaces = truth.get("surfaces")
    if surfaces and "surface" in drive.data.columns:
        labels = drive.data["surface"].astype(str).to_numpy()
        out = np.full(len(labels), np.nan)
        for name in np.unique(labels):
            if name in surfaces and has_parametric_truth(drive, axle, direction, name):
                out[labels == name] = drive.true_tire(axle, direction, name).peak()[1]
        if np.isfinite(out).all():
            return out
    if "mu_true" in drive.data.columns:
        return drive.col("mu_true")
    raise ValueError(f"drive from {drive.meta.source} carries no friction truth")


def truth_grip_class(mu_peak: ArrayLike, threshold: float = GRIP_THRESHOLD) -> NDArray[np.str_]:
    """'high' where the true peak friction is at least ``threshold``, else 'low'.

    >>> truth_grip_class([1.0, 0.6, 0.7]).tolist()
    ['high', 'low', 'high']
    """
    mu = np.asarray(mu_peak, float)
    return np.where(mu >= threshold, "high", "low")


def truth_excitation(
    drive, *, min_accel: float = 2.0, min_duration: float = 0.3
) -> NDArray[np.bool_]:
    """Sufficient excitation of each sample, from the measured accelerations.

    A sample is sufficiently excited when ``sqrt(ax² + ay²) >= min_accel``
    [m/s²] has held for ``min_duration`` [s] (see the module docstring).
    Missing ``ax`` or ``ay`` counts as zero; a drive with neither raises.
    """
    if not (drive.has("ax") or drive.has("ay")):
        raise ValueError(f"drive from {drive.meta.source} has neither 'ax' nor 'ay'")
    ax = drive.col("ax") if drive.has("ax") else 0.0
    ay = drive.col("ay") if drive.has("ay") else 0.0
    a = np.hypot(ax, ay) * np.ones(drive.n)
    return sustained(a >= min_accel, drive.t, min_duration)


def truth_at_estimates(drive, table, values: ArrayLike) -> NDArray:
    """A per-sample truth series of ``drive`` sampled at the estimate times of ``table``.

    Estimators may drop leading samples or run at their own rate; each estimate
    takes the truth of the first drive sample at or after its time ``t`` [s]
    (the same sample when the times coincide).

    Parameters
    ----------
    drive : Drive
    table : DataFrame
        Estimates with a ``t`` column [s].
    values : array, shape (drive.n,)
        The truth at every drive sample.

    Returns
    -------
    array, shape (len(table),)
    """
    values = np.asarray(values)
    t_est = table["t"].to_numpy(float)
    if len(t_est) == drive.n and np.allclose(t_est, drive.t):
        return values
    idx = np.clip(np.searchsorted(drive.t, t_est - 1e-9), 0, drive.n - 1)
    return values[idx]
