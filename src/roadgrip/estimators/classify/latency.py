"""The latency of the wheel speeds against the accelerometer: fitted, and aligned.

The saturation model compares the measured longitudinal acceleration with what the
measured slips predict, sample by sample. Each message of a car's bus has its own latency
(0-150 ms on the multi-body family's realistic sensors), so at the onset of an
acceleration the slip from wheel speeds that arrive before the accelerometer's reading
rises ahead of it: the measured acceleration falls short of both classes' predictions and
the first evidence says 'low' on dry asphalt (the other way round, 'high' on gravel).

:func:`fit_wheel_latency` measures the latency from the drives a calibration is given: the
free-rolling wheels' rim speed changes as the car accelerates, with no slip between them
and the ground outside braking, so its derivative is the accelerometer's reading at the
right delay. The least squares of ``d(R omega)/dt = g a_x(t - latency) + b`` over the
non-braking samples, on a grid of the drive's sample step, gives it (the pitch of the body
under acceleration lags the accelerometer's reading by 10-20 ms besides, which the fit
aligns as measured). An all-wheel-drive car has no free-rolling wheel: its wheels' slip
grows with the acceleration and reads as a latency (about ``v / (g C_x)``, 80-110 ms on
the family's cars), so the latency is not fitted there.

A drive read with a fitted vehicle file (``--vehicle car.yaml``, :mod:`roadgrip.io.calibration`)
has its wheel speeds moved by the speed's delay and ``a_x`` by its own
(``delay_accelerometer_x``), which puts the two on one clock and leaves the fit about 0. A
file without that entry (written before it existed, or fitted on a drive without a pose)
moves ``a_x`` by ``a_y``'s delay, and where ``a_x`` and ``a_y`` are separate messages of the
bus (each with its own latency, as on the multi-body family's realistic sensors) the two are
not on one clock after it: so the fit runs on calibrated drives too and measures what
remains (``docs/validation-classification.md``).

:func:`delay_channels` aligns: the earlier of the two signals waits for the later, the
accelerometer's ``ax`` when the wheel speeds are later (``latency > 0``), the four wheel
speeds when they are earlier. Each output sample takes the delayed channel's latest
sample at or before ``t - |latency|`` (the first sample before that history exists). The
same function serves a block of samples (:func:`aligned_drive`) and the online step
(:class:`DelayLine` carries the samples a later one can still need), so stepping equals
the batch.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import uniform_filter1d

from roadgrip.drive import SIGNAL_COLUMNS, WHEEL_COLUMNS, Drive
from roadgrip.estimators.array_frame import ArrayFrame
from roadgrip.signals import undriven_wheels

__all__ = [
    "LATENCY_MAX_S",
    "DelayLine",
    "aligned_drive",
    "delay_channels",
    "delay_line_init",
    "delayed_columns",
    "fit_wheel_latency",
]

LATENCY_MAX_S = 0.25
"""Largest latency of the wheel speeds against the accelerometer the fit considers [s]
(either sign); a minimum at this bound is not a measurement."""

LATENCY_SMOOTHING_S = 0.15
"""Moving-average window of both signals before the wheel speed is differentiated [s]."""

LATENCY_MIN_SPEED = 3.0
"""Slowest free-rolling rim speed [m/s] the fit uses (a slow wheel's encoder quantisation
dominates its derivative)."""

LATENCY_BRAKING_ACCEL = -0.5
"""Samples whose 0.5-s mean acceleration is below this [m/s²] are braking: every wheel
slips, so the fit leaves them out."""

LATENCY_MIN_SAMPLES = 500
"""Fewest samples for a latency fit."""

_TIME_TOL = 1e-9
"""Tolerance [s] of the sample times' comparison (``t - latency`` lands on a sample time)."""


class DelayLine(NamedTuple):
    """The delayed channel's recent samples (:func:`delay_channels`).

    Attributes
    ----------
    t : ndarray, shape (k,)
        Sample times [s].
    values : ndarray, shape (k, m)
        The channel's values (``m = 1``: ``ax`` [m/s²]; ``m = 4``: wheel speeds [rad/s]).
    """

    t: NDArray[np.float64]
    values: NDArray[np.float64]


def delay_line_init(latency: float) -> DelayLine:
    """An empty delay line for ``latency`` [s] (the channel's width, :func:`delayed_columns`)."""
    m = len(delayed_columns(latency))
    return DelayLine(np.zeros(0), np.zeros((0, m)))


def delayed_columns(latency: float) -> tuple[str, ...]:
    """The columns that wait: ``('ax',)`` for ``latency > 0``, the wheel speeds for
    ``latency < 0``, none for 0."""
    if latency > 0:
        return ("ax",)
    if latency < 0:
        return WHEEL_COLUMNS
    return ()


def delay_channels(
    line: DelayLine, t: NDArray, values: NDArray, latency: float,
) -> tuple[NDArray[np.float64], DelayLine]:
    """The channel delayed by ``|latency|`` [s] over new samples, and the line after them.

    Parameters
    ----------
    line : DelayLine
        Samples before these (empty at the start of a drive).
    t : ndarray, shape (n,)
        New sample times [s], increasing, later than ``line.t``.
    values : ndarray, shape (n, m)
        The channel at those times.
    latency : float
        [s]; its magnitude is the delay.

    Returns
    -------
    delayed : ndarray, shape (n, m)
        Each sample's latest value at or before ``t - |latency|`` (the earliest held
        before that).
    line : DelayLine
        The samples a later one can still need.
    """
    t = np.asarray(t, float)
    values = np.asarray(values, float).reshape(t.size, -1)
    t_src = np.concatenate([line.t, t])
    v_src = np.concatenate([line.values.reshape(line.t.size, values.shape[1]), values])
    j = np.searchsorted(t_src, t - abs(latency) + _TIME_TOL, side="right") - 1
    j = np.maximum(j, 0)
    keep = int(j[-1]) if j.size else 0
    return v_src[j], DelayLine(t_src[keep:], v_src[keep:])


