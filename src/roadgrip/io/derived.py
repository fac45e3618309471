"""Signals the readers derive from recorded streams: body velocity from a pose, noise level.

Estimators take them through :mod:`roadgrip.signals`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["CLOCK_INTERVALS", "body_velocity_from_pose", "savgol_quadratic", "white_noise_std"]

CLOCK_INTERVALS = 20
"""Intervals at the start of a record whose median is the clock step of the windowed
pose fit: a later sample never changes an earlier fit."""


def body_velocity_from_pose(
    t: ArrayLike,
    x: ArrayLike,
    y: ArrayLike,
    psi: ArrayLike,
    *,
    window: float | None = None,
    bad: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body-frame velocity ``(vx, vy)`` [m/s] differentiated from a pose.

    The map-frame velocity ``(x', y')`` is rotated into the body frame at the
    sample's heading: ``vx = cos(psi) x' + sin(psi) y'``,
    ``vy = -sin(psi) x' + cos(psi) y'``; ``psi`` is unwrapped first.

    ``window=None`` differentiates by central differences in ``t``
    (:func:`numpy.gradient`, second order, one-sided at the ends). With a
    ``window`` [s], a local quadratic (Savitzky-Golay) fit over that window on a
    uniform clock (its step the median of the first :data:`CLOCK_INTERVALS`
    intervals, so that each value depends on the samples within half a window of
    it and no others) gives ``x'``, ``y'`` and a smoothed ``psi``, for noisy poses;
    the fit never spans a missing tick (a gap in ``t`` over 1.5 steps) or a
    sample flagged in ``bad``: samples within half a window of either, and
    segments shorter than a window, get NaN.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s], increasing.
    x, y : array_like, shape (n,)
        Position of the reference point in the map frame [m].
    psi : array_like, shape (n,)
        Heading [rad], wrapped or not.
    window : float, optional
        Fit window [s] (odd number of samples, at least 5).
    bad : array_like of bool, shape (n,), optional
        Samples not to use (localisation jumps); only with ``window``.

    Returns
    -------
    vx, vy : ndarray, shape (n,)
        Body velocity of the reference point [m/s].
    """
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    psi = np.unwrap(np.asarray(psi, float))
    if window is None:
        if bad is not None:
            raise ValueError("bad samples are only handled by the windowed fit (give window)")
        return _rotate_to_body(np.gradient(x, t), np.gradient(y, t), psi)
    return _savgol_body_velocity(t, x, y, psi, float(window), bad)


def _rotate_to_body(xd, yd, psi):
    c, s = np.cos(psi), np.sin(psi)
    return c * xd + s * yd, -s * xd + c * yd


def _savgol_body_velocity(t, x, y, psi, window, bad):
    n = len(t)
    vx = np.full(n, np.nan)
    vy = np.full(n, np.nan)
    if n < 5:
        return vx, vy
    h = float(np.median(np.diff(t[:CLOCK_INTERVALS + 1])))
    w = max(round(window / h) // 2 * 2 + 1, 5)
    bad = np.zeros(n, bool) if bad is None else np.asarray(bad, bool)
    # segments between missing ticks and bad samples
    brk = np.r_[True, np.diff(t) > 1.5 * h] | bad
    seg = np.cumsum(brk)
    for s in np.unique(seg):
        idx = np.flatnonzero((seg == s) & ~bad)
        if len(idx) < w:
            continue
        i0, i1 = idx[0], idx[-1] + 1
        # only the centred fits: within half a window of the ends stays NaN
        xd = savgol_quadratic(x[i0:i1], w, deriv=1, delta=h)
        yd = savgol_quadratic(y[i0:i1], w, deriv=1, delta=h)
        vx[i0:i1], vy[i0:i1] = _rotate_to_body(xd, yd, savgol_quadratic(psi[i0:i1], w))
    return vx, vy


def savgol_quadratic(v: ArrayLike, window: int, deriv: int = 0, delta: float = 1.0) -> NDArray[np.float64]:
    """Savitzky-Golay filter of a local quadratic fit, at the centre of each window.

    The least-squares quadratic through ``window = 2 m + 1`` consecutive samples
    ``v[i-m] .. v[i+m]``, evaluated at the middle one (Savitzky & Golay 1964): its value
    (``deriv=0``)

        ``(c_0 v[i] + sum_k c_k (v[i+k] + v[i-k]))``,
        ``c_k = 3 (3 m² + 3 m - 1 - 5 k²) / ((2 m - 1)(2 m + 1)(2 m + 3))``,

    or its slope (``deriv=1``), that of the straight-line fit,

        ``sum_k k (v[i+k] - v[i-k]) / (delta m (m + 1)(2 m + 1) / 3)``,

    ``k = 1 .. m``. Summed in pairs, a constant offset of ``v`` cancels exactly in the
    slope. The interior of :func:`scipy.signal.savgol_filter` with ``polyorder=2``, to
    rounding, without importing :mod:`scipy.signal` (0.8 s). The first and last ``m``
    samples, where no centred window fits, are NaN.

    Parameters
    ----------
    v : array_like, shape (n,)
        Samples on a uniform clock.
    window : int
        Odd number of samples, at least 3.
    deriv : {0, 1}
        Value or first derivative.
    delta : float
        Sample spacing [s] (for ``deriv=1``).

    Returns
    -------
    ndarray, shape (n,)
        In the unit of ``v`` (per second for ``deriv=1``); all NaN when ``n < window``.

    Examples
    --------
    >>> savgol_quadratic([0.0, 1.0, 4.0, 9.0, 16.0], 5, deriv=1, delta=1.0)
    array([nan, nan,  4., nan, nan])
    """
    if window < 3 or window % 2 == 0:
        raise ValueError(f"window must be an odd number of samples >= 3, got {window!r}")
    if deriv not in (0, 1):
        raise ValueError(f"deriv must be 0 or 1, got {deriv!r}")
    v = np.asarray(v, float)
    n, m = len(v), window // 2
    out = np.full(n, np.nan)
    if n < window:
        return out
    centre = v[m:n - m]
    if deriv == 1:
        acc = np.zeros(n - 2 * m)
        for k in range(1, m + 1):
            acc += k * (v[m + k:n - m + k] - v[m - k:n - m - k])
        out[m:n - m] = acc / (delta * (m * (m + 1) * (2 * m + 1) / 3.0))
        return out
    norm = (2 * m - 1) * (2 * m + 1) * (2 * m + 3)
    acc = (3.0 * (3 * m * m + 3 * m - 1) / norm) * centre
    for k in range(1, m + 1):
        acc += (3.0 * (3 * m * m + 3 * m - 1 - 5 * k * k) / norm) * (v[m + k:n - m + k] + v[m - k:n - m - k])
    out[m:n - m] = acc
    return out


def white_noise_std(x: ArrayLike) -> float:
    """Standard deviation of the white noise on a sampled signal [unit of ``x``].

    The robust scale (1.4826 times the median absolute deviation) of the second
    differences, divided by ``sqrt(6)``: white noise of standard deviation
    ``s`` gives second differences of variance ``6 s²``, while a signal that is
    smooth at the sampling rate contributes little to them. Linear
    interpolation has zero second difference, so the signal must be taken as
    sampled, not resampled onto a finer clock.

    Parameters
    ----------
    x : array_like, shape (n,)
        Samples on a (roughly) uniform clock.

    Returns
    -------
    float
        NaN when there are fewer than 10 second differences (``n < 12``).
    """
    d2 = np.diff(np.asarray(x, dtype=float), 2)
    if d2.size < 10:
        return float("nan")
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0))
