"""Any estimator of the registry fed one sample at a time, its rows out after its look-ahead.

:class:`OnlineEstimator` takes samples (mappings of canonical column to value, SI units)
from any source, in time order, and returns the rows that have become final: a row at
time ``t`` once a sample at ``t + lookahead`` or later has arrived
(``Estimator.lookahead``). It is the one stepping path of the package: the live loop
(:class:`roadgrip.live.runner.LiveEstimator`) and the causality test
(``tests/test_causality.py``) both go through it.

It holds the first samples (three, or ``warmup`` seconds of them), runs the method's
``prepare`` on them for what the method knows before the first sample (the columns, the
vehicle, the drive metadata, the GP-SSM's sub-steps), ``init`` and steps them. From then
on:

* a causal method (look-ahead 0) prepares each new sample with the sample before it
  (a difference, the interpolated sub-steps of the GP-SSM) through the method's
  ``prepare_rows`` (or ``prepare``) on those two rows held as NumPy columns
  (:class:`~roadgrip.estimators.array_frame.ArrayFrame`), and steps it (``step_donated``
  where the method has one: its state is not used again): a row costs one ``step`` and
  some 0.1 ms, with no DataFrame built;
* a method with a look-ahead (a pose differentiated by a centred fit) keeps the samples
  of ``2 lookahead`` plus :data:`CONTEXT_SAMPLES` intervals behind the last row out and
  those of the look-ahead in front of it, prepares that window at each sample and steps
  the prepared samples that are final.

Either way the samples are those of the method's own ``prepare`` and go through the same
``init`` / ``step`` as the batch run, so the rows equal ``run``'s on the same samples
(``tests/test_causality.py``). Memory is bounded by the window, not by the drive. The
method's floors (the sustained grip), running noise levels and filter states live in its
step state.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import pandas as pd

from roadgrip.drive import Drive, DriveMeta
from roadgrip.estimators import get
from roadgrip.estimators.array_frame import ArrayFrame
from roadgrip.estimators.base import conform
from roadgrip.estimators.protocol import DriveInfo, EstimatorConfig
from roadgrip.vehicle.params import VehicleParams

__all__ = ["CONTEXT_SAMPLES", "OnlineEstimator"]

CONTEXT_SAMPLES = 8
"""Sample intervals kept beyond twice the look-ahead: the previous sample of a difference
or an interpolation, and a margin for a jittered clock."""

_FIRST_SAMPLES = 3
"""Samples collected before the first ``prepare`` without a warm-up (a median interval
needs two)."""


class OnlineEstimator:
    """One estimator fed one sample at a time (module docstring).

    Parameters
    ----------
    method : str
        A method of :mod:`roadgrip.estimators`.
    vehicle : VehicleParams
    config : EstimatorConfig or mapping, optional
        The method's configuration or its options (``None``: defaults).
    seed : int
    sample_rate : float, optional
        Nominal sample rate [Hz] of the source (``DriveMeta.sample_rate``); default the
        rate of the first samples.
    extra : mapping, optional
        Drive metadata a reader would give (``DriveMeta.extra``: ``steer_is_command``,
        ``sensor_noise``, ``format``).
    warmup : float, optional
        Seconds of samples held before the first ``prepare`` [s] (the first chunk of a
        streamed drive); default three samples.

    Attributes
    ----------
    lookahead : float or None
        The declared look-ahead [s], known from the first samples.
    info : DriveInfo or None
        What ``prepare`` derived from the first samples.
    state : object
        The method's step state after the last sample stepped (None before).

    Examples
    --------
    >>> from roadgrip.sim.scenarios import simulate_scenario
    >>> drive = simulate_scenario("straight-cruise", duration=2.0)
    >>> online = OnlineEstimator("brls", drive.vehicle)
    >>> rows = [r for rec in drive.data.to_dict("records") for r in online.push(rec)]
    >>> rows += online.finish()
    >>> len(rows) == drive.n
    True
    """

    def __init__(self, method: str, vehicle: VehicleParams, config: EstimatorConfig | Mapping[str, Any] | None = None,
                 *, seed: int = 0, sample_rate: float | None = None, extra: Mapping[str, Any] | None = None,
                 warmup: float | None = None) -> None:
        self.estimator = get(method)
        if config is None or isinstance(config, Mapping):
            config = self.estimator.Config.from_options(config)
        self.config = config
        self.vehicle = vehicle
        self.seed = int(seed)
        self.sample_rate = None if sample_rate is None else float(sample_rate)
        self.extra = dict(extra or {})
        if warmup is not None and not warmup > 0:
            raise ValueError(f"warmup must be positive, got {warmup}")
        self.warmup = None if warmup is None else float(warmup)
        self.lookahead: float | None = None
        self.info: DriveInfo | None = None
        self.state: Any = None
        self._rows: list[dict[str, Any]] = []
        self._columns: list[str] | None = None
        self._meta: DriveMeta | None = None
        self._done = -math.inf  # time of the last sample stepped [s]
        self._keep = math.inf  # seconds of samples kept behind the last stepped one

    @property
    def started(self) -> bool:
        """The first samples have been prepared (the warm-up is over)."""
        return self.info is not None

    def push(self, sample: Mapping[str, float]) -> list[dict[str, Any]]:
        """Take one sample (``t`` [s] and the canonical columns, the same at every sample);
        return the rows that have become final, in time order."""
        row = dict(sample)
        if "t" not in row:
            raise ValueError("a sample needs its time 't' [s]")
        row["t"] = float(row["t"])
        if self._columns is None:
            self._columns = [str(c) for c in row]
        elif len(row) != len(self._columns) or not all(c in row for c in self._columns):
            raise ValueError(f"sample at t={row['t']} has columns {sorted(row)}, the first had {sorted(self._columns)}")
        if self._rows and not row["t"] > self._rows[-1]["t"]:
            raise ValueError(f"sample time {row['t']} does not follow {self._rows[-1]['t']}")
        self._rows.append(row)
        if self.info is None:
            return self._advance(None) if self._ready() else []
        assert self.lookahead is not None
        if self.lookahead == 0.0:
            return self._next_row()
        return self._advance(row["t"] - self.lookahead)

    def finish(self) -> list[dict[str, Any]]:
        """The rows still held back by the look-ahead (or the warm-up): the drive has ended."""
        if not self._rows or (self.info is not None and self.lookahead == 0.0):
            return []
        return self._advance(math.inf)

    def _ready(self) -> bool:
        """Enough first samples for the first ``prepare``."""
        if self.warmup is None:
            return len(self._rows) >= _FIRST_SAMPLES
        return len(self._rows) >= 2 and self._rows[-1]["t"] - self._rows[0]["t"] + 1e-9 >= self.warmup

    def _samples(self, window: Drive) -> Sequence[Any]:
        """The method's samples of ``window``, a piece of the drive after its start."""
        assert self.info is not None
        if self.estimator.prepare_rows is not None:
            return self.estimator.prepare_rows(window, self.config, self.info)
        return self.estimator.prepare(window, self.config).samples

    def _next_row(self) -> list[dict[str, Any]]:
        """A causal method: the newest sample prepared with the one before it, stepped."""
        assert self._meta is not None and self._columns is not None
        rows = self._rows[-2:]
        del self._rows[:-1]
        window = Drive(ArrayFrame.from_records(rows, self._columns), self._meta)  # type: ignore[arg-type]
        return self._step(self._samples(window), math.inf)

    def _step(self, samples: Sequence[Any], until: float) -> list[dict[str, Any]]:
        """Step the samples after the last stepped one up to ``until`` [s]."""
        step = self.estimator.step_donated or self.estimator.step  # the old state is not used again
        out: list[dict[str, Any]] = []
        for s in samples:
            if s.t <= self._done or s.t > until:
                continue
            self.state, r = step(self.state, s)
            if r is not None:
                out.append(dict(r))
            self._done = float(s.t)
        return out

    def _window(self) -> Drive:
        if self._meta is None:
            df = pd.DataFrame(self._rows, columns=self._columns)
            first = Drive.from_frame(df, self.vehicle, source="online", extra=self.extra)
            rate = self.sample_rate if self.sample_rate is not None else first.meta.sample_rate
            self._meta = DriveMeta(self.vehicle, "online", float(rate), None, dict(self.extra))
            return Drive(first.data, self._meta)
        assert self._columns is not None
        return Drive(ArrayFrame.from_records(self._rows, self._columns), self._meta)  # type: ignore[arg-type]

    def _advance(self, until: float | None) -> list[dict[str, Any]]:
        """Step the prepared samples of the window after the last stepped one up to
        ``until`` [s] (None: the newest sample's time less the look-ahead)."""
        window = self._window()
        if self.info is None:  # the first samples: what prepare knows before the first
            prepared = self.estimator.prepare(window, self.config)
            info: DriveInfo = prepared.info
            self.lookahead = float(self.estimator.lookahead(self.config, info))
            rate = window.meta.sample_rate
            self._keep = 2.0 * self.lookahead + (CONTEXT_SAMPLES / rate if rate > 0 else 0.0)
            self.state = self.estimator.init(info, self.config, self.seed)
            self.info = info
            samples = prepared.samples
        else:
            samples = self._samples(window)
        assert self.lookahead is not None
        if until is None:
            until = float(window.t[-1]) - self.lookahead
        out = self._step(samples, until)
        cut = self._done - self._keep
        while len(self._rows) > 2 and self._rows[1]["t"] < cut:
            self._rows.pop(0)
        return out

    def table(self, rows: list[dict[str, Any]]) -> pd.DataFrame:
        """Rows of :meth:`push` / :meth:`finish` as the estimates table (contract columns first)."""
        return conform(pd.DataFrame(rows))
