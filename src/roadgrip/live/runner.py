"""An estimator fed row by row: the package's one stepping path with the live contract.

:class:`LiveEstimator` gives every fresh row to an
:class:`~roadgrip.estimators.online.OnlineEstimator`, which holds the first ``warmup``
seconds of rows, derives from them what the method's ``prepare`` derives from a drive,
steps them, and from then on prepares and steps each row as it comes (one protocol
``step`` and about 0.1 ms, no DataFrame): the rows of the causal batch run
``run_chunks([first warmup seconds, the rest])`` (``tests/live/test_live_equals_batch.py``,
to the float round-off the methods' streaming documents). During the warm-up nothing is
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
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from roadgrip.estimators import get
from roadgrip.estimators.array_frame import ArrayFrame
from roadgrip.estimators.online import OnlineEstimator
from roadgrip.estimators.protocol import rows_to_table
from roadgrip.io.vss import VSS_COLUMNS, VSS_PREFIX, vss_records
from roadgrip.live.assembler import Row
from roadgrip.vehicle.params import VehicleParams

__all__ = ["LIVE_METHODS", "REASONS", "WARMUP_S", "LiveEstimator", "LiveRow"]

LIVE_METHODS = ("cascade", "brls", "slipmap", "gpssm")
"""Methods run live (every method of the registry steps; these four are tested live)."""

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


class LiveEstimator:
    """One method run on rows as they arrive (module docstring).

    Parameters
    ----------
    method : str
        One of :data:`LIVE_METHODS`.
    vehicle : VehicleParams
    columns : list of str
        The canonical columns the rows carry (``t`` first).
    options : dict, optional
        Estimator options (:meth:`EstimatorConfig.from_options`).
    warmup : float
        Seconds of rows before the first estimate [s] (what ``prepare`` derives from a
        drive comes from them).
    seed : int
    keep_tables : bool
        Keep the estimator's rows and the samples it was given (tests).

    Attributes
    ----------
    online : OnlineEstimator
        The stepping estimator (its ``state`` is the method's step state).
    tables, inputs : list of DataFrame
        The estimator's own rows and the samples it was given (one table each), when
        ``keep_tables``.
    """

    def __init__(self, method: str, vehicle: VehicleParams, columns: list[str], options: dict[str, Any] | None = None,
                 warmup: float = WARMUP_S, seed: int = 0, keep_tables: bool = False):
        if method not in LIVE_METHODS:
            raise ValueError(f"live runs {', '.join(LIVE_METHODS)}, not {method!r}")
        if not warmup > 0:
            raise ValueError(f"warmup must be positive, got {warmup}")
        est = get(method)
        self.method = method
        self.config = est.Config.from_options(options or {})
        self.prior = tuple(float(v) for v in est.prior_band(self.config))
        self.vehicle = vehicle
        self.columns = [c for c in columns if c != "t"]
        self.warmup = float(warmup)
        self.online = OnlineEstimator(method, vehicle, self.config, seed=seed, warmup=self.warmup)
        self._informed = False
        self._out_columns: list[str] | None = None
        self.keep_tables = keep_tables
        self._kept_rows: list[dict[str, Any]] = []
        self._kept_inputs: list[dict[str, float]] = []

    @property
    def started(self) -> bool:
        """The warm-up is over."""
        return self.online.started

    @property
    def state(self) -> Any:
        """The method's step state after the last row (None during the warm-up)."""
        return self.online.state

    @property
    def tables(self) -> list[pd.DataFrame]:
        """The estimator's rows so far as one table (``keep_tables``)."""
        return [rows_to_table(self._kept_rows)] if self._kept_rows else []

    @property
    def inputs(self) -> list[pd.DataFrame]:
        """The samples given to the estimator so far as one table (``keep_tables``)."""
        return [pd.DataFrame(self._kept_inputs, columns=["t", *self.columns])] if self._kept_inputs else []

    def feed(self, rows: list[Row]) -> list[LiveRow]:
        """The output rows of ``rows`` (one each, in order)."""
        out: list[LiveRow | None] = []
        stepped: list[dict[str, Any]] = []
        at: list[int] = []  # where each estimator row goes in ``out``
        for r in rows:
            if r.stale:
                gap = "never received" if not math.isfinite(r.silent_s) else f"silent {r.silent_s:.2f} s"
                out.append(_withheld(r.t, "signal_timeout", f"{', '.join(r.stale)} {gap}"))
                continue
            sample = {"t": r.t, **{c: r.values[c] for c in self.columns}}
            warm = self.started
            got = self.online.push(sample)
            if self.keep_tables:
                self._kept_inputs.append(sample)
                self._kept_rows.extend(got)
            if not warm:  # the warm-up's rows (all of them once it ends) claim nothing
                out.append(_withheld(r.t, "warming_up"))
                if got:
                    self._answered(got)
                continue
            at.extend(range(len(out), len(out) + len(got)))
            out.extend([None] * len(got))
            stepped.extend(got)
        if stepped:
            for i, live in zip(at, self._answered(stepped), strict=True):
                out[i] = live
        assert all(o is not None for o in out)
        return out  # type: ignore[return-value]

    def _answered(self, rows: list[dict[str, Any]]) -> list[LiveRow]:
        """The estimator's rows as live rows (VSS values, class, axles)."""
        if self._out_columns is None:  # only what the VSS rules read
            self._out_columns = [c for c in VSS_COLUMNS if c in rows[0] and c != "excited"]
        columns: dict[str, Any] = {c: [r[c] for r in rows] for c in self._out_columns}
        excited = np.array([bool(r.get("excited", False)) for r in rows], bool)
        if self._informed and len(rows):
            excited[0] = True  # informed by earlier rows
        if excited.any():
            self._informed = True
        columns["excited"] = excited
        records = vss_records(ArrayFrame(columns), self.method, self.prior)  # type: ignore[arg-type]
        nan = float("nan")
        out = []
        for row, rec in zip(rows, records, strict=True):
            mp = rec.get(VSS_PREFIX + "MostProbable", nan)
            lo = rec.get(VSS_PREFIX + "LowerBound", nan)
            up = rec.get(VSS_PREFIX + "UpperBound", nan)
            claims = any(math.isfinite(v) for v in (mp, lo, up))
            out.append(LiveRow(rec["t"], mp, lo, up, str(row.get("grip_class", "unknown")),
                               float(row.get("mu_front", nan)), float(row.get("mu_rear", nan)),
                               "ok" if claims else "no_claim", ""))
        return out

    def curve(self, alpha: np.ndarray) -> Any:
        """The learned friction curves with their 95 % band at slip angles ``alpha`` [rad]
        (:class:`~roadgrip.estimators.gpssm.posterior.CurvePosterior`), for the GP-SSM
        after its warm-up; None otherwise (the other methods learn no curve)."""
        fs = self.state
        if self.method != "gpssm" or fs is None or fs.state is None:
            return None
        from roadgrip.blas_threads import one_blas_thread
        from roadgrip.estimators.gpssm.posterior import posterior_curves

        with one_blas_thread():
            return posterior_curves(fs.ctx, fs.state, np.asarray(alpha, float))
