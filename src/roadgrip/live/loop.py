"""The live loop: frames from a source, rows through the estimator, rows out to the sinks.

Each turn takes one frame (waiting up to ``poll`` seconds), then every frame already
waiting (up to ``max_batch``), so that a loop behind the bus catches up by giving the
estimator several rows at once instead of building a backlog. The latency of a row is
from the receipt of the frame that completed it to its write by the last sink.

A source that raises (a bus that went away: ``can.CanError`` or ``OSError``) ends the
loop with the reason in :attr:`LiveStats.ended`, or, with ``reconnect``, is opened
again (every second, up to ``reconnect`` attempts). A source silent for ``idle``
seconds after its first frame ends the loop (``ended = 'idle ...'``); a log source ends at its end; rows the
estimator refuses (``ValueError``) end it with the estimator's message.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from roadgrip.live.assembler import RowAssembler
from roadgrip.live.runner import LiveEstimator

__all__ = ["LiveStats", "run_live"]


@dataclass
class LiveStats:
    """What a live run did.

    Attributes
    ----------
    frames : int
        Frames received.
    rows : int
        Rows written.
    latency_s : list of float
        Per row after the warm-up: frame receipt to row written [s].
    frames_report : dict
        :meth:`~roadgrip.io.can.FrameDecoder.report` (accepted, dropped per reason).
    dropped_rows : int
        Rows dropped by the assembler (time not after the previous row's).
    withheld : int
        Rows written with the claims withheld for stale signals.
    reconnects : int
    ended : str
        Why the loop ended.
    """

    frames: int = 0
    rows: int = 0
    latency_s: list[float] = field(default_factory=list)
    frames_report: dict[str, int] = field(default_factory=dict)
    dropped_rows: int = 0
    withheld: int = 0
    reconnects: int = 0
    ended: str = ""

    def latency_summary(self) -> dict[str, float]:
        """``p50``, ``p99`` and ``max`` of the latency [ms] (NaN without rows)."""
        if not self.latency_s:
            return {"p50": float("nan"), "p99": float("nan"), "max": float("nan")}
        a = np.asarray(self.latency_s) * 1e3
        return {"p50": float(np.percentile(a, 50)), "p99": float(np.percentile(a, 99)), "max": float(a.max())}


def run_live(source: Any, assembler: RowAssembler, estimator: LiveEstimator, sinks: list[Any], *,
             poll: float = 0.1, idle: float | None = 5.0, max_batch: int = 256, max_rows: int | None = None,
             reconnect: int = 0, open_source: Callable[[], Any] | None = None,
             should_stop: Callable[[], bool] | None = None) -> LiveStats:
    """Run the live loop until the source ends, goes away, idles or ``max_rows`` are written.

    Parameters
    ----------
    source : object with ``recv(timeout)``
        A python-can bus, or a log (:class:`~roadgrip.live.replay.LogSource`); ``recv``
        returns a ``can.Message`` or None after ``timeout`` seconds.
    assembler : RowAssembler
    estimator : LiveEstimator
    sinks : list
        Objects with ``write(rows)``.
    poll : float
        Longest wait for one frame [s].
    idle : float or None
        End after this long without a frame [s], counted from the first frame (None: never).
    max_batch : int
        Frames taken per turn at most.
    max_rows : int, optional
        End after this many rows.
    reconnect : int
        Attempts to open the source again after it failed (needs ``open_source``).
    open_source : callable, optional
        Opens the source again.
    should_stop : callable, optional
        Polled each turn; True ends the loop (``ended = 'stopped'``).

    Returns
    -------
    LiveStats
    """
    import can

    stats = LiveStats()
    last_frame: float | None = None  # the idle time counts from the first frame
    ended = ""
    clock = time.perf_counter
    while not ended:
        if should_stop is not None and should_stop():
            ended = "stopped"
            break
        try:
            msg = source.recv(poll)
        except (can.CanError, OSError) as exc:
            if stats.reconnects < reconnect and open_source is not None:
                stats.reconnects += 1
                time.sleep(1.0)
                try:
                    source = open_source()
                except (can.CanError, OSError):
                    pass
                continue
            ended = f"source failed: {exc}"
            break
        if msg is None:
            if getattr(source, "at_end", False):
                ended = "end of log"
            elif idle is not None and last_frame is not None and time.monotonic() - last_frame > idle:
                ended = f"idle {idle:g} s"
            continue
        last_frame = time.monotonic()
        pending: list[tuple[Any, float]] = []
        taken = 0
        while msg is not None:
            stats.frames += 1
            taken += 1
            if not (msg.is_error_frame or msg.is_remote_frame):
                for row in assembler.push(msg.arbitration_id, msg.data, msg.timestamp):
                    pending.append((row, clock()))
            if taken >= max_batch:
                break
            try:
                msg = source.recv(0.0)
            except (can.CanError, OSError):
                msg = None
        if not pending:
            continue
        warm = estimator.started
        try:
            out = estimator.feed([r for r, _ in pending])
        except ValueError as exc:  # an input the estimator refuses: end with its words, not a traceback
            ended = f"estimator stopped at t = {pending[0][0].t:.3f} s: {exc}"
            break
        for s in sinks:
            s.write(out)
        done = clock()
        if warm:
            stats.latency_s.extend(done - t_in for _, t_in in pending)
        stats.rows += len(out)
        stats.withheld += sum(r.reason == "signal_timeout" for r in out)
        if max_rows is not None and stats.rows >= max_rows:
            ended = f"{max_rows} rows"
    stats.ended = ended
    stats.frames_report = assembler.decoder.report()
    stats.dropped_rows = assembler.dropped_rows
    return stats
