r"""True axle friction curves and friction utilisation of a simulated drive.

A simulated drive states its true lateral friction curve mu(alpha) per axle in one
of two ways:

Parametric
    ``meta.truth['surfaces'][label]`` holds the tire curves (keys ``'front'``,
    ``'rear'``, ``'front_long'``, ``'rear_long'``) and :meth:`Drive.true_tire`
    rebuilds them. The planar and lateral models of :mod:`roadgrip.sim` do this.
Binned
    ``meta.truth['truth_curve'] == 'binned'``, or the surfaces carry only their
    peak friction ``{'mu': float}``. The true curve is then *defined* by the
    drive's own truth columns: the axle's ``Fy / Fz`` against its slip angle,
    averaged in slip bins (:func:`binned_truth_curve`). A multi-body model, whose
    single-track axle force is not one function of the single-track slip angle,
    states its truth this way.

:func:`true_curve` returns ``mu(alpha)`` for either kind, so that scores computed
against it (:mod:`roadgrip.evaluate.suite`) do not depend on how the truth is stored.

Binned curve
------------
Samples enter the curve of ``axle`` on ``surface`` when

* ``Fz > 0`` (a lifted axle carries no friction information),
* ``|Fx| / Fz <= max_long`` (default :data:`PURE_LATERAL_MAX_FX`, 0.05): the curve is the
  pure-lateral one. Under a friction-ellipse combined-slip law with longitudinal peak
  ``D_x`` (:mod:`roadgrip.vehicle.planar`), a longitudinal friction of 0.05 scales the
  lateral force by no less than ``sqrt(1 - (0.05 / D_x)²)``: at most 0.13 % of it lost
  on dry asphalt (``D_x = 1.0``), 0.35 % on gravel (0.6), 1.4 % on snow (0.3);
* all of ``alpha``, ``Fx``, ``Fy``, ``Fz`` are finite.

The slip axis is cut into bins of width ``bin_width`` aligned on its multiples (as
:func:`roadgrip.evaluate.metrics.covered_mask`); a bin is *visited* when at least
``min_count`` samples fall in it. Each visited bin keeps its count, the mean slip of its
samples (its centroid ``alpha_mean``) and the mean ``Fy / Fz`` (``mu_mean``). Because the
mean of a linear function is the function at the mean, ``(alpha_mean, mu_mean)`` lies on
the curve up to its curvature, whereas ``mu_mean`` read at the bin *centre* would carry
the slope times the offset of the samples within the bin (up to half a bin, i.e. 0.07 at
a slope of 16 /rad and the default 0.5 deg bins). Evaluating the curve,
:meth:`BinnedCurve.__call__`, therefore interpolates linearly between the centroids of
adjacent visited bins and extrapolates the end segment of a run of adjacent visited bins
to the run's outer bin edges; a visited bin with no visited neighbour is constant at its
``mu_mean``. Slips whose bin was not visited give NaN. With ``max|mu''|`` the curvature
over the visited range, the error at any point of a run is below about
``2 bin_width² max|mu''|`` (interpolation over at most two bin widths, extrapolation over
at most one, plus the in-bin averaging).

Utilisation
-----------
:func:`friction_utilisation`: the fraction of the available friction an axle uses,
``sqrt(Fx² + Fy²) / (mu Fz)`` [-], from the ``util_f_true`` / ``util_r_true`` columns
when the drive carries them, otherwise computed from the axle forces and ``mu_true``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEFAULT_BIN_WIDTH",
    "DEFAULT_MIN_COUNT",
    "PURE_LATERAL_MAX_FX",
    "BinnedCurve",
    "binned_truth_curve",
    "friction_utilisation",
    "has_parametric_truth",
    "true_curve",
    "utilisation_source",
]

DEFAULT_BIN_WIDTH = float(np.radians(0.5))
"""Default slip bin width [rad]: the benchmark's curve bins (0.5 deg)."""

DEFAULT_MIN_COUNT = 10
"""Default number of pure-lateral samples a bin needs to count as visited."""

PURE_LATERAL_MAX_FX = 0.05
"""Largest ``|Fx| / Fz`` [-] of a sample that enters the pure-lateral binned curve."""

_AXLES = ("front", "rear")


