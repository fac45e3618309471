r"""Accuracy and calibration of a friction grid against the true friction of its cells.

Map cells and calibration
    Cells with at least ``min_obs`` excited observations are evaluated: mean
    absolute error, the fraction within ``tol``, and the fraction whose truth
    lies inside ``mean ± z(p) std`` for nominal levels ``p`` (a calibration
    curve; a calibrated map has empirical ≈ nominal). Never-excited cells must
    report wide uncertainty; the fraction that do is returned.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.stats import norm

from roadgrip.evaluate._arrays import as_1d as _f
from roadgrip.evaluate._arrays import same_length as _same_len

__all__ = ["MapMetrics", "cell_truth", "map_metrics"]


@dataclass(frozen=True)
class MapMetrics:
    """Accuracy and calibration of a friction grid against true cell friction.

    Attributes
    ----------
    n_cells : int
        Cells with at least ``min_obs`` observations and a known truth.
    mae : float
        Mean absolute error of the cell means [-].
    within_tol : float
        Fraction of evaluated cells within ``tol`` of the truth.
    coverage95 : float
        Fraction of evaluated cells whose truth lies in ``mean ± 1.96 std``.
    calibration : tuple of (float, float)
        ``(nominal, empirical)`` coverage pairs at several nominal levels.
    unobserved_wide : float
        Fraction of never-observed cells whose std is at least ``wide_std`` (NaN: none).
    """

    n_cells: int
    mae: float
    within_tol: float
    coverage95: float
    calibration: tuple[tuple[float, float], ...]
    unobserved_wide: float


def map_metrics(
    mean: ArrayLike,
    std: ArrayLike,
    n_obs: ArrayLike,
    truth: ArrayLike,
    *,
    min_obs: int = 10,
    tol: float = 0.1,
    wide_std: float = 0.2,
    levels: Sequence[float] = (0.5, 0.8, 0.9, 0.95, 0.99),
) -> MapMetrics:
    """Cell error, tolerance hit rate and calibration of a friction map.

    Parameters
    ----------
    mean, std : array_like, shape (C,)
        Cell mean and standard deviation of friction [-] (NaN allowed for
        unobserved cells).
    n_obs : array_like, shape (C,)
        Excited observations fused into each cell.
    truth : array_like, shape (C,)
        True friction of each cell (NaN where unknown).

    Examples
    --------
    >>> m = map_metrics([0.5, 0.8, 0.3], [0.05, 0.05, 1.0], [20, 20, 0], [0.52, 0.5, 0.6])
    >>> m.n_cells, round(m.mae, 3), m.within_tol, m.unobserved_wide
    (2, 0.16, 0.5, 1.0)
    """
    mean, std, nobs, tru = (_f(n, a) for n, a in
                            (("mean", mean), ("std", std), ("n_obs", n_obs), ("truth", truth)))
    _same_len(mean=mean, std=std, n_obs=nobs, truth=tru)
    if np.any(std[np.isfinite(std)] < 0):
        raise ValueError("map std must be non-negative")
    ev = (nobs >= min_obs) & np.isfinite(tru) & np.isfinite(mean) & np.isfinite(std)
    never = nobs <= 0
    unobs_wide = float(np.mean(~np.isfinite(std[never]) | (std[never] >= wide_std))) if never.any() else np.nan
    n = int(ev.sum())
    if n == 0:
        return MapMetrics(0, np.nan, np.nan, np.nan, tuple((p, np.nan) for p in levels), unobs_wide)
    err = np.abs(mean[ev] - tru[ev])
    s = np.maximum(std[ev], 1e-12)
    cal = tuple((float(p), float(np.mean(err <= norm.ppf(0.5 + p / 2.0) * s))) for p in levels)
    cov95 = float(np.mean(err <= 1.959963984540054 * s))
    return MapMetrics(n, float(err.mean()), float(np.mean(err <= tol)), cov95, cal, unobs_wide)


def cell_truth(
    cell_x: ArrayLike,
    cell_y: ArrayLike,
    cell_size: float,
    x: ArrayLike,
    y: ArrayLike,
    mu_true: ArrayLike,
) -> NDArray[np.float64]:
    """True friction of each cell: mean ``mu_true`` of the drive samples inside it.

    Parameters
    ----------
    cell_x, cell_y : array_like, shape (C,)
        Cell centres [m].
    cell_size : float
        Cell edge length [m].
    x, y, mu_true : array_like, shape (n,)
        Sample positions [m] and true friction there.

    Returns
    -------
    ndarray, shape (C,)
        NaN for cells with no sample.

    Examples
    --------
    >>> cell_truth([0.5, 1.5, 5.5], [0.5, 0.5, 0.5], 1.0, [0.2, 0.7, 1.1], [0.5] * 3, [0.4, 0.6, 0.9])
    array([0.5, 0.9, nan])
    """
    cx, cy = _f("cell_x", cell_x), _f("cell_y", cell_y)
    x, y, mu = _f("x", x), _f("y", y), _f("mu_true", mu_true)
    _same_len(x=x, y=y, mu_true=mu)
    if cell_size <= 0:
        raise ValueError(f"cell_size must be positive, got {cell_size}")
    key_c = np.floor(np.c_[cx, cy] / cell_size).astype(np.int64)
    key_s = np.floor(np.c_[x, y] / cell_size).astype(np.int64)
    out = np.full(len(cx), np.nan)
    if len(x) == 0:
        return out
    uniq, inv = np.unique(key_s, axis=0, return_inverse=True)
    inv = inv.ravel()
    sums = np.bincount(inv, weights=mu, minlength=len(uniq))
    cnts = np.bincount(inv, minlength=len(uniq))
    lookup = {tuple(k): i for i, k in enumerate(uniq.tolist())}
    for j, k in enumerate(key_c.tolist()):
        i = lookup.get(tuple(k))
        if i is not None:
            out[j] = sums[i] / cnts[i]
    return out
