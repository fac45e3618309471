"""A drive played onto a CAN bus (or into a CAN log), DBC-encoded; buses and logs as sources.

:func:`replay_drive` encodes every sample of a drive as the frames of the signal map's
messages (:meth:`~roadgrip.io.can.FrameEncoder.encode_sample`, the clock message first)
and sends them at the drive's pace divided by ``speed`` (``speed=inf``: as fast as the
bus takes them). :func:`open_bus` opens any python-can interface (socketcan, vector,
pcan, kvaser, virtual, udp_multicast, ...); :class:`LogSource` reads a CAN log
(``.blf``, ``.asc``, ``.trc``) with the bus's ``recv``. :func:`replay_live` plays a drive
onto a fresh in-process ``virtual`` bus from a thread and runs the live loop on it (the
tests and the latency benchmark).
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from roadgrip.drive import Drive
from roadgrip.io.can import CAN_LOG_SUFFIXES, FrameEncoder

__all__ = ["LiveReplay", "LogSource", "open_bus", "quantised", "replay_drive", "replay_live", "shipped_codec"]


def open_bus(interface: str, channel: str | int | None = None, **kwargs: Any) -> Any:
    """A python-can bus; ``ValueError`` naming the interface when it cannot be opened.

    ``virtual`` buses keep the senders' timestamps (``preserve_timestamps``).
    """
    import can

    if interface == "virtual":
        kwargs.setdefault("preserve_timestamps", True)
    try:
        return can.Bus(interface=interface, channel=channel, **kwargs)
    except (can.CanError, OSError, ImportError, ValueError, NotImplementedError) as exc:
        raise ValueError(f"cannot open CAN interface {interface!r} channel {channel!r}: {exc}") from None


class LogSource:
    """A CAN log read frame by frame with ``recv(timeout)``, like a bus.

    Parameters
    ----------
    path : str or Path
        ``.blf``, ``.asc`` or ``.trc``.
    speed : float
        Log seconds per wall second: a frame is handed out when its time has come (``inf``:
        at once, the default).

    Attributes
    ----------
    at_end : bool
        Every frame has been read.
    """

    def __init__(self, path: str | Path, speed: float = float("inf")):
        import can

        p = Path(path)
        if not p.is_file():
            raise ValueError(f"no such file: {p}")
        if p.suffix.lower() not in CAN_LOG_SUFFIXES:
            raise ValueError(f"{p.name}: a CAN log is {', '.join(CAN_LOG_SUFFIXES)}")
        if not speed > 0:
            raise ValueError(f"speed must be positive, got {speed}")
        self._reader: Iterator[Any] = iter(can.LogReader(str(p)))
        self.speed = float(speed)
        self._next: Any = None
        self._start: tuple[float, float] | None = None  # (wall time, log time) of the first frame
        self.at_end = False

    def recv(self, timeout: float | None = None) -> Any:
        if self.at_end:
            return None
        if self._next is None:
            try:
                self._next = next(self._reader)
            except StopIteration:
                self.at_end = True
                return None
        if math.isfinite(self.speed):
            now = time.monotonic()
            if self._start is None:
                self._start = (now, float(self._next.timestamp))
            due = self._start[0] + (float(self._next.timestamp) - self._start[1]) / self.speed
            if due > now:
                wait = due - now
                if timeout is not None and wait > timeout:
                    time.sleep(timeout)
                    return None
                time.sleep(wait)
        msg, self._next = self._next, None
        return msg

    def shutdown(self) -> None:
        self.at_end = True


def _rows(drive: Drive, columns: list[str]) -> Iterator[dict[str, float]]:
    data = {c: drive.col(c) for c in columns}
    for i in range(drive.n):
        yield {c: float(v[i]) for c, v in data.items()}


def replay_drive(drive: Drive, send: Callable[[Any], None], encoder: FrameEncoder, *, speed: float = 1.0,
                 t0_wall: float | None = None, stop: Callable[[], bool] | None = None,
                 drop: Callable[[float, int], bool] | None = None) -> int:
    """Play a drive as DBC frames.

    Parameters
    ----------
    drive : Drive
        Every column of the signal map must be in it (``t`` always is).
    send : callable
        Takes a ``can.Message``: a bus's ``send`` or a ``can.Logger``.
    encoder : FrameEncoder
    speed : float
        Drive seconds per wall second (``inf``: no waiting). Frame timestamps are the
        drive's times (on a bus that keeps them) shifted by ``t0_wall``.
    t0_wall : float, optional
        Timestamp of the drive's first sample (default: now when ``speed`` is finite, 0
        otherwise).
    stop : callable, optional
        Polled per sample; True ends the replay.
    drop : callable, optional
        ``drop(t, frame_id)`` True leaves that frame out (fault tests: a silent signal).

    Returns
    -------
    int
        Frames sent.

    Raises
    ------
    ValueError
        A mapped column missing from the drive, or a speed that is not positive.
    """
    import can

    if not speed > 0:
        raise ValueError(f"speed must be positive, got {speed}")
    columns = [c for c in encoder.decoder.columns]
    missing = [c for c in columns if not drive.has(c)]
    if missing:
        raise ValueError(f"the drive lacks {', '.join(missing)}, which the signal map sends")
    realtime = math.isfinite(speed)
    start = time.time()
    base = t0_wall if t0_wall is not None else (start if realtime else 0.0)
    t_first = float(drive.t[0])
    sent = 0
    for row in _rows(drive, columns):
        if stop is not None and stop():
            break
        rel = row["t"] - t_first
        if realtime:
            wait = start + rel / speed - time.time()
            if wait > 0:
                time.sleep(wait)
        stamp = base + rel
        for fid, data in encoder.encode_sample(row):
            if drop is not None and drop(row["t"], fid):
                continue
            send(can.Message(timestamp=stamp, arbitration_id=fid, data=data, is_extended_id=fid > 0x7FF))
            sent += 1
    return sent


def quantised(drive: Drive, encoder: FrameEncoder) -> Drive:
    """The drive as the DBC carries it: every mapped column encoded and decoded again
    (the resolution and range of its signals), the other columns left out."""
    import pandas as pd

    columns = encoder.decoder.columns
    out: dict[str, list[float]] = {c: [] for c in columns}
    dec = type(encoder.decoder)(encoder.db, encoder.decoder.map)
    for row in _rows(drive, columns):
        values: dict[str, float] = {}
        for fid, data in encoder.encode_sample(row):
            got = dec.decode(fid, data)
            if got is None:
                raise ValueError(f"a frame of the drive at t = {row['t']} s does not decode: {dec.report()}")
            values.update(got)
        for c in columns:
            out[c].append(values[c])
    df = pd.DataFrame({c: np.asarray(v) for c, v in out.items()})
    return Drive.from_frame(df, drive.vehicle, source=f"{drive.meta.source} (quantised)")


def shipped_codec() -> tuple[Any, dict[str, Any]]:
    """The shipped DBC and its signal map (:data:`~roadgrip.io.can.SHIPPED_DBC`,
    :data:`~roadgrip.io.can.SHIPPED_MAP`), loaded."""
    from roadgrip.io.can import SHIPPED_DBC, SHIPPED_MAP, load_dbc, load_signal_map

    return load_dbc(SHIPPED_DBC), load_signal_map(SHIPPED_MAP)


class LiveReplay(NamedTuple):
    """What :func:`replay_live` gives back.

    Attributes
    ----------
    estimator : LiveEstimator
        The estimator after the last row (its tables kept with ``keep_tables``).
    rows : list of LiveRow
        The rows written, in order.
    stats : LiveStats
        The loop's counts, latencies and why it ended.
    backlog : int
        Rows written later than one sample interval after the last frame was sent: 0 when
        the loop kept up with the replay.
    wall_s : float
        Wall time from the start of the replay to the end of the loop [s].
    """

    estimator: Any
    rows: list[Any]
    stats: Any
    backlog: int
    wall_s: float


_channels = itertools.count()


def replay_live(drive: Drive, method: str, *, codec: tuple[Any, dict[str, Any]] | None = None,
                options: dict[str, Any] | None = None, speed: float = float("inf"), warmup: float | None = None,
                seed: int = 0, send_wrapper: Callable[[Callable[[Any], None]], Callable[[Any], None]] | None = None,
                drop: Callable[[float, int], bool] | None = None, keep_tables: bool = False,
                max_rows: int | None = None, idle: float = 1.0, poll: float = 0.05) -> LiveReplay:
    """Replay ``drive`` onto a fresh ``virtual`` bus from a thread and run the live loop on it.

    The sender shares the process (and the GIL) with the loop, as a bus driver's thread
    would. The loop decodes, assembles, estimates (:class:`~roadgrip.live.runner.LiveEstimator`)
    and writes each row to a list.

    Parameters
    ----------
    drive : Drive
        With every column of the signal map.
    method : str
        A live method (:data:`~roadgrip.live.runner.LIVE_METHODS`).
    codec : (Database, dict), optional
        DBC and signal map; default :func:`shipped_codec`.
    options : dict, optional
        Estimator options.
    speed : float
        Drive seconds per wall second (``inf``: as fast as the bus takes the frames).
    warmup : float, optional
        The estimator's warm-up [s] (default :data:`~roadgrip.live.runner.WARMUP_S`).
    seed : int
    send_wrapper : callable, optional
        Wraps the bus's ``send`` (fault injection).
    drop : callable, optional
        ``drop(t, frame_id)``: frames left out (:func:`replay_drive`).
    keep_tables : bool
        Keep the estimator's rows and inputs (:class:`~roadgrip.live.runner.LiveEstimator`).
    max_rows : int, optional
        End the loop after this many rows (default: when the bus has been idle ``idle`` s).
    idle, poll : float
        The loop's idle end and longest wait for a frame [s] (:func:`~roadgrip.live.loop.run_live`).

    Returns
    -------
    LiveReplay
    """
    from roadgrip.io.can import FrameDecoder
    from roadgrip.live.assembler import RowAssembler
    from roadgrip.live.loop import run_live
    from roadgrip.live.runner import WARMUP_S, LiveEstimator
    from roadgrip.live.sinks import ListSink

    db, m = codec if codec is not None else shipped_codec()
    name = f"roadgrip-replay-{next(_channels)}"
    rx, tx = open_bus("virtual", name), open_bus("virtual", name)
    decoder = FrameDecoder(db, m)
    est = LiveEstimator(method, drive.vehicle, decoder.columns, options, warmup=WARMUP_S if warmup is None else warmup,
                        seed=seed, keep_tables=keep_tables)
    sink = ListSink()
    send = tx.send if send_wrapper is None else send_wrapper(tx.send)
    written_at_end = [0]
    grace = 1.0 / drive.meta.sample_rate if drive.meta.sample_rate > 0 else 0.01

    def sender() -> None:
        replay_drive(drive, send, FrameEncoder(db, m), speed=speed, drop=drop)
        time.sleep(grace)
        written_at_end[0] = len(sink.rows)

    th = threading.Thread(target=sender, daemon=True)
    t0 = time.perf_counter()
    th.start()
    try:
        stats = run_live(rx, RowAssembler(decoder), est, [sink], poll=poll, idle=idle, max_rows=max_rows)
        wall = time.perf_counter() - t0
    finally:
        th.join()
        rx.shutdown()
        tx.shutdown()
    return LiveReplay(est, sink.rows, stats, len(sink.rows) - written_at_end[0], wall)
