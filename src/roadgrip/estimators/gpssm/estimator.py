"""The GP-SSM filter as an estimator of the protocol (:mod:`roadgrip.estimators.protocol`).

``prepare`` takes the filter's inputs from a drive and interpolates sub-steps where the
data are slower than ``max_dt``; ``init`` / ``step`` run the filter one sample at a time
(a sub-step gives no row); ``run`` processes a whole drive and returns the table, the
posterior curves at ``curve_times`` and the summary. :class:`GPSSM` is a small online
object for callers that feed samples themselves.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.blas_threads import one_blas_thread
from roadgrip.estimators.base import EstimateResult, ProgressCallback, conform
from roadgrip.estimators.gpssm.compiled import BOOL_COLUMNS, ROW_FIELDS, advance, sample_array
from roadgrip.estimators.gpssm.config import GPSSMConfig
from roadgrip.estimators.gpssm.inputs import Sample, accelerometer_ay, drive_inputs, upsample_inputs
from roadgrip.estimators.gpssm.posterior import CurvePosterior, curves_frame, posterior_curves
from roadgrip.estimators.gpssm.state import Context, GPSSMEstimate, GPSSMState, copy_state
from roadgrip.estimators.gpssm.stepping import step as filter_step
from roadgrip.estimators.gpssm.stepping import step_unthreaded
from roadgrip.estimators.protocol import DriveInfo, Prepared
from roadgrip.vehicle.params import VehicleParams

__all__ = ["GPSSM", "FilterState", "config_inputs", "init", "prepare", "prepare_rows", "prior_band", "run", "run_block", "run_filter",
           "step", "step_donated"]

PROGRESS_EVERY = 50
"""Output rows between two calls of the progress callback."""


class FilterState(NamedTuple):
    """Protocol state: the run's context, the seed and the filter state (None before
    the first sample)."""

    ctx: Context
    seed: int
    state: GPSSMState | None


def config_inputs(drive: Any, config: GPSSMConfig) -> NDArray[np.float64]:
    """:func:`~roadgrip.estimators.gpssm.inputs.drive_inputs` of a drive (or a chunk of one)
    with ``config``'s sources and its plausibility bound on a measured ``vy``, and the
    accelerometer's ``ay`` where the filter's is another source
    (:func:`~roadgrip.estimators.gpssm.inputs.accelerometer_ay`), shape (n, 8)."""
    data = drive_inputs(drive, config.vx_source, config.vy_source, config.ay_source,
                        max_sideslip_ratio=config.max_sideslip_ratio, min_speed=config.min_speed)
    return np.column_stack([data, accelerometer_ay(drive, config.ay_source)])


def prepare(drive: Any, config: GPSSMConfig) -> Prepared:
    """The filter's input samples of a drive (:class:`~roadgrip.estimators.gpssm.inputs.Sample`),
    with interpolated sub-steps (``recorded=False``) where the sample interval exceeds
    ``config.max_dt``; ``info.derived['substeps']`` is their number per interval."""
    data, keep, k = upsample_inputs(config_inputs(drive, config), config.max_dt)
    return Prepared(DriveInfo.from_drive(drive, substeps=int(k)), _samples(data, keep))


def prepare_rows(drive: Any, config: GPSSMConfig, info: DriveInfo) -> list[Sample]:
    """The input samples of a piece of a drive whose start :func:`prepare` has seen, with
    the start's sub-steps per interval (``info.derived['substeps']``, as a streamed drive's
    later chunks, :mod:`~roadgrip.estimators.gpssm.stream`): the interval from the piece's
    first row to its second is interpolated as the whole drive's run does it."""
    k = int(info.derived.get("substeps", 1))
    data, keep, _ = upsample_inputs(config_inputs(drive, config), config.max_dt, k)
    return _samples(data, keep)


def _samples(data: NDArray[np.float64], keep: NDArray[np.bool_]) -> list[Sample]:
    return [Sample(*row[:7], recorded=bool(kept), ay_accel=row[7]) for row, kept in zip(data, keep, strict=True)]


def init(info: DriveInfo, config: GPSSMConfig, seed: int = 0) -> FilterState:
    """The state before the first sample (the filter initialises from that sample)."""
    return FilterState(Context(config, info.vehicle, info.derived.get("substeps", 1)), int(seed), None)


def step(fs: FilterState, sample: Sample) -> tuple[FilterState, dict[str, Any] | None]:
    """One sample: the next state and the output row (None for a sub-step). The input
    state is left unchanged."""
    return step_donated(fs if fs.state is None else fs._replace(state=copy_state(fs.state)), sample)