def _check_axle(axle: str) -> str:
    if axle not in _AXLES:
        raise ValueError(f"axle must be 'front' or 'rear', got {axle!r}")
    return axle[0]


@dataclass(frozen=True)
class BinnedCurve:
    """True lateral friction curve of one axle, binned from the drive's truth columns.

    Only visited bins are kept (see the module docstring). Call the object for
    ``mu(alpha)``.

    Attributes
    ----------
    axle : str
        ``'front'`` or ``'rear'``.
    surface : str or None
        Surface label the samples were taken from (None: all samples).
    bin_width : float
        Bin width [rad]; bin ``k`` spans ``[k, k + 1) * bin_width``.
    min_count : int
        Samples a bin needed to be kept.
    max_long : float
        Largest ``|Fx| / Fz`` [-] of the samples used.
    bins : ndarray of int, shape (B,)
        Bin indices ``k``, increasing.
    centres : ndarray, shape (B,)
        Bin centres ``(k + 0.5) * bin_width`` [rad].
    alpha_mean : ndarray, shape (B,)
        Mean slip angle of the samples in each bin [rad].
    mu_mean : ndarray, shape (B,)
        Mean ``Fy / Fz`` of the samples in each bin [-].
    count : ndarray of int, shape (B,)
        Samples in each bin.
    """

    axle: str
    surface: str | None
    bin_width: float
    min_count: int
    max_long: float
    bins: NDArray[np.int64]
    centres: NDArray[np.float64]
    alpha_mean: NDArray[np.float64]
    mu_mean: NDArray[np.float64]
    count: NDArray[np.int64]

    def __len__(self) -> int:
        return len(self.bins)

    @property
    def slip_range(self) -> tuple[float, float]:
        """Lower edge of the first and upper edge of the last visited bin [rad] (NaN if none)."""
        if len(self.bins) == 0:
            return (float("nan"), float("nan"))
        return (float(self.bins[0] * self.bin_width), float((self.bins[-1] + 1) * self.bin_width))

    def __call__(self, alpha: ArrayLike) -> NDArray[np.float64]:
        """Friction ``mu(alpha)`` [-], same shape as ``alpha`` [rad]; NaN outside visited bins.

        Linear between the centroids of adjacent visited bins, the end segment
        extended to the outer edges of a run of adjacent bins, constant over an
        isolated bin (module docstring).
        """
        a = np.asarray(alpha, dtype=float)
        out = np.full(a.shape, np.nan)
        nb = len(self.bins)
        if nb == 0:
            return out
        flat = a.ravel()
        ok = np.isfinite(flat)
        ids = np.zeros(flat.shape, np.int64)
        ids[ok] = np.floor(flat[ok] / self.bin_width).astype(np.int64)
        pos = np.clip(np.searchsorted(self.bins, ids), 0, nb - 1)
        inside = ok & (self.bins[pos] == ids)
        # neighbours in the same run of adjacent visited bins
        adjacent = np.diff(self.bins) == 1  # bin i and i + 1 adjacent, shape (B-1,)
        has_right = np.r_[adjacent, False]
        has_left = np.r_[False, adjacent]
        right = flat >= self.alpha_mean[pos]
        # segment (i, i + 1): the right one where a is right of the centroid (or there
        # is no left neighbour), the left one otherwise
        use_right = np.where(right, has_right[pos], ~has_left[pos] & has_right[pos])
        use_left = ~use_right & has_left[pos]
        i = np.where(use_right, pos, pos - 1)
        i = np.clip(i, 0, max(nb - 2, 0))
        j = np.minimum(i + 1, nb - 1)
        seg = (use_right | use_left) & inside
        vals = self.mu_mean[pos].copy()
        if seg.any():
            ai, aj = self.alpha_mean[i[seg]], self.alpha_mean[j[seg]]
            mi, mj = self.mu_mean[i[seg]], self.mu_mean[j[seg]]
            vals[seg] = mi + (mj - mi) * (flat[seg] - ai) / (aj - ai)
        res = np.where(inside, vals, np.nan)
        out[...] = res.reshape(a.shape)
        return out

    def at_centres(self) -> NDArray[np.float64]:
        """The curve at the bin centres [-], shape (B,)."""
        return self(self.centres)


