r"""Sensor time offsets: the delay of each sensor against the others, and a drive aligned by them.

Loggers stamp samples when they arrive, not when they were measured; a sensor that
filters or buffers its output reaches the log late. Two kinematic identities hold
whatever the tires do, so the lag at which both sides correlate best is the sensors'
relative delay:

========================  ===================================  ============================
pair                      identity                             measures
========================  ===================================  ============================
``ay`` vs ``vx·r``        ``a_y = v_x r + dv_y/dt``            accelerometer behind gyro
``r`` vs ``dpsi/dt``      ``r = dpsi/dt``                      gyro behind the pose
========================  ===================================  ============================

(``dv_y/dt`` is small and nearly in phase with ``v_x r`` on a car that is not sliding,
so the first pair is unbiased to within a few milliseconds on the simulators.) The
steering angle is left out: its lag to the yaw rate is the vehicle's own dynamics,
not a clock offset.

Delays are stated against one clock, that of the pose where the drive has one (motion
capture or localisation stamps), else the gyro's: the gyro's delay is the second pair's
lag, the accelerometer's the sum of both. :func:`align_drive` moves each sensor's
columns (the accelerometer's ``ax`` and ``ay`` together, they share one device) back by
its delay and drops the samples at the ends that have no partner.

Method (:func:`lag_correlation`): both signals on a uniform grid, the slow trend (10 s
moving mean) removed, cut into windows of ``window`` seconds; per window the
cross-correlation at every lag up to ``max_lag`` by FFT, normalised by the energies of
the overlapping parts (a Pearson coefficient without the overlap's bias towards zero
lag); the correlations of all windows are summed, the peak located to a fraction of a
sample by a parabola through the three highest lags. The spread of the windows' own
peaks, weighted by the energy each explains, gives the standard error. Samples in gaps of the time base and outliers of the
pose derivative (localisation jumps) are left out of the sums; samples where only the
signal departs from the identity (``signal_valid``: a braked wheel's speed) are left out of
the signal's side alone (:func:`masked_lag_correlation`), the reference kept at every lag.

Positive delay: the signal lags (arrives after) its reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from roadgrip.drive import Drive
from roadgrip.io.calibration import shift_columns
from roadgrip.signals import body_velocity_from_pose, wheel_speed_vx

__all__ = [
    "ACCELEROMETER",
    "GYRO",
    "POSE",
    "DelayFit",
    "SensorDelay",
    "align_drive",
    "estimate_delay",
    "lag_correlation",
    "masked_lag_correlation",
    "sensor_delays",
]

ACCELEROMETER = ("ax", "ay")
"""Columns of the accelerometer (one device, one clock)."""
GYRO = ("yaw_rate",)
POSE = ("x", "y", "psi")
"""Columns of the pose; with ``vx_pose``, ``vy_pose`` where present (derived from it)."""
POSE_DERIVED = ("vx_pose", "vy_pose")

TREND_WINDOW = 10.0
"""Moving-mean window [s] removed from both signals (biases and slow drifts)."""

SIDESLIP_WINDOW = 0.5
"""Smoothing [s] of the pose's lateral velocity and its derivative in the accelerometer's
reference ``vx r + dvy/dt`` (the pose is differentiated twice)."""

MIN_CORRELATION = 0.5
"""Peak correlation [-] below which a delay is not reported as reliable."""
MAX_STD = 0.02
"""Standard error [s] above which a delay is not reported as reliable."""


@dataclass(frozen=True)
class DelayFit:
    """Result of :func:`estimate_delay` for one pair of signals.

    Attributes
    ----------
    delay : float
        Lag [s] of the signal behind its reference at the correlation peak (NaN when
        there is no usable window).
    std : float
        Standard error [s] from the spread of the windows' peaks (NaN with fewer than
        three usable windows).
    peak_corr : float
        Correlation coefficient [-] at the peak, in [-1, 1].
    windows : int
        Windows with a usable correlation (peak above ``MIN_CORRELATION``, away from
        the search edge).
    windows_total : int
    at_edge : bool
        The peak lies at ``±max_lag``: the delay may be larger than the search.
    """

    delay: float
    std: float
    peak_corr: float
    windows: int
    windows_total: int
    at_edge: bool

    @property
    def reliable(self) -> bool:
        """Peak correlation at least ``MIN_CORRELATION``, standard error at most
        ``MAX_STD``, and the peak inside the search range."""
        return (math.isfinite(self.delay) and self.peak_corr >= MIN_CORRELATION
                and math.isfinite(self.std) and self.std <= MAX_STD and not self.at_edge)


@dataclass(frozen=True)
class SensorDelay:
    """The delay of one sensor against the drive's reference clock.

    Attributes
    ----------
    sensor : str
        ``'accelerometer'`` or ``'gyro'``.
    columns : tuple of str
        Its columns (moved together by :func:`align_drive`).
    reference : str
        The clock it is stated against: ``'pose'`` or ``'gyro'``.
    delay, std : float
        [s]; positive: the sensor's samples arrive late.
    peak_corr : float
        Peak correlation of the weakest pair it was derived from [-].
    pairs : tuple of str
        The correlated pairs, e.g. ``('ay~vx*r+dvy/dt', 'r~dpsi/dt')`` (``r`` the yaw rate).
    fits : tuple of DelayFit
        Their fits.
    """

    sensor: str
    columns: tuple[str, ...]
    reference: str
    delay: float
    std: float
    peak_corr: float
    pairs: tuple[str, ...]
    fits: tuple[DelayFit, ...] = field(repr=False)

    @property
    def reliable(self) -> bool:
        return all(f.reliable for f in self.fits)


def _uniform(t: NDArray, gap: float) -> tuple[NDArray, NDArray]:
    """Uniform grid over ``t`` at its median step, and the mask of grid points inside a gap."""
    dt = float(np.median(np.diff(t)))
    grid = t[0] + dt * np.arange(math.floor((t[-1] - t[0]) / dt) + 1)
    k = np.clip(np.searchsorted(t, grid, side="right"), 1, len(t) - 1)
    in_gap = (t[k] - t[k - 1]) > gap * dt
    return grid, in_gap


def _moving_mean(x: NDArray, n: int) -> NDArray:
    if n < 2 or len(x) < n:
        return np.full_like(x, x.mean())
    c = np.concatenate(([0.0], np.cumsum(x)))
    half = n // 2
    lo = np.clip(np.arange(len(x)) - half, 0, len(x))
    hi = np.clip(np.arange(len(x)) + half + 1, 0, len(x))
    return (c[hi] - c[lo]) / (hi - lo)


def _xcorr(a: NDArray, b: NDArray, lags: NDArray) -> NDArray:
    """``sum_i a[i] b[i - k]`` for each ``k`` of ``lags`` (by FFT)."""
    n = len(a)
    nfft = 1 << math.ceil(math.log2(max(n + int(np.abs(lags).max()), 2)))
    full = np.fft.irfft(np.fft.rfft(a, nfft) * np.conj(np.fft.rfft(b, nfft)), nfft)
    return full[lags % nfft]


def masked_lag_correlation(sig: NDArray, ref: NDArray, sig_ok: NDArray, max_lag: int
                           ) -> tuple[NDArray, NDArray, NDArray]:
    """:func:`lag_correlation` over the samples where ``sig_ok``, the reference used at
    every lag: ``c[k] = sum_i m[i] sig[i] ref[i - k]``, ``e_sig[k] = sum_i m[i] sig[i]²``,
    ``e_ref[k] = sum_i m[i] ref[i - k]²`` (``m`` the mask, ``i - k`` inside the record).
    Setting the left-out samples to zero instead would leave both signals at zero over the
    same stretch and pull the peak towards lag zero.

    Parameters
    ----------
    sig, ref : ndarray, shape (n,)
    sig_ok : ndarray of bool, shape (n,)
    max_lag : int
        [samples].

    Returns
    -------
    c, e_sig, e_ref : ndarray, shape (2 max_lag + 1,)
    """
    n = len(sig)
    K = min(int(max_lag), n - 1)
    lags = np.arange(-K, K + 1)
    m = np.asarray(sig_ok, float)
    one = np.ones(n)
    c = _xcorr(m * sig, ref, lags)
    e_sig = _xcorr(m * sig * sig, one, lags)
    e_ref = _xcorr(m, ref * ref, lags)
    if K < max_lag:
        pad = int(max_lag) - K
        c, e_sig, e_ref = (np.pad(a, pad) for a in (c, e_sig, e_ref))
    return c, e_sig, e_ref


def lag_correlation(sig: NDArray, ref: NDArray, max_lag: int) -> tuple[NDArray, NDArray, NDArray]:
    """Sums of the lagged products and the energies of the overlapping parts.

    Parameters
    ----------
    sig, ref : ndarray, shape (n,)
        Zero-mean signals on one uniform grid (zeros where a sample is left out).
    max_lag : int
        Largest lag [samples] in both directions.

    Returns
    -------
    c, e_sig, e_ref : ndarray, shape (2 max_lag + 1,)
        For lags ``k = -max_lag .. max_lag``: ``c[k] = sum_i sig[i] ref[i - k]`` and the
        energies ``sum sig²``, ``sum ref²`` over the samples that enter it; their
        ratio ``c / sqrt(e_sig e_ref)`` is the correlation at lag ``k`` (``sig`` behind
        ``ref`` by ``k`` samples at a positive peak).
    """
    n = len(sig)
    K = min(int(max_lag), n - 1)
    nfft = 1 << math.ceil(math.log2(max(n + K, 2)))
    full = np.fft.irfft(np.fft.rfft(sig, nfft) * np.conj(np.fft.rfft(ref, nfft)), nfft)
    lags = np.arange(-K, K + 1)
    c = full[lags % nfft]
    cs = np.concatenate(([0.0], np.cumsum(sig * sig)))
    cr = np.concatenate(([0.0], np.cumsum(ref * ref)))
    # lag k >= 0: sig[k:], ref[:n-k]; k < 0: sig[:n+k], ref[-k:]
    pos = lags >= 0
    e_sig = np.where(pos, cs[n] - cs[np.clip(lags, 0, n)], cs[np.clip(n + lags, 0, n)])
    e_ref = np.where(pos, cr[np.clip(n - lags, 0, n)], cr[n] - cr[np.clip(-lags, 0, n)])
    if K < max_lag:  # pad to the requested length with no overlap
        pad = int(max_lag) - K
        c, e_sig, e_ref = (np.pad(a, pad) for a in (c, e_sig, e_ref))
    return c, e_sig, e_ref


def _peak(rho: NDArray) -> tuple[float, float, bool]:
    """Sub-sample argmax of a correlation over lags ``-K .. K`` (parabola through the top
    three): (lag [samples], peak value, at the edge)."""
    K = (len(rho) - 1) // 2
    if not np.isfinite(rho).any():
        return math.nan, math.nan, False
    i = int(np.nanargmax(rho))
    if i == 0 or i == len(rho) - 1:
        return float(i - K), float(rho[i]), True
    y0, y1, y2 = rho[i - 1], rho[i], rho[i + 1]
    den = y0 - 2.0 * y1 + y2
    off = 0.5 * (y0 - y2) / den if den < 0 else 0.0
    return float(i - K + off), float(y1 - 0.25 * (y0 - y2) * off), False


def estimate_delay(
    t: ArrayLike,
    signal: ArrayLike,
    reference: ArrayLike,
    *,
    valid: ArrayLike | None = None,
    signal_valid: ArrayLike | None = None,
    max_lag: float = 1.0,
    window: float = 30.0,
    smooth: float = 0.2,
) -> DelayFit:
    """Delay of ``signal`` behind ``reference`` from their cross-correlation.

    Parameters
    ----------
    t : array_like, shape (n,)
        Increasing time [s]; gaps longer than three median steps are left out.
    signal, reference : array_like, shape (n,)
        Two measurements of one quantity (any common unit; gains do not matter).
    valid : array_like of bool, shape (n,), optional
        Samples to use (e.g. no localisation jump); default all finite ones.
    signal_valid : array_like of bool, shape (n,), optional
        Samples of ``signal`` alone to use, the reference kept at every lag
        (:func:`masked_lag_correlation`): where the signal departs from the identity
        for a while (a braked wheel slipping).
    max_lag : float
        Largest delay searched in both directions [s].
    window : float
        Longest window whose peaks give the standard error [s]; shorter drives are cut
        into six windows, each at least ``8 max_lag`` long.
    smooth : float
        Moving-mean window [s] applied to both signals (noise; symmetric, so it shifts
        nothing).

    Returns
    -------
    DelayFit

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(0, 120, 0.01)
    >>> ref = np.sin(0.9 * t) + 0.5 * np.sin(2.3 * t)
    >>> sig = np.sin(0.9 * (t - 0.25)) + 0.5 * np.sin(2.3 * (t - 0.25))
    >>> round(estimate_delay(t, sig, ref).delay, 3)
    0.25
    """
    t = np.asarray(t, float)
    sig = np.asarray(signal, float)
    ref = np.asarray(reference, float)
    ok = np.isfinite(sig) & np.isfinite(ref) & np.isfinite(t)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if ok.sum() < 16 or not math.isfinite(max_lag) or max_lag <= 0:
        return DelayFit(math.nan, math.nan, math.nan, 0, 0, False)
    sig_ok = None if signal_valid is None else np.asarray(signal_valid, bool)[ok]
    t, sig, ref = t[ok], sig[ok], ref[ok]
    grid, in_gap = _uniform(t, gap=3.0)
    dt = float(grid[1] - grid[0]) if len(grid) > 1 else 1.0
    s = np.interp(grid, t, sig)
    r = np.interp(grid, t, ref)
    trend = max(round(TREND_WINDOW / dt), 2)
    s -= _moving_mean(s, trend)
    r -= _moving_mean(r, trend)
    n_smooth = round(smooth / dt)
    if n_smooth >= 2:
        s = _moving_mean(s, n_smooth)
        r = _moving_mean(r, n_smooth)
    s[in_gap] = 0.0
    r[in_gap] = 0.0
    m = None if sig_ok is None else (np.interp(grid, t, sig_ok.astype(float)) > 0.999) & ~in_gap
    K = max(math.ceil(max_lag / dt), 1)
    # at least six windows where the drive is long enough for them to hold 8 max_lag each
    W = max(round(min(window, (grid[-1] - grid[0]) / 6.0) / dt), 8 * K)
    starts = range(0, len(grid), W)
    tot = np.zeros((3, 2 * K + 1))
    peaks, n_win = [], 0
    for a in starts:
        seg_s, seg_r = s[a:a + W], r[a:a + W]
        if len(seg_s) < 4 * K:
            continue
        n_win += 1
        parts = np.stack(lag_correlation(seg_s, seg_r, K) if m is None
                         else masked_lag_correlation(seg_s, seg_r, m[a:a + W], K))
        tot += parts
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = parts[0] / np.sqrt(parts[1] * parts[2])
        lag, val, edge = _peak(rho)
        if math.isfinite(lag) and val >= MIN_CORRELATION and not edge:
            # weight: the window's explained energy (a strongly excited, well-correlated
            # window locates the peak more precisely than a quiet one)
            peaks.append((lag * dt, val**2 * float(parts[2, K])))
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = tot[0] / np.sqrt(tot[1] * tot[2])
    lag, val, edge = _peak(rho)
    std = math.nan
    if len(peaks) >= 3:
        d, w = np.array(peaks).T
        w = w / w.sum()
        n_eff = 1.0 / float(np.sum(w * w))
        var = float(np.sum(w * (d - np.sum(w * d)) ** 2)) * n_eff / max(n_eff - 1.0, 1.0)
        std = math.sqrt(var / n_eff)
    return DelayFit(lag * dt, std, val, len(peaks), n_win, edge)


def _heading_rate(drive: Drive) -> tuple[NDArray, NDArray]:
    """``dpsi/dt`` [rad/s] of the pose and the samples to trust (no jump, no outlier)."""
    t = drive.t
    psi = np.unwrap(drive.col("psi"))
    rate = np.gradient(psi, t) if len(t) > 2 else np.zeros(len(t))
    ok = np.isfinite(rate)
    if drive.has("pose_jump"):
        jump = drive.data["pose_jump"].to_numpy(bool)
        ok &= ~(jump | np.roll(jump, 1) | np.roll(jump, -1))
    if ok.any():
        med = float(np.median(rate[ok]))
        mad = float(np.median(np.abs(rate[ok] - med))) + 1e-6
        ok &= np.abs(rate - med) < max(20.0 * mad, 1.0)
    return rate, ok


def _sideslip_rate(drive: Drive, gyro_delay: float) -> tuple[NDArray, NDArray]:
    """``dv_y/dt`` [m/s²] from the pose (Savitzky-Golay over ``SIDESLIP_WINDOW``, then a
    moving mean as long), moved onto the gyro's clock (``gyro_delay`` [s] behind the pose),
    and the samples where it exists."""
    t = drive.t
    bad = drive.data["pose_jump"].to_numpy(bool) if drive.has("pose_jump") else None
    vy = body_velocity_from_pose(t, drive.col("x"), drive.col("y"), drive.col("psi"),
                                 window=SIDESLIP_WINDOW, bad=bad)[1]
    ok = np.isfinite(vy)
    if ok.sum() < 3:
        return np.zeros(len(t)), np.ones(len(t), bool)
    dvy = np.gradient(np.where(ok, vy, 0.0), t)
    dt = float(np.median(np.diff(t)))
    dvy = _moving_mean(dvy, round(SIDESLIP_WINDOW / dt))
    ok &= np.isfinite(dvy)
    if gyro_delay != 0.0:
        dvy = np.interp(t - gyro_delay, t, dvy)
        ok = np.interp(t - gyro_delay, t, ok.astype(float)) > 0.999
    return np.where(ok, dvy, 0.0), ok


def sensor_delays(drive: Drive, *, max_lag: float = 1.0, window: float = 30.0) -> list[SensorDelay]:
    """The delay of the accelerometer and the gyro against the drive's reference clock.

    The reference is the pose where the drive has one (``x, y, psi``), else the gyro
    (whose delay is then 0 by definition and not listed). A sensor whose columns are
    missing is left out.

    Parameters
    ----------
    drive : Drive
        Uses ``ay``, ``yaw_rate``, the speed (:func:`roadgrip.signals.wheel_speed_vx`),
        ``psi`` and ``pose_jump`` where present.
    max_lag, window : float
        [s], see :func:`estimate_delay`.

    Returns
    -------
    list of SensorDelay
    """
    out: list[SensorDelay] = []
    t = drive.t
    gyro_fit = None
    if drive.has("yaw_rate", "psi") and drive.has_pose:
        rate, ok = _heading_rate(drive)
        gyro_fit = estimate_delay(t, drive.col("yaw_rate"), rate, valid=ok, max_lag=max_lag,
                                  window=window)
        out.append(SensorDelay("gyro", GYRO, "pose", gyro_fit.delay, gyro_fit.std,
                               gyro_fit.peak_corr, ("r~dpsi/dt",), (gyro_fit,)))
    if drive.has("ay", "yaw_rate"):
        try:
            vx, _ = wheel_speed_vx(drive)
        except ValueError:
            vx = None
        if vx is not None:
            ref, ok, pair = vx * drive.col("yaw_rate"), None, "ay~vx*r"
            if gyro_fit is not None:
                dvy, ok = _sideslip_rate(drive, gyro_fit.delay if gyro_fit.reliable else 0.0)
                ref, pair = ref + dvy, "ay~vx*r+dvy/dt"
            fit = estimate_delay(t, drive.col("ay"), ref, valid=ok, max_lag=max_lag, window=window)
            cols = tuple(c for c in ACCELEROMETER if drive.has(c))
            if gyro_fit is None:
                out.append(SensorDelay("accelerometer", cols, "gyro", fit.delay, fit.std, fit.peak_corr,
                                       (pair,), (fit,)))
            else:
                std = math.hypot(fit.std, gyro_fit.std)
                out.append(SensorDelay("accelerometer", cols, "pose", fit.delay + gyro_fit.delay, std,
                                       min(fit.peak_corr, gyro_fit.peak_corr),
                                       (pair, "r~dpsi/dt"), (fit, gyro_fit)))
    return out


def align_drive(drive: Drive, delays: list[SensorDelay] | None = None, *,
                reliable_only: bool = True) -> tuple[Drive, list[SensorDelay]]:
    """The drive with each sensor's columns moved back by its delay.

    Parameters
    ----------
    drive : Drive
    delays : list of SensorDelay, optional
        Default :func:`sensor_delays` of the drive.
    reliable_only : bool
        Apply only delays that are :attr:`SensorDelay.reliable`.

    Returns
    -------
    aligned : Drive
        Shifted columns, the ends without a partner dropped; ``meta.extra['alignment_s']``
        holds the shift of each column [s].
    applied : list of SensorDelay
    """
    if delays is None:
        delays = sensor_delays(drive)
    applied = [d for d in delays if math.isfinite(d.delay) and (d.reliable or not reliable_only)]
    shifts: dict[str, float] = {}
    for d in applied:
        for col in d.columns:
            shifts[col] = d.delay
    if not shifts:
        return drive, []
    return shift_columns(drive, shifts), applied
