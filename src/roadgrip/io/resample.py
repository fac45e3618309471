"""Resampling of asynchronous streams onto one clock.

Each stream is a frame with its own time column ``t`` [s] and some signal
columns. Continuous signals are interpolated linearly; commands and other
piecewise-constant signals can be held (zero-order hold, the last value
received). Nothing is extrapolated: outside a stream's span, and inside gaps
longer than ``max_gap``, its signals are missing, and with ``drop_missing``
those clock ticks are dropped.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np
import pandas as pd

__all__ = ["make_clock", "resample"]


def make_clock(t_start: float, t_end: float, rate: float) -> np.ndarray:
    """Uniform clock ``t_start + k / rate`` for all ``k`` with a tick ``<= t_end``.

    Parameters
    ----------
    t_start, t_end : float
        Span [s].
    rate : float
        Sample rate [Hz], positive.

    Returns
    -------
    ndarray, shape (n,)
    """
    if not rate > 0 or not np.isfinite(rate):
        raise ValueError(f"resample rate must be positive and finite, got {rate!r} Hz")
    if not t_end >= t_start:
        raise ValueError(f"resample span is empty: [{t_start}, {t_end}] s")
    n = int(np.floor((t_end - t_start) * rate + 1e-9)) + 1
    return t_start + np.arange(n) / rate


def _stream_time(name: str, df: pd.DataFrame) -> np.ndarray:
    if "t" not in df.columns:
        raise ValueError(f"stream {name!r} has no time column 't'")
    t = df["t"].to_numpy(float)
    if len(t) == 0:
        raise ValueError(f"stream {name!r} is empty")
    if not np.isfinite(t).all():
        raise ValueError(f"stream {name!r} has NaN/inf time stamps")
    if len(t) > 1 and (np.diff(t) <= 0).any():
        raise ValueError(f"stream {name!r}: time is not strictly increasing")
    return t


def resample(
    streams: Mapping[str, pd.DataFrame],
    rate: float | None = None,
    clock: np.ndarray | None = None,
    *,
    hold: Iterable[str] = (),
    max_gap: float | None = None,
    drop_missing: bool = True,
) -> pd.DataFrame:
    """Put asynchronous streams onto one clock.

    Parameters
    ----------
    streams : mapping of str to DataFrame
        Stream name -> frame with a strictly increasing ``t`` [s] column and signal
        columns (numeric). Signal names must be unique across streams.
    rate : float, optional
        Output rate [Hz]; the clock then spans the overlap of all streams (the
        latest start to the earliest end). Exactly one of ``rate`` and ``clock``.
    clock : ndarray, shape (n,), optional
        Explicit output times [s], strictly increasing.
    hold : iterable of str
        Signal columns resampled with zero-order hold (last value received at or
        before the tick) instead of linear interpolation.
    max_gap : float, optional
        Longest gap [s] between two samples of a stream that is bridged; ticks
        inside a longer gap get NaN for that stream's signals.
    drop_missing : bool
        Drop the ticks where any signal is missing (outside a stream's span or in
        a gap). Otherwise they are kept as NaN.

    Returns
    -------
    DataFrame
        Column ``t`` then the signals of each stream in order.
    """
    if not streams:
        raise ValueError("resample needs at least one stream")
    if (rate is None) == (clock is None):
        raise ValueError("resample needs exactly one of rate and clock")
    times = {name: _stream_time(name, df) for name, df in streams.items()}
    if clock is None:
        t0 = max(t[0] for t in times.values())
        t1 = min(t[-1] for t in times.values())
        if t1 < t0:
            raise ValueError("streams do not overlap in time: nothing to resample")
        clock = make_clock(t0, t1, float(rate))
    clock = np.asarray(clock, dtype=float)
    if clock.ndim != 1 or (len(clock) > 1 and (np.diff(clock) <= 0).any()):
        raise ValueError("resample clock must be a 1-D strictly increasing array")
    hold = set(hold)
    out: dict[str, np.ndarray] = {"t": clock}
    for name, df in streams.items():
        ts = times[name]
        inside = (clock >= ts[0]) & (clock <= ts[-1])
        # index of the last sample at or before each tick
        k = np.clip(np.searchsorted(ts, clock, side="right") - 1, 0, len(ts) - 1)
        if max_gap is not None and len(ts) > 1:
            k2 = np.minimum(k + 1, len(ts) - 1)
            gap = ts[k2] - ts[k]
            on_sample = ts[k] == clock
            inside &= (gap <= max_gap) | on_sample
        for col in df.columns:
            if col == "t":
                continue
            if col in out:
                raise ValueError(f"signal {col!r} appears in more than one stream")
            v = df[col].to_numpy(float)
            r = v[k] if col in hold else np.interp(clock, ts, v)
            out[col] = np.where(inside, r, np.nan)
    res = pd.DataFrame(out)
    if drop_missing:
        res = res[res.notna().all(axis=1)].reset_index(drop=True)
    return res
