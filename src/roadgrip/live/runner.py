"""An estimator fed row by row, through the methods' streaming API.

:class:`LiveEstimator` holds the first ``warmup`` seconds of rows, gives them to the
method's ``run_chunks`` as the first chunk (what ``prepare`` derives from a drive, it
derives from them), and from then on gives every batch of new rows as the next chunk:
the rows of the causal batch run ``run_chunks([first warmup seconds, the rest])``, to
the float round-off the methods' streaming documents. During the warm-up nothing is
claimed (reason ``'warming_up'``).

A row whose signals are stale (:class:`~roadgrip.live.assembler.Row`) is not given to
the estimator: its output row claims nothing (class ``'unknown'``, no VSS values) and
says why (``reason = 'signal_timeout'``, ``detail`` naming the columns and the
silence). When the signals return the estimator goes on from its state.

Each output row is a :class:`LiveRow`: the road friction in the VSS form
(:func:`roadgrip.io.vss.vss_records`, percent, a value absent where it is not known),
the grip class, per-axle estimates and the reason a claim is withheld.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators import get
from roadgrip.io.vss import VSS_PREFIX, vss_records
from roadgrip.live.assembler import Row
from roadgrip.vehicle.params import VehicleParams

__all__ = ["LIVE_METHODS", "REASONS", "WARMUP_S", "LiveEstimator", "LiveRow"]

LIVE_METHODS = ("cascade", "brls", "slipmap", "gpssm")
"""Methods with a streaming ``run_chunks`` (continue from a state over a block of samples)."""

REASONS = ("ok", "warming_up", "signal_timeout", "no_claim")
"""Why a row claims what it claims (the DBC's ``Reason`` values, in this order)."""

WARMUP_S = 1.0
"""Default warm-up [s]: the first chunk the method derives its drive constants from."""


class LiveRow(NamedTuple):
    """One output row.

    Attributes
    ----------
    t : float
        Sample time [s].
    most_probable, lower, upper : float
        Road friction [%] (VSS ``RoadFriction``); NaN where not claimed.
    grip_class : str
        ``'high'``, ``'low'`` or ``'unknown'``.
    mu_front, mu_rear : float
        Per-axle estimates [-] (NaN for the classifiers and when withheld).
    reason : str
        One of :data:`REASONS`.
    detail : str
        Words for the reason (the stale columns and their silence).
    """

    t: float
    most_probable: float
    lower: float
    upper: float
    grip_class: str
    mu_front: float
    mu_rear: float
    reason: str
    detail: str

    def vss(self) -> dict[str, Any]:
        """The row as a VSS JSON-lines record (absent keys where nothing is claimed),
        with ``roadgrip.class`` and ``roadgrip.reason``."""
        rec: dict[str, Any] = {"t": self.t}
        for key, v in (("MostProbable", self.most_probable), ("LowerBound", self.lower),
                       ("UpperBound", self.upper)):
            if math.isfinite(v):
                rec[VSS_PREFIX + key] = round(v, 3)
        rec["roadgrip.class"] = self.grip_class
        rec["roadgrip.reason"] = self.reason
        if self.detail:
            rec["roadgrip.detail"] = self.detail
        return rec


def _withheld(t: float, reason: str, detail: str = "") -> LiveRow:
    nan = float("nan")
    return LiveRow(t, nan, nan, nan, "unknown", nan, nan, reason, detail)


class _Feed:
    """An iterator the streaming generator pulls its next chunk from."""

    def __init__(self) -> None:
        self.chunk: Drive | None = None

    def __iter__(self) -> Iterator[Drive]:
        return self

    def __next__(self) -> Drive:
        if self.chunk is None:
            raise StopIteration
        chunk, self.chunk = self.chunk, None
        return chunk


class LiveEstimator:
    """One method run on rows as they arrive (module docstring).

    Parameters
    ----------
    method : str
        One of the streaming methods (cascade, brls, slipmap, gpssm).
    vehicle : VehicleParams
    columns : list of str
        The canonical columns the rows carry (``t`` first).
    options : dict, optional
        Estimator options (:meth:`EstimatorConfig.from_options`).
    warmup : float
        Seconds of rows in the first chunk [s].
    seed : int

    Attributes
    ----------
    tables, inputs : list of DataFrame
        The estimator's own tables and the samples it was given, per chunk, when
        ``keep_tables`` (tests).
    """

    def __init__(self, method: str, vehicle: VehicleParams, columns: list[str], options: dict[str, Any] | None = None,
                 warmup: float = WARMUP_S, seed: int = 0, keep_tables: bool = False):
        if method not in LIVE_METHODS:
            raise ValueError(f"live runs {', '.join(LIVE_METHODS)}, not {method!r}")
        if not warmup > 0:
            raise ValueError(f"warmup must be positive, got {warmup}")
        if method == "cascade":
            from roadgrip.estimators.cascade.stream import run_chunks
        elif method == "gpssm":
            from roadgrip.estimators.gpssm.stream import run_chunks
        else:
            from roadgrip.estimators.classify.stream import run_chunks
        est = get(method)
        self.method = method
        self.config = est.Config.from_options(options or {})
        self.prior = tuple(float(v) for v in est.prior_band(self.config))
        self.vehicle = vehicle
        self.columns = [c for c in columns if c != "t"]
        self.warmup = float(warmup)
        self._feed = _Feed()
        self._gen = run_chunks(self._feed, self.config, seed)
        self._held: list[Row] = []
        self._meta: Any = None
        self._informed = False
        self.state: Any = None
        self.keep_tables = keep_tables
        self.tables: list[pd.DataFrame] = []
        self.inputs: list[pd.DataFrame] = []

    @property
    def started(self) -> bool:
        """The warm-up is over."""
        return self._meta is not None

    def _drive(self, rows: list[Row]) -> Drive:
        data = {"t": np.fromiter((r.t for r in rows), float, len(rows))}
        for c in self.columns:
            data[c] = np.fromiter((r.values[c] for r in rows), float, len(rows))
        df = pd.DataFrame(data)
        if self._meta is None:
            d = Drive.from_frame(df, self.vehicle, source="live")
            self._meta = d.meta
            return d
        # the decoder checked every value against the DBC's range; the times increase
        return Drive(df, self._meta)

    def _run(self, rows: list[Row]) -> list[LiveRow]:
        self._feed.chunk = self._drive(rows)
        self._feed_data = self._feed.chunk.data
        res = next(self._gen)
        self.state = res.state
        table = res.table
        if self.keep_tables:
            self.tables.append(table)
            self.inputs.append(self._feed_data)
        if self._informed and len(table):
            table = table.copy()
            table.loc[table.index[0], "excited"] = True  # informed by earlier chunks
        if len(table) and "excited" in table.columns and bool(table["excited"].to_numpy(bool).any()):
            self._informed = True
        records = vss_records(table, self.method, self.prior)
        cls = table["grip_class"].astype(str).to_numpy()
        mf, mr = table["mu_front"].to_numpy(float), table["mu_rear"].to_numpy(float)
        nan = float("nan")
        out = []
        for i, rec in enumerate(records):
            mp = rec.get(VSS_PREFIX + "MostProbable", nan)
            lo = rec.get(VSS_PREFIX + "LowerBound", nan)
            up = rec.get(VSS_PREFIX + "UpperBound", nan)
            claims = any(math.isfinite(v) for v in (mp, lo, up))
            out.append(LiveRow(rec["t"], mp, lo, up, str(cls[i]), float(mf[i]), float(mr[i]),
                               "ok" if claims else "no_claim", ""))
        return out

    def feed(self, rows: list[Row]) -> list[LiveRow]:
        """The output rows of ``rows`` (one each, in order)."""
        out: list[LiveRow] = []
        batch: list[Row] = []
        for r in rows:
            if r.stale:
                if batch:
                    out.extend(self._step(batch))
                    batch = []
                gap = "never received" if not math.isfinite(r.silent_s) else f"silent {r.silent_s:.2f} s"
                out.append(_withheld(r.t, "signal_timeout", f"{', '.join(r.stale)} {gap}"))
            else:
                batch.append(r)
        if batch:
            out.extend(self._step(batch))
        return out

    def _step(self, rows: list[Row]) -> list[LiveRow]:
        if self.started:
            return self._run(rows)
        out = []
        for i, r in enumerate(rows):
            self._held.append(r)
            out.append(_withheld(r.t, "warming_up"))
            if len(self._held) >= 2 and self._held[-1].t - self._held[0].t + 1e-9 >= self.warmup:
                first, self._held = self._held, []
                self._run(first)  # the first chunk: its rows were answered 'warming_up'
                if i + 1 < len(rows):
                    out.extend(self._run(rows[i + 1:]))
                break
        return out

    def curve(self, alpha: np.ndarray) -> Any:
        """The learned friction curves with their 95 % band at slip angles ``alpha`` [rad]
        (:class:`~roadgrip.estimators.gpssm.posterior.CurvePosterior`), for the GP-SSM
        after its warm-up; None otherwise (the other methods learn no curve)."""
        if self.method != "gpssm" or self.state is None or self.state.filter is None:
            return None
        from roadgrip.blas_threads import one_blas_thread
        from roadgrip.estimators.gpssm.posterior import posterior_curves

        with one_blas_thread():
            return posterior_curves(self.state.ctx, self.state.filter, np.asarray(alpha, float))
