"""Signals the readers derive from recorded streams: body velocity from a pose, noise level.

Estimators take them through :mod:`roadgrip.signals`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["body_velocity_from_pose", "white_noise_std"]


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
    uniform clock gives ``x'``, ``y'`` and a smoothed ``psi``, for noisy poses;
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
    from scipy.signal import savgol_filter

    n = len(t)
    vx = np.full(n, np.nan)
    vy = np.full(n, np.nan)
    if n < 5:
        return vx, vy
    h = float(np.median(np.diff(t)))
    w = max(round(window / h) // 2 * 2 + 1, 5)
    half = w // 2
    bad = np.zeros(n, bool) if bad is None else np.asarray(bad, bool)
    # segments between missing ticks and bad samples
    brk = np.r_[True, np.diff(t) > 1.5 * h] | bad
    seg = np.cumsum(brk)
    for s in np.unique(seg):
        idx = np.flatnonzero((seg == s) & ~bad)
        if len(idx) < w:
            continue
        i0, i1 = idx[0], idx[-1] + 1
        xd = savgol_filter(x[i0:i1], w, 2, deriv=1, delta=h)
        yd = savgol_filter(y[i0:i1], w, 2, deriv=1, delta=h)
        bx, by = _rotate_to_body(xd, yd, savgol_filter(psi[i0:i1], w, 2))
        # the edges use a one-sided fit: keep only the centred part
        bx[:half] = bx[-half:] = np.nan
        by[:half] = by[-half:] = np.nan
        vx[i0:i1], vy[i0:i1] = bx, by
    return vx, vy


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