def step_donated(fs: FilterState, sample: Sample) -> tuple[FilterState, dict[str, Any] | None]:
    """:func:`step` that reuses (overwrites) the arrays of ``fs``, which the caller gives up:
    the same state and row without the copy of the particles' statistics (about half of a
    step's time at the default 400 particles)."""
    new, est = filter_step(fs.ctx, fs.state, sample, fs.seed)
    return fs._replace(state=new), (_row(est) if sample.recorded else None)


def prior_band(config: GPSSMConfig) -> tuple[float, float]:
    """``(0, peak_max)``: before any excitation the data bound the peak by nothing."""
    return 0.0, float(config.peak_max)


def _row(est: GPSSMEstimate) -> dict[str, Any]:
    row = est._asdict()
    return {("yaw_rate_est" if k == "yaw_rate" else k): v for k, v in row.items()}


def run_filter(
    drive: Any,
    config: GPSSMConfig,
    seed: int = 0,
    *,
    curve_times: Sequence[float] | None = None,
    curve_alpha: NDArray | None = None,
    progress: ProgressCallback | None = None,
) -> tuple[pd.DataFrame, dict[float, CurvePosterior]]:
    """Filter a whole drive.

    Parameters
    ----------
    drive : Drive
    config : GPSSMConfig
    seed : int
    curve_times : sequence of float, optional
        Times [s from the drive start] of the posterior curves; default
        ``config.curve_times``.
    curve_alpha : ndarray, optional
        Slip grid of the curves [rad]; default 161 points on ``±peak_range``.
    progress : callable, optional
        Called with the number of rows produced since its last call.

    Returns
    -------
    table : DataFrame
        One row per recorded sample: the contract columns and the fields of
        :class:`~roadgrip.estimators.gpssm.state.GPSSMEstimate` (``yaw_rate`` as
        ``yaw_rate_est``).
    curves : dict
        Requested time -> :class:`~roadgrip.estimators.gpssm.posterior.CurvePosterior`
        at the first sample at or after it (the last sample for times beyond the end).
    """
    prepared = prepare(drive, config)
    fs = init(prepared.info, config, seed)
    ctx = fs.ctx
    times = sorted(config.curve_times if curve_times is None else curve_times)
    if curve_alpha is None:
        curve_alpha = np.linspace(-config.peak_range, config.peak_range, 161)
    data = sample_array(prepared.samples)
    recorded = data[:, 7] != 0.0
    # where the curves are read: the first recorded sample at or after each time (the last
    # one for times beyond the end)
    rec = np.flatnonzero(recorded)
    t_rec = data[rec, 0]
    t0 = prepared.info.t0
    at = [int(rec[min(int(np.searchsorted(t_rec, t0 + t)), len(rec) - 1)]) for t in times]
    ends = set(at)
    if progress is not None:  # the callback every PROGRESS_EVERY rows
        ends.update(int(i) for i in rec[PROGRESS_EVERY - 1::PROGRESS_EVERY])
    ends.add(len(data) - 1)
    curves: dict[float, CurvePosterior] = {}
    state = None
    blocks = []
    start = 0
    with one_blas_thread():
        for end in sorted(ends):
            state, out = run_block(ctx, state, data[start:end + 1], seed)
            blocks.append(out)
            for t, i in zip(times, at, strict=True):
                if i == end:
                    curves[(t0 + t) - t0] = posterior_curves(ctx, state, curve_alpha)
            if progress is not None:
                done = int(recorded[start:end + 1].sum())
                if done:
                    progress(done)
            start = end + 1
    out = np.concatenate(blocks)[recorded]
    return rows_table(out), curves


def run_block(ctx: Context, state: GPSSMState | None, data: NDArray, seed: int = 0) -> tuple[GPSSMState, NDArray]:
    """Samples ``data`` (K, 8) (:func:`~roadgrip.estimators.gpssm.compiled.sample_array`)
    through the filter from ``state`` (None: initialise from the first sample with
    ``seed``): the compiled step (:func:`~roadgrip.estimators.gpssm.compiled.advance`), or
    the NumPy reference for ``linalg='direct'``. The state after the block reuses the
    arrays of ``state``; the rows (K, len(ROW_FIELDS)) are one per sample."""
    if ctx.config.linalg == "direct":
        return _stepped(ctx, state, data, seed)
    return advance(ctx, state, data, seed)


def _stepped(ctx: Context, state: GPSSMState | None, data: NDArray, seed: int) -> tuple[GPSSMState, NDArray]:
    """The NumPy reference step (``linalg='direct'``) over samples, rows as :func:`advance`'s."""
    out = np.empty((len(data), len(ROW_FIELDS)))
    for i, row in enumerate(data):
        state, est = step_unthreaded(ctx, state, Sample(*row), seed)
        out[i] = est
    return state, out


