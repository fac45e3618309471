"""The GP-SSM filter over a drive given in chunks: memory bounded by the chunk, not the drive.

:func:`run_chunks` takes consecutive pieces of one drive (e.g. row groups of a Parquet
file, :func:`roadgrip.cli.stream.drive_chunks`) and yields the estimates table of each.
What the filter carries from one sample to the next passes from chunk to chunk in a
:class:`StreamState`: the particles, their conjugate statistics and information
matrices, the random generator (advanced per step inside the compiled block, so chunk
seams need not fall on any block boundary), the slip histogram and moments, the peak
slip angles, the guard's trailing second of ``a_y`` and its physics floor, the divergence
bookkeeping, the last input row (the sub-steps up to the next chunk's first sample
interpolate from it) and a running tally of the diagnostics. None of it grows with the
drive.

What :func:`~roadgrip.estimators.gpssm.estimator.prepare` derives from a whole drive, the
sub-steps per sample interval (``ceil(median dt / max_dt)``), comes from the first chunk.
With the inputs read sample by sample (speed from the wheels or a ``vx`` column, the
accelerometer's ``a_y``, no pose) the chunks give the rows of
:func:`~roadgrip.estimators.gpssm.estimator.run` over the whole drive for the same seed,
bit for bit, wherever the seams fall. The pose derivatives (``vx_source='pose'``,
``vy_source='pose'``, ``ay_source='kinematic'``) are taken per chunk, so near a seam they
differ from the whole drive's.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.blas_threads import one_blas_thread
from roadgrip.estimators.gpssm.config import GPSSMConfig
from roadgrip.estimators.gpssm.estimator import config_inputs, rows_table, run_block
from roadgrip.estimators.gpssm.guard import Guard
from roadgrip.estimators.gpssm.inputs import substeps, upsample_inputs
from roadgrip.estimators.gpssm.posterior import CurvePosterior, posterior_curves
from roadgrip.estimators.gpssm.state import Context, GPSSMState, copy_state
from roadgrip.estimators.protocol import DriveInfo

__all__ = ["ChunkResult", "StreamState", "Tally", "begin", "carried_bytes", "pending_curves", "run_chunk",
           "run_chunks"]


class Tally(NamedTuple):
    """Running totals over the rows so far (the diagnostics of
    :func:`~roadgrip.estimators.gpssm.estimator.run`'s ``meta``)."""

    rows: int = 0
    ess_sum: float = 0.0
    ess_min: float = np.inf
    resampled: int = 0
    diverged: int = 0
    excited: int = 0
    collapsed: int = 0

    def add(self, table: pd.DataFrame) -> Tally:
        """The tally with the rows of ``table`` (a chunk's) added."""
        if not len(table):
            return self
        ess = table["ess"].to_numpy(float)
        return Tally(self.rows + len(table), self.ess_sum + float(ess.sum()), min(self.ess_min, float(ess.min())),
                     self.resampled + int(table["resampled"].sum()), self.diverged + int(table["diverged"].sum()),
                     self.excited + int(table["excited"].sum()), self.collapsed + int(table["collapsed"].sum()))

    def diagnostics(self) -> dict[str, Any]:
        """``ess_mean``, ``ess_min`` (effective sample size [particles]),
        ``resampling_rate`` [-], ``diverged_samples``, ``collapsed_samples`` and
        ``excited_samples``."""
        n = max(self.rows, 1)
        return {"ess_mean": self.ess_sum / n, "ess_min": float(self.ess_min), "resampling_rate": self.resampled / n,
                "diverged_samples": self.diverged, "collapsed_samples": self.collapsed,
                "excited_samples": self.excited}


class StreamState(NamedTuple):
    """What passes from one chunk to the next.

    Attributes
    ----------
    info : DriveInfo
        What :func:`begin` derived from the first chunk (``derived['substeps']``: filter
        steps per sample interval).
    ctx : Context
        The run's configuration, vehicle and noise levels (and the compiled step's
        constants and scratch, which hold nothing of the drive).
    seed : int
    filter : GPSSMState or None
        The filter after the last sample so far (None before the first): particles,
        statistics, random generator, slip histogram, guard window.
    last : ndarray, shape (7,), or None
        The last input row so far (:func:`~roadgrip.estimators.gpssm.inputs.drive_inputs`
        columns).
    pending : tuple of float
        The requested curve times [s from the drive start] not reached yet.
    curve_alpha : ndarray, shape (n_alpha,)
        Slip grid of the posterior curves [rad].
    tally : Tally
    """

    info: DriveInfo
    ctx: Context
    seed: int
    filter: GPSSMState | None
    last: NDArray | None
    pending: tuple[float, ...]
    curve_alpha: NDArray
    tally: Tally


class ChunkResult(NamedTuple):
    """One chunk's estimates.

    Attributes
    ----------
    table : DataFrame
        The rows of the chunk's samples (the columns of
        :func:`~roadgrip.estimators.gpssm.estimator.run`'s table).
    state : StreamState
        The state after the chunk's last sample (its own copy: the next chunk does not
        change it).
    info : DriveInfo
        What :func:`begin` derived from the first chunk (the same for every chunk).
    curves : dict
        Requested time [s from the drive start] ->
        :class:`~roadgrip.estimators.gpssm.posterior.CurvePosterior` at the first
        sample at or after it, for the times reached in this chunk. Updating one dict
        with every chunk's and then with :func:`pending_curves` of the last chunk's state
        gives the curves of the whole run.
    """

    table: pd.DataFrame
    state: StreamState
    info: DriveInfo
    curves: dict[float, CurvePosterior]


def begin(first: Any, config: GPSSMConfig | None = None, seed: int = 0, *,
          curve_alpha: NDArray | None = None) -> StreamState:
    """The state before the first chunk, with what the whole drive's run derives from the
    drive taken from the first chunk ``first`` (a Drive; not filtered here).

    Parameters
    ----------
    first : Drive
        The first chunk.
    config : GPSSMConfig, optional
    seed : int
    curve_alpha : ndarray, optional
        Slip grid of the curves at ``config.curve_times`` [rad]; default 161 points on
        ``±peak_range``.
    """
    config = config if config is not None else GPSSMConfig()
    k = substeps(first.col("t"), config.max_dt)
    info = DriveInfo.from_drive(first, substeps=int(k))
    if curve_alpha is None:
        curve_alpha = np.linspace(-config.peak_range, config.peak_range, 161)
    return StreamState(info, Context(config, info.vehicle, k), int(seed), None, None,
                       tuple(sorted(config.curve_times)), np.asarray(curve_alpha, float), Tally())


def _chunk_samples(state: StreamState, chunk: Any) -> tuple[NDArray, NDArray]:
    """The chunk's filter samples (n', 9) (``sample_array`` layout, sub-steps included)
    and its last input row."""
    config = state.ctx.config
    data = config_inputs(chunk, config)
    if not len(data):
        raise ValueError("a chunk of the drive has no samples")
    k = state.ctx.substeps
    if state.last is None:
        rows, keep, _ = upsample_inputs(data, config.max_dt, k)
    else:
        if not data[0, 0] > state.last[0]:
            raise ValueError(f"chunks must follow each other in time: a chunk starts at t = {data[0, 0]} s, "
                             f"the one before ended at t = {state.last[0]} s")
        # the sub-steps of the interval across the seam interpolate from the last row before it
        rows, keep, _ = upsample_inputs(np.vstack([state.last, data]), config.max_dt, k)
        rows, keep = rows[1:], keep[1:]
    return np.column_stack([rows[:, :7], keep.astype(float), rows[:, 7:]]), data[-1].copy()


def run_chunk(state: StreamState, chunk: Any) -> ChunkResult:
    """Filter one chunk from ``state`` (left unchanged).

    Parameters
    ----------
    state : StreamState
        From :func:`begin` or the previous chunk's result.
    chunk : Drive
        The samples after ``state``'s (times increasing, none before its last).

    Returns
    -------
    ChunkResult
    """
    data, last = _chunk_samples(state, chunk)
    ctx, t0 = state.ctx, state.info.t0
    recorded = data[:, 7] != 0.0
    rec = np.flatnonzero(recorded)
    t_rec = data[rec, 0]
    # the curve times reached in this chunk: at the first recorded sample at or after each
    reached = {t: int(rec[j]) for t in state.pending if (j := int(np.searchsorted(t_rec, t0 + t))) < len(rec)}
    pending = tuple(t for t in state.pending if t not in reached)
    filt = None if state.filter is None else copy_state(state.filter)
    curves: dict[float, CurvePosterior] = {}
    blocks = []
    start = 0
    with one_blas_thread():
        for end in sorted({*reached.values(), len(data) - 1}):
            filt, out = run_block(ctx, filt, data[start:end + 1], state.seed)
            blocks.append(out)
            at_end = [t for t, i in reached.items() if i == end]
            if at_end:
                cp = posterior_curves(ctx, filt, state.curve_alpha)
                for t in at_end:
                    curves[(t0 + t) - t0] = cp
            start = end + 1
    table = rows_table(np.concatenate(blocks)[recorded])
    assert filt is not None
    new = state._replace(filter=filt, last=last, pending=pending, tally=state.tally.add(table))
    return ChunkResult(table, new, state.info, curves)


def pending_curves(state: StreamState) -> dict[float, CurvePosterior]:
    """The curves of the requested times not reached by the samples so far, at the last
    sample (after the last chunk: the whole run's curves for times beyond the drive's
    end). Empty when every time was reached or before the first sample."""
    if not state.pending or state.filter is None:
        return {}
    t0 = state.info.t0
    with one_blas_thread():
        cp = posterior_curves(state.ctx, state.filter, state.curve_alpha)
    return {(t0 + t) - t0: cp for t in state.pending}


def run_chunks(chunks: Iterable[Any], config: GPSSMConfig | None = None, seed: int = 0, *,
               curve_alpha: NDArray | None = None) -> Iterator[ChunkResult]:
    """The GP-SSM filter over consecutive chunks of one drive (times increasing across
    chunks).

    Parameters
    ----------
    chunks : iterable of Drive
        Pieces of one drive, in order; the first with at least two samples (its median
        interval sets the sub-steps), the others with at least one.
    config : GPSSMConfig, optional
    seed : int
        The filter's random seed (the same rows as ``run(drive, config, seed)``).
    curve_alpha : ndarray, optional
        Slip grid [rad] of the curves at ``config.curve_times`` (:func:`begin`).

    Yields
    ------
    ChunkResult
    """
    config = config if config is not None else GPSSMConfig()
    state: StreamState | None = None
    for chunk in chunks:
        if state is None:
            if chunk.n < 2:
                raise ValueError(f"the first chunk of a streamed drive needs at least two samples, got {chunk.n}")
            state = begin(chunk, config, seed, curve_alpha=curve_alpha)
        res = run_chunk(state, chunk)
        state = res.state
        yield res


def carried_bytes(obj: Any, _seen: set[int] | None = None) -> int:
    """Bytes a :class:`StreamState` carries to the next chunk [B].

    The arrays reachable from it, each counted once (a view of an array already counted
    adds nothing), and the guard's trailing window at 8 bytes a value; other Python
    objects count nothing. What must not grow with the number of chunks.
    """
    seen = set() if _seen is None else _seen
    if id(obj) in seen:
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return obj.nbytes if obj.base is None or id(obj.base) not in seen else 0
    if isinstance(obj, Guard):
        return 8 * (len(obj.times) + len(obj.ay) + len(obj.accel) + len(obj.nis))
    if isinstance(obj, Context):
        return carried_bytes(obj.kernel, seen)
    if isinstance(obj, dict):
        return sum(carried_bytes(v, seen) for v in obj.values())
    if isinstance(obj, tuple | list):
        return sum(carried_bytes(v, seen) for v in obj)
    return 0