def _surface_mask(drive, surface: str | None) -> tuple[NDArray[np.bool_], str | None]:
    n = drive.n
    if "surface" not in drive.data.columns:
        if surface is not None:
            raise ValueError(
                f"surface {surface!r} asked for, but the drive from {drive.meta.source} has no "
                "'surface' column"
            )
        return np.ones(n, bool), None
    labels = drive.data["surface"].astype(str).to_numpy()
    if surface is None:
        surface = str(drive.data["surface"].astype(str).mode().iloc[0])
    elif surface not in set(labels.tolist()):
        raise ValueError(
            f"surface {surface!r} never occurs in the drive from {drive.meta.source}; "
            f"its surfaces are {sorted(set(labels.tolist()))}"
        )
    return labels == surface, surface


def binned_truth_curve(
    drive,
    axle: str = "front",
    surface: str | None = None,
    *,
    bin_width: float = DEFAULT_BIN_WIDTH,
    min_count: int = DEFAULT_MIN_COUNT,
    max_long: float = PURE_LATERAL_MAX_FX,
) -> BinnedCurve:
    """The true pure-lateral friction curve of an axle, binned from truth columns.

    Parameters
    ----------
    drive : Drive
        Needs ``alpha_<a>_true`` [rad], ``Fx<a>_true``, ``Fy<a>_true``, ``Fz<a>_true``
        [N] (``<a>`` = ``f`` or ``r``).
    axle : {'front', 'rear'}
    surface : str, optional
        Surface label (``surface`` column). Default: the label under the vehicle for
        most of the drive, as :meth:`Drive.true_tire`; all samples when the drive has
        no ``surface`` column.
    bin_width : float
        Slip bin width [rad] (default 0.5 deg, the benchmark's).
    min_count : int
        Samples a bin needs to be kept.
    max_long : float
        Samples with ``|Fx| / Fz`` above this [-] are left out (combined slip);
        ``np.inf`` keeps them all.

    Returns
    -------
    BinnedCurve
        Empty (every evaluation NaN) when no bin reaches ``min_count``.

    Raises
    ------
    ValueError
        Bad axle, bin width, count or threshold; unknown surface; missing columns.
    """
    a = _check_axle(axle)
    if not (np.isfinite(bin_width) and bin_width > 0):
        raise ValueError(f"bin_width must be a positive number of rad, got {bin_width!r}")
    if int(min_count) != min_count or min_count < 1:
        raise ValueError(f"min_count must be a positive integer, got {min_count!r}")
    if not max_long >= 0:
        raise ValueError(f"max_long must be a non-negative number (or inf), got {max_long!r}")
    cols = (f"alpha_{a}_true", f"Fx{a}_true", f"Fy{a}_true", f"Fz{a}_true")
    missing = [c for c in cols if c not in drive.data.columns]
    if missing:
        raise ValueError(
            f"drive from {drive.meta.source} lacks truth column(s) {missing} for the binned "
            f"{axle} friction curve"
        )
    sel, surface = _surface_mask(drive, surface)
    alpha, fx, fy, fz = (drive.col(c) for c in cols)
    with np.errstate(divide="ignore", invalid="ignore"):
        keep = (sel & (fz > 0) & np.isfinite(alpha) & np.isfinite(fx) & np.isfinite(fy)
                & np.isfinite(fz) & (np.abs(fx) <= max_long * fz))
    alpha, mu = alpha[keep], fy[keep] / fz[keep]
    ids = np.floor(alpha / bin_width).astype(np.int64)
    uniq, inv, counts = np.unique(ids, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    a_sum = np.bincount(inv, weights=alpha, minlength=len(uniq))
    m_sum = np.bincount(inv, weights=mu, minlength=len(uniq))
    good = counts >= min_count
    cnt = counts[good].astype(np.int64)
    return BinnedCurve(
        axle=axle,
        surface=surface,
        bin_width=float(bin_width),
        min_count=int(min_count),
        max_long=float(max_long),
        bins=uniq[good].astype(np.int64),
        centres=(uniq[good] + 0.5) * bin_width,
        alpha_mean=a_sum[good] / cnt,
        mu_mean=m_sum[good] / cnt,
        count=cnt,
    )


def has_parametric_truth(
    drive, axle: str = "front", direction: str = "lateral", surface: str | None = None
) -> bool:
    """Whether :meth:`Drive.true_tire` gives the drive's true curve.

    True when ``meta.truth['surfaces']`` carries the tire curve of ``axle`` and
    ``direction`` for ``surface`` (for every surface when None) and the truth does not
    declare ``truth_curve = 'binned'``.
    """
    _check_axle(axle)
    if direction not in ("lateral", "longitudinal"):
        raise ValueError(f"direction must be 'lateral' or 'longitudinal', got {direction!r}")
    truth = drive.meta.truth or {}
    surfaces = truth.get("surfaces")
    if not surfaces or truth.get("truth_curve") == "binned":
        return False
    key = axle if direction == "lateral" else f"{axle}_long"
    entries = [surfaces[surface]] if surface in surfaces else (
        list(surfaces.values()) if surface is None else [])
    return bool(entries) and all(isinstance(e, dict) and key in e for e in entries)


def true_curve(
    drive,
    axle: str = "front",
    surface: str | None = None,
    *,
    bin_width: float = DEFAULT_BIN_WIDTH,
    min_count: int = DEFAULT_MIN_COUNT,
    max_long: float = PURE_LATERAL_MAX_FX,
) -> Callable[[ArrayLike], NDArray[np.float64]]:
    """The true lateral friction curve ``mu(alpha)`` of an axle, however the drive states it.

    The parametric tire of :meth:`Drive.true_tire` when :func:`has_parametric_truth`,
    otherwise the :func:`binned_truth_curve` (``bin_width``, ``min_count`` and
    ``max_long`` apply to it only), which is NaN outside its visited bins.

    Parameters
    ----------
    drive : Drive
    axle : {'front', 'rear'}
    surface : str, optional
        Surface label; default the one under the vehicle for most of the drive.

    Returns
    -------
    callable
        ``mu(alpha)``: slip angle [rad] to friction [-], vectorised.
    """
    if has_parametric_truth(drive, axle, "lateral", surface):
        return drive.true_tire(axle, surface=surface).mu
    return binned_truth_curve(drive, axle, surface, bin_width=bin_width, min_count=min_count,
                              max_long=max_long)


# -- utilisation ----------------------------------------------------------------------
def utilisation_source(drive, axle: str = "front") -> str | None:
    """Where :func:`friction_utilisation` takes an axle's utilisation from.

    Returns
    -------
    str or None
        ``'column'`` (``util_<a>_true``), ``'computed'`` (axle forces and ``mu_true``)
        or None (neither available).
    """
    a = _check_axle(axle)
    if f"util_{a}_true" in drive.data.columns:
        return "column"
    if drive.has(f"Fx{a}_true", f"Fy{a}_true", f"Fz{a}_true", "mu_true"):
        return "computed"
    return None


def friction_utilisation(drive, axle: str = "front") -> NDArray[np.float64]:
    """Friction utilisation of an axle at every sample, ``|F| / (mu Fz)`` [-], shape (n,).

    The ``util_<a>_true`` column when present; otherwise
    ``hypot(Fx<a>_true, Fy<a>_true) / (mu_true * Fz<a>_true)``, NaN where
    ``Fz <= 0`` or ``mu_true <= 0``.

    Raises
    ------
    ValueError
        The drive has neither the column nor the forces and ``mu_true``.
    """
    a = _check_axle(axle)
    src = utilisation_source(drive, axle)
    if src == "column":
        return drive.data[f"util_{a}_true"].to_numpy(float)
    if src is None:
        raise ValueError(
            f"drive from {drive.meta.source} carries no {axle} friction utilisation: it needs "
            f"'util_{a}_true', or 'Fx{a}_true', 'Fy{a}_true', 'Fz{a}_true' and 'mu_true'"
        )
    fx, fy, fz = (drive.col(f"F{c}{a}_true") for c in "xyz")
    mu = drive.col("mu_true")
    den = mu * fz
    out = np.full(drive.n, np.nan)
    ok = (fz > 0) & (mu > 0)
    out[ok] = np.hypot(fx[ok], fy[ok]) / den[ok]
    return out
