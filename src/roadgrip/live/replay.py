"""A drive played onto a CAN bus (or into a CAN log), DBC-encoded; buses and logs as sources.

:func:`replay_drive` encodes every sample of a drive as the frames of the signal map's
messages (:meth:`~roadgrip.io.can.FrameEncoder.encode_sample`, the clock message first)
and sends them at the drive's pace divided by ``speed`` (``speed=inf``: as fast as the
bus takes them). :func:`open_bus` opens any python-can interface (socketcan, vector,
pcan, kvaser, virtual, udp_multicast, ...); :class:`LogSource` reads a CAN log
(``.blf``, ``.asc``, ``.trc``) with the bus's ``recv``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from roadgrip.drive import Drive
from roadgrip.io.can import CAN_LOG_SUFFIXES, FrameEncoder

__all__ = ["LogSource", "open_bus", "quantised", "replay_drive"]


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