def rows_table(out: NDArray) -> pd.DataFrame:
    """The table of the rows of :func:`run_block` (as :func:`_row` gives them)."""
    cols = {("yaw_rate_est" if k == "yaw_rate" else k): out[:, i] for i, k in enumerate(ROW_FIELDS)}
    for k in BOOL_COLUMNS:
        cols[k] = cols[k] != 0.0
    return conform(pd.DataFrame(cols))


def run(
    drive: Any, config: GPSSMConfig | None = None, seed: int = 0, progress: ProgressCallback | None = None
) -> EstimateResult:
    """The whole drive: table, posterior curves at ``config.curve_times`` and meta.

    ``meta`` holds ``config``, ``seed``, ``timing``, ``diagnostics`` (effective sample
    size, resampling rate, ``diverged_samples`` and a ``warning`` when there are any,
    ``collapsed_samples``: steps whose weights collapsed, column ``collapsed``)
    and ``summary``: the smaller of the two axles' peak estimates
    and the union of their bands at the last sample.
    """
    config = config if config is not None else GPSSMConfig()
    t_start = time.perf_counter()
    table, curves = run_filter(drive, config, seed, progress=progress)
    wall = max(time.perf_counter() - t_start, 1e-12)
    meta: dict[str, Any] = {
        "config": config.to_meta(),
        "seed": int(seed),
        "timing": {"wall_s": wall, "samples": int(drive.n), "samples_per_s": drive.n / wall,
                   "realtime_factor": drive.duration / wall},
        "diagnostics": {
            "ess_mean": float(table["ess"].mean()),
            "ess_min": float(table["ess"].min()),
            "resampling_rate": float(table["resampled"].mean()),
            "particles": config.particles,
            "basis": config.basis.label(),
            "linalg": config.linalg,
        },
        "summary": summary(table),
    }
    n_div = int(table["diverged"].sum())
    meta["diagnostics"]["diverged_samples"] = n_div
    meta["diagnostics"]["collapsed_samples"] = int(table["collapsed"].sum())
    if n_div:
        meta["diagnostics"]["warning"] = (
            f"the filter diverged on {n_div} of {len(table)} samples (column 'diverged'): "
            "there the peaks are reported with the prior band and the state was re-initialised")
    if not table["excited"].any():
        meta["diagnostics"]["information"] = "no excitation: posterior equals the prior"
    return EstimateResult("gpssm", table, meta, curves_frame(curves, drive) if curves else None)


def summary(table: pd.DataFrame) -> dict[str, float]:
    """VSS-style summary of the last row: ``MostProbable`` the smaller axle peak,
    ``LowerBound`` / ``UpperBound`` the union of the axle bands."""
    last = table.iloc[-1]
    return {
        "MostProbable": float(min(last["mu_front"], last["mu_rear"])),
        "LowerBound": float(min(last["mu_front_lower"], last["mu_rear_lower"])),
        "UpperBound": float(max(last["mu_front_upper"], last["mu_rear_upper"])),
    }


class GPSSM:
    """Online GP-SSM friction learner fed one :class:`Sample` at a time.

    Wraps :func:`~roadgrip.estimators.gpssm.stepping.step`; the configuration is never
    changed. Samples are taken as given (no sub-steps: see :func:`prepare`).

    Parameters
    ----------
    config : GPSSMConfig
    vehicle : VehicleParams
    seed : int

    Examples
    --------
    >>> from roadgrip.vehicle import PRESETS
    >>> f = GPSSM(GPSSMConfig(particles=20, basis="separable:8"), PRESETS["suv"])
    >>> est = f.step(Sample(t=0.0, ay=0.0, yaw_rate=0.0, steer=0.0, vx=15.0))
    >>> est.excited
    False
    """

    def __init__(self, config: GPSSMConfig, vehicle: VehicleParams, seed: int = 0) -> None:
        self.ctx = Context(config, vehicle)
        self.seed = seed
        self.state_: GPSSMState | None = None

    @property
    def config(self) -> GPSSMConfig:
        return self.ctx.config

    def step(self, sample: Sample) -> GPSSMEstimate:
        self.state_, est = filter_step(self.ctx, self.state_, sample, self.seed)
        return est

    def curves(self, alpha: NDArray, level: float = 0.95) -> CurvePosterior:
        if self.state_ is None:
            raise ValueError("no data yet: call step() first")
        with one_blas_thread():
            return posterior_curves(self.ctx, self.state_, alpha, level)

