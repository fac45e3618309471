"""Decoded frames into rows of canonical signals, one row per cycle of the mapped messages.

A *cycle* is one frame of every mapped message. A row is complete when the cycle holds
every message; a message that comes again before the cycle is complete (the next cycle
has begun) closes it incomplete, and so does the clock message (with a ``t`` signal),
which opens every cycle: a lost clock frame costs its row (dropped, counted) and never
shifts the rows after it. In an incomplete row a message lost once keeps its
last value (sample and hold) while it is silent for less than its ``timeout``; past
that its columns are *stale* and the row says which (:attr:`Row.stale`), so that the
estimator is not fed invented values.

Time is the sample clock when the map has a ``t`` signal (the rows of a replayed drive
keep the drive's times exactly), else the receive time of the cycle's first frame.
Silences are measured on that clock. A row that would not follow the previous one in
time (its clock message was lost) is dropped and counted.
"""

from __future__ import annotations

from typing import NamedTuple

from roadgrip.io.can import FrameDecoder

__all__ = ["Row", "RowAssembler"]


class Row(NamedTuple):
    """One sample of canonical signals.

    Attributes
    ----------
    t : float
        Sample time [s].
    values : dict of str to float
        Canonical column -> value [SI] (held values included; ``t`` among them).
    stale : tuple of str
        Columns silent past their timeout (empty when the row can be estimated).
    silent_s : float
        The longest silence among the stale columns [s] (0 when none).
    """

    t: float
    values: dict[str, float]
    stale: tuple[str, ...]
    silent_s: float


class RowAssembler:
    """Rows from frames (module docstring).

    Parameters
    ----------
    decoder : FrameDecoder

    Attributes
    ----------
    dropped_rows : int
        Rows dropped because their time did not follow the previous row's.
    """

    def __init__(self, decoder: FrameDecoder):
        self.decoder = decoder
        self.required = frozenset(decoder.messages)
        self.clock_id = next((fid for fid, mm in decoder.messages.items()
                              if any(t == "t" for t, *_ in mm.targets)), None)
        self._timeout = {fid: min(to for *_, to in mm.targets) for fid, mm in decoder.messages.items()}
        self._columns = {fid: tuple(t for t, *_ in mm.targets if t != "t") for fid, mm in decoder.messages.items()}
        self._values: dict[str, float] = {}
        self._last_rx: dict[int, float] = {}
        self._seen: set[int] = set()
        self._cycle_t: float | None = None
        self._last_row_t = float("-inf")
        self.dropped_rows = 0

    def push(self, frame_id: int, data: bytes | bytearray, timestamp: float) -> list[Row]:
        """Decode one frame; the rows it completes (none, one, or two when it closes an
        incomplete cycle and completes its own)."""
        values = self.decoder.decode(frame_id, data)
        if values is None:
            return []
        rows = []
        # a message seen again, or the clock message (which opens every cycle), closes the cycle
        if frame_id in self._seen or (frame_id == self.clock_id and self._seen):
            row = self._close()
            if row is not None:
                rows.append(row)
        if not self._seen:
            self._cycle_t = float(timestamp)
        now = values["t"] if "t" in values else (self._cycle_t if self.clock_id is None else None)
        if now is not None:
            self._cycle_t = float(now)
        self._values.update(values)
        self._seen.add(frame_id)
        self._last_rx[frame_id] = self._cycle_t if self._cycle_t is not None else float(timestamp)
        if self._seen >= self.required:
            row = self._close()
            if row is not None:
                rows.append(row)
        return rows

    def silence(self, now: float) -> dict[int, float]:
        """Frame id -> seconds since its last accepted frame, for the messages silent past
        their timeout at time ``now`` (the sample clock)."""
        out = {}
        for fid in self.required:
            last = self._last_rx.get(fid)
            gap = float("inf") if last is None else now - last
            if gap > self._timeout[fid]:
                out[fid] = gap
        return out

    def _close(self) -> Row | None:
        seen, self._seen = self._seen, set()
        t = self._cycle_t
        if t is None or (self.clock_id is not None and self.clock_id not in seen) or not t > self._last_row_t:
            self.dropped_rows += 1
            return None
        self._last_row_t = t
        silent = self.silence(t)
        for fid in silent:
            self.decoder.resync(fid)
        stale = tuple(c for fid in sorted(silent) for c in self._columns[fid])
        missing = [c for fid in self.required for c in self._columns[fid] if c not in self._values]
        if missing and not stale:
            stale = tuple(missing)
        values = dict(self._values)
        values["t"] = t
        return Row(t, values, stale, max(silent.values()) if silent else 0.0)
