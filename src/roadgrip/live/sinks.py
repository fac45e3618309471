"""Where live friction goes: CAN frames per the DBC, VSS JSON lines (a stream or UDP), a
Foxglove live view, or a list (tests).

Every sink has ``write(rows)`` taking :class:`~roadgrip.live.runner.LiveRow` objects and
``close()``. A sink never raises on a row: a UDP peer that is not listening or a bus
that refuses a frame is counted in ``errors``.
"""

from __future__ import annotations

import json
import math
import socket
from typing import IO, Any

import numpy as np

from roadgrip.io.can import FrameEncoder
from roadgrip.live.runner import REASONS, LiveRow

__all__ = ["CLASS_CODES", "CanSink", "FoxgloveSink", "ListSink", "UdpSink", "VssSink"]

CLASS_CODES = {"unknown": 0, "low": 1, "high": 2}
"""``GripClass`` values of the output message."""


class ListSink:
    """Keeps the rows (tests, the replay comparison)."""

    def __init__(self) -> None:
        self.rows: list[LiveRow] = []
        self.errors = 0

    def write(self, rows: list[LiveRow]) -> None:
        self.rows.extend(rows)

    def close(self) -> None:
        pass


class VssSink:
    """VSS JSON lines (:meth:`LiveRow.vss`) to a text stream, flushed per batch."""

    def __init__(self, stream: IO[str]):
        self.stream = stream
        self.errors = 0

    def write(self, rows: list[LiveRow]) -> None:
        if rows:
            self.stream.write("".join(json.dumps(r.vss()) + "\n" for r in rows))
            self.stream.flush()

    def close(self) -> None:
        self.stream.flush()


class UdpSink:
    """VSS JSON lines as UDP datagrams, one row each, to ``host:port``."""

    def __init__(self, host: str, port: int):
        self.address = (host, int(port))
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.errors = 0

    def write(self, rows: list[LiveRow]) -> None:
        for r in rows:
            try:
                self.sock.sendto(json.dumps(r.vss()).encode(), self.address)
            except OSError:
                self.errors += 1

    def close(self) -> None:
        self.sock.close()


class CanSink:
    """The output message of the DBC (e.g. ``RG_Friction``) per row, on a python-can bus.

    Signals filled: ``MostProbable``, ``LowerBound``, ``UpperBound`` [%] with
    ``*Valid`` flags (0 where the value is withheld), ``GripClass``
    (:data:`CLASS_CODES`) and ``Reason`` (index in :data:`~roadgrip.live.runner.REASONS`),
    plus the counter and checksum of the map's integrity rule.
    """

    def __init__(self, bus: Any, encoder: FrameEncoder, message: str):
        import can

        self._can = can
        self.bus = bus
        self.encoder = encoder
        self.message = message
        encoder.db.get_message_by_name(message)  # KeyError names an unknown message
        self.errors = 0

    def frame(self, row: LiveRow) -> tuple[int, bytes]:
        """``(frame id, payload)`` of one row."""
        values: dict[str, float] = {"GripClass": CLASS_CODES.get(row.grip_class, 0),
                                    "Reason": REASONS.index(row.reason)}
        for name, v in (("MostProbable", row.most_probable), ("LowerBound", row.lower), ("UpperBound", row.upper)):
            ok = math.isfinite(v)
            values[name] = v if ok else 0.0
            values[name + "Valid"] = int(ok)
        return self.encoder.encode(self.message, values)

    def write(self, rows: list[LiveRow]) -> None:
        for r in rows:
            fid, data = self.frame(r)
            try:
                self.bus.send(self._can.Message(arbitration_id=fid, data=data, is_extended_id=fid > 0x7FF))
            except (self._can.CanError, OSError):
                self.errors += 1

    def close(self) -> None:
        pass


FRICTION_SCHEMA = {
    "type": "object",
    "properties": {
        "t": {"type": "number"}, "most_probable": {"type": "number"}, "lower": {"type": "number"},
        "upper": {"type": "number"}, "grip_class": {"type": "string"}, "mu_front": {"type": "number"},
        "mu_rear": {"type": "number"}, "reason": {"type": "string"}, "detail": {"type": "string"},
    },
}
CURVE_SCHEMA = {
    "type": "object",
    "properties": {
        "t": {"type": "number"}, "alpha_deg": {"type": "array", "items": {"type": "number"}},
        "front": {"type": "object"}, "rear": {"type": "object"},
    },
}


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


class FoxgloveSink:
    """A Foxglove WebSocket server (``foxglove-sdk``) with the live friction.

    Topics: ``/roadgrip/friction`` (JSON per row: the :class:`LiveRow` fields, the
    friction trace with its class and reason; withheld values null) and, for an
    estimator that learns a curve (:meth:`LiveEstimator.curve`), ``/roadgrip/curve``
    every ``curve_period`` seconds of drive time: slip angles [deg] and per axle the
    mean, lower and upper friction curve [-] on ``n_alpha`` slip angles in ±12 deg. Open it
    in Foxglove Studio (``ws://host:port``) or any WebSocket client of the ``foxglove.sdk.v1``
    protocol. A curve costs the GP-SSM's posterior on every slip angle (about 10 to 25 ms
    per angle with 64 particles here), taken in the loop: its row waits for it.
    """

    def __init__(self, estimator: Any = None, host: str = "127.0.0.1", port: int = 8765,
                 curve_period: float = 2.0, n_alpha: int = 25):
        import foxglove

        self.context = foxglove.Context()  # its own channels: several sinks in one process stay apart
        self.server = foxglove.start_server(host=host, port=port, name="roadgrip", context=self.context)
        self.port = self.server.port
        self.friction = foxglove.Channel("/roadgrip/friction", schema=FRICTION_SCHEMA, context=self.context)
        self.curve_channel = foxglove.Channel("/roadgrip/curve", schema=CURVE_SCHEMA, context=self.context)
        self.estimator = estimator
        self.curve_period = float(curve_period)
        self._next_curve = float("-inf")
        self._alpha = np.deg2rad(np.linspace(-12.0, 12.0, n_alpha))
        self.errors = 0

    def write(self, rows: list[LiveRow]) -> None:
        for r in rows:
            msg = {k: (_finite(v) if isinstance(v, float) else v) for k, v in r._asdict().items()}
            self.friction.log(msg, log_time=max(int(r.t * 1e9), 0))
        if rows and self.estimator is not None and rows[-1].t >= self._next_curve:
            cp = self.estimator.curve(self._alpha)
            if cp is not None:
                self._next_curve = rows[-1].t + self.curve_period
                axle = {name: {"mean": cp.mean[i].tolist(), "lower": cp.lower[i].tolist(),
                               "upper": cp.upper[i].tolist()} for i, name in enumerate(("front", "rear"))}
                self.curve_channel.log({"t": rows[-1].t, "alpha_deg": np.rad2deg(cp.alpha).tolist(), **axle},
                                       log_time=max(int(rows[-1].t * 1e9), 0))

    def close(self) -> None:
        self.server.stop()
