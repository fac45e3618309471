"""Any estimator of the registry fed one sample at a time, its rows out after its look-ahead.

:class:`OnlineEstimator` takes samples (mappings of canonical column to value, SI units)
from any source, in time order, and returns the rows that have become final: a row at
time ``t`` once a sample at ``t + lookahead`` or later has arrived
(``Estimator.lookahead``). It keeps the samples of ``2 lookahead`` plus
:data:`CONTEXT_SAMPLES` intervals behind the last row out and those of the look-ahead in
front of it, what the method's input preparation needs
around a sample (a centred pose fit, a difference with the previous sample, the
interpolated sub-steps of the GP-SSM), runs the method's ``prepare`` on them and
steps the prepared samples that are final through ``init`` / ``step``: the same
protocol functions as the batch run, so the rows equal ``run``'s on the same samples
(``tests/test_causality.py``). Memory is bounded by that window, not by the drive.

The method's floors (the sustained grip), running noise levels and filter states live
in its step state; what ``prepare`` knows before the first sample comes from the
first samples (the columns, the vehicle, the drive metadata given).

Limitation: the GP-SSM interpolates sub-steps with the count of the first samples'
median interval; a clock whose intervals straddle a multiple of ``max_dt`` can give
another count later than the batch run's over the whole drive.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from roadgrip.drive import Drive, DriveMeta
from roadgrip.estimators import get
from roadgrip.estimators.base import conform
from roadgrip.estimators.protocol import DriveInfo, EstimatorConfig
from roadgrip.vehicle.params import VehicleParams

__all__ = ["CONTEXT_SAMPLES", "OnlineEstimator"]

CONTEXT_SAMPLES = 8
"""Sample intervals kept beyond twice the look-ahead: the previous sample of a difference
or an interpolation, and a margin for a jittered clock."""

_FIRST_SAMPLES = 3
"""Samples collected before the first ``prepare`` (a median interval needs two)."""


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

    Attributes
    ----------
    lookahead : float or None
        The declared look-ahead [s], known from the first samples.

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
                 *, seed: int = 0, sample_rate: float | None = None, extra: Mapping[str, Any] | None = None) -> None:
        self.estimator = get(method)
        if config is None or isinstance(config, Mapping):
            config = self.estimator.Config.from_options(config)
        self.config = config
        self.vehicle = vehicle
        self.seed = int(seed)
        self.sample_rate = None if sample_rate is None else float(sample_rate)
        self.extra = dict(extra or {})
        self.lookahead: float | None = None
        self._rows: list[dict[str, Any]] = []
        self._columns: list[str] | None = None
        self._meta: DriveMeta | None = None
        self._state: Any = None
        self._done = -math.inf  # time of the last sample stepped [s]
        self._keep = math.inf  # seconds of samples kept behind the last stepped one

    def push(self, sample: Mapping[str, float]) -> list[dict[str, Any]]:
        """Take one sample (``t`` [s] and the canonical columns, the same at every sample);
        return the rows that have become final, in time order."""
        row = {str(k): v for k, v in sample.items()}
        if "t" not in row:
            raise ValueError("a sample needs its time 't' [s]")
        row["t"] = float(row["t"])
        if self._columns is None:
            self._columns = list(row)
        elif set(row) != set(self._columns):
            raise ValueError(f"sample at t={row['t']} has columns {sorted(row)}, the first had {sorted(self._columns)}")
        if self._rows and not row["t"] > self._rows[-1]["t"]:
            raise ValueError(f"sample time {row['t']} does not follow {self._rows[-1]['t']}")
        self._rows.append(row)
        if self._state is None:
            return self._advance(None) if len(self._rows) >= _FIRST_SAMPLES else []
        assert self.lookahead is not None
        return self._advance(row["t"] - self.lookahead)

    def finish(self) -> list[dict[str, Any]]:
        """The rows still held back by the look-ahead: the drive has ended."""
        if not self._rows:
            return []
        return self._advance(math.inf)

    def _window(self) -> Drive:
        df = pd.DataFrame(self._rows, columns=self._columns)
        if self._meta is None:
            first = Drive.from_frame(df, self.vehicle, source="online", extra=self.extra)
            rate = self.sample_rate if self.sample_rate is not None else first.meta.sample_rate
            self._meta = DriveMeta(self.vehicle, "online", float(rate), None, dict(self.extra))
        return Drive(df.reset_index(drop=True), self._meta)

    def _advance(self, until: float | None) -> list[dict[str, Any]]:
        """Step the prepared samples after the last stepped one up to ``until`` [s]
        (None: the newest sample's time less the look-ahead)."""
        window = self._window()
        prepared = self.estimator.prepare(window, self.config)
        if self._state is None:  # the first samples: what prepare knows before the first
            info: DriveInfo = prepared.info
            self.lookahead = float(self.estimator.lookahead(self.config, info))
            rate = window.meta.sample_rate
            self._keep = 2.0 * self.lookahead + (CONTEXT_SAMPLES / rate if rate > 0 else 0.0)
            self._state = self.estimator.init(info, self.config, self.seed)
        assert self.lookahead is not None
        if until is None:
            until = float(window.t[-1]) - self.lookahead
        out: list[dict[str, Any]] = []
        for s in prepared.samples:
            if s.t <= self._done or s.t > until:
                continue
            self._state, r = self.estimator.step(self._state, s)
            if r is not None:
                out.append(dict(r))
            self._done = float(s.t)
        cut = self._done - self._keep
        while len(self._rows) > 2 and self._rows[1]["t"] < cut:
            self._rows.pop(0)
        return out

    def table(self, rows: list[dict[str, Any]]) -> pd.DataFrame:
        """Rows of :meth:`push` / :meth:`finish` as the estimates table (contract columns first)."""
        return conform(pd.DataFrame(rows))