def aligned_drive(drive: Drive, latency: float, line: DelayLine | None = None) -> tuple[Drive, DelayLine]:
    """The drive's signals with the earlier channel delayed (:func:`delay_channels`).

    Parameters
    ----------
    drive : Drive
        A whole drive, or a block of one that follows ``line``'s samples.
    latency : float
        Latency of the wheel speeds behind the accelerometer [s].
    line : DelayLine, optional
        Default :func:`delay_line_init` (the start of a drive).

    Returns
    -------
    drive : Drive
        The measured signal columns (:data:`~roadgrip.drive.SIGNAL_COLUMNS` present),
        aligned; the same drive when ``latency`` is 0 or the channel is absent.
    line : DelayLine
    """
    line = delay_line_init(latency) if line is None else line
    cols = delayed_columns(latency)
    present = [c for c in cols if c in drive.data.columns]
    if not present:
        return drive, line
    values = np.column_stack([drive.col(c) if c in drive.data.columns else np.full(drive.n, np.nan)
                              for c in cols])
    delayed, line = delay_channels(line, drive.t, values, latency)
    out = {c: np.asarray(drive.data[c]) for c in SIGNAL_COLUMNS if c in drive.data.columns}
    for k, c in enumerate(cols):
        if c in drive.data.columns:
            out[c] = delayed[:, k]
    return Drive(ArrayFrame(out), drive.meta), line  # type: ignore[arg-type]


def _filled(t: NDArray, x: NDArray) -> NDArray:
    """``x`` with its missing samples (dropouts) interpolated over time."""
    ok = np.isfinite(x)
    return np.interp(t, t[ok], x[ok]) if ok.sum() >= 2 else np.full(t.shape, np.nan)


def fit_wheel_latency(drives: Sequence[Drive]) -> tuple[float, dict[str, Any]]:
    """Latency of the free-rolling wheels' speed behind the accelerometer [s] (module docstring).

    Parameters
    ----------
    drives : sequence of Drive
        One car's drives (its :class:`~roadgrip.vehicle.params.VehicleParams` from the first).

    Returns
    -------
    latency : float
        A multiple of the first drive's sample step; 0 where not fitted.
    fit : dict
        ``fitted``, ``samples``, and ``latency_s`` or the ``reason`` it was not fitted.
    """
    params = drives[0].vehicle
    free = undriven_wheels(params.drive)
    if not free.any():
        return 0.0, {"fitted": False, "samples": 0,
                     "reason": "all-wheel drive: no free-rolling wheel (its slip reads as a latency)"}
    cols = [c for c, f in zip(WHEEL_COLUMNS, free, strict=True) if f]
    step = float(np.median(np.diff(drives[0].t))) if drives[0].n > 1 else 0.0
    if not step > 0:
        return 0.0, {"fitted": False, "samples": 0, "reason": "fewer than two samples"}
    rows = []
    for d in drives:
        if not d.has("ax", *cols) or d.n < 3:
            continue
        t = d.t
        k = max(1, round(LATENCY_SMOOTHING_S / step))
        with np.errstate(invalid="ignore"):
            rim = np.nanmean(np.column_stack([d.col(c) for c in cols]), axis=1) * params.wheel_radius
        rim, ax = _filled(t, rim), _filled(t, d.col("ax"))
        if not (np.isfinite(rim).all() and np.isfinite(ax).all()):
            continue
        dv = np.gradient(uniform_filter1d(rim, k, mode="nearest"), t)
        ax_s = uniform_filter1d(ax, k, mode="nearest")
        # braking by either signal, widened by the largest latency: which of the two is
        # late is what the fit measures, so neither may decide where a stop begins
        mean = max(1, round(0.5 / step))
        braking = (uniform_filter1d(ax, mean, mode="nearest") < LATENCY_BRAKING_ACCEL) | \
            (uniform_filter1d(dv, mean, mode="nearest") < LATENCY_BRAKING_ACCEL)
        braking = uniform_filter1d(braking.astype(float), 2 * round(LATENCY_MAX_S / step) + 1,
                                   mode="nearest") > 0
        edge = (t > t[0] + LATENCY_MAX_S + LATENCY_SMOOTHING_S) & (t < t[-1] - LATENCY_SMOOTHING_S)
        use = edge & ~braking & (rim > LATENCY_MIN_SPEED)
        rows.append((t, ax_s, dv, use))
    n = int(sum(u.sum() for *_, u in rows))
    if n < LATENCY_MIN_SAMPLES:
        return 0.0, {"fitted": False, "samples": n, "reason": "too few free-rolling samples"}
    lags = np.arange(-round(LATENCY_MAX_S / step), round(LATENCY_MAX_S / step) + 1) * step
    sse = np.zeros(lags.size)
    for i, lag in enumerate(lags):
        for t, ax_s, dv, use in rows:
            a = np.interp(t[use] - lag, t, ax_s)
            x = np.column_stack([a, np.ones_like(a)])
            coef, *_ = np.linalg.lstsq(x, dv[use], rcond=None)
            sse[i] += float(np.sum((dv[use] - x @ coef) ** 2))
    best = int(np.argmin(sse))
    if best in (0, lags.size - 1):
        return 0.0, {"fitted": False, "samples": n, "reason": f"no minimum within +-{LATENCY_MAX_S} s"}
    return float(lags[best]), {"fitted": True, "samples": n, "latency_s": float(lags[best])}
