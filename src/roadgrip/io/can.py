"""CAN frames decoded with a DBC (`cantools`) through a *signal map*, live or from a log.

A signal map is a YAML file naming the DBC signal that fills each canonical column, in
the form of the MDF4 channel map (:mod:`roadgrip.io.mdf`)::

    vehicle: sedan          # optional; the readers' vehicle argument overrides it
    rate: 100               # optional raster of a log [Hz]; default the fastest mapped message's
    max_gap: 0.25           # optional [s]; longer gaps in a signal are not bridged (logs)
    timeout: 0.1            # optional [s]; live: a signal silent longer stops the claims
    integrity: xor8         # optional; check <Message>_Checksum and <Message>_Counter
    output: RG_Friction     # optional; the message roadgrip live writes its estimates in
    signals:
      t:        {signal: SampleTime}                 # optional sample clock, else frame times
      ax:       {signal: AccX}                       # unit from the DBC (e.g. g)
      ay:       {signal: AccY, sign: -1, axis: "sensor y points right"}
      steer:    {signal: SWA, scale: 0.0625, axis: "steering-wheel angle / 16"}
      omega_fl: {signal: WhlSpdFL, message: ESP_21, unit: rpm}   # the DBC gives no unit
    extras:
      brake_pressure: {signal: BrkPrs}

Entries take ``signal`` (required), ``message`` (when several messages hold the name),
``unit``, ``sign``, ``scale``, ``axis`` and ``timeout`` [s]. Values are the DBC's
physical values (raw times factor plus offset) converted from the signal's unit to SI
(the DBC's unit, or the map's when the DBC gives none; the two must agree), then
``sign`` and ``scale`` apply, as for MDF4.

**Faults.** :class:`FrameDecoder` drops and counts, per reason (:data:`FAULTS`): a frame
whose id the DBC does not define (``unknown_id``), a length other than the DBC's
(``bad_length``), a mapped signal outside the DBC's ``[min|max]`` (``out_of_range``),
and with ``integrity: xor8`` a wrong checksum (``checksum``) or counter (``counter``).
The xor8 rule: ``<Message>_Checksum`` is a whole byte equal to the XOR of the frame
id's two low bytes and every other payload byte; ``<Message>_Counter`` steps by one
(modulo its range) from one accepted frame of the message to the next; after a frame
is refused the next counter value is taken as it comes (resynchronised), so a
lost frame costs one more frame.

CAN logs (``.blf``, ``.asc``, ``.trc``, read by python-can) become a drive through the
same map (:func:`read_can_log`): every mapped signal is a stream of its accepted
frames, interpolated onto one uniform clock as MDF4 channels are. Frames out of time
order (a logger merging its channels) are put in order; of frames with the same time
stamp, the last one read holds.
"""

from __future__ import annotations

import math
from collections import Counter
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd

from roadgrip.drive import SIGNAL_COLUMNS, Drive, DriveValidationError
from roadgrip.io.mapping import (
    QUANTITY_OF,
    check_map_entry,
    map_vehicle,
    read_map,
    si_unit,
    unit_factor,
)
from roadgrip.io.resample import make_clock, resample
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "CAN_LOG_SUFFIXES",
    "FAULTS",
    "SHIPPED_DBC",
    "SHIPPED_MAP",
    "FrameDecoder",
    "MappedMessage",
    "load_dbc",
    "load_signal_map",
    "read_can_log",
    "xor8",
]

CAN_LOG_SUFFIXES = (".blf", ".asc", ".trc")
"""CAN log files read by :func:`read_can_log`."""

FAULTS = ("unknown_id", "bad_length", "out_of_range", "checksum", "counter", "undecodable")
"""Reasons a frame is dropped (the keys of :attr:`FrameDecoder.dropped`)."""

_DATA = Path(__file__).resolve().parents[1] / "data" / "can"
SHIPPED_DBC = _DATA / "roadgrip.dbc"
"""The example DBC of the canonical chassis signals and the friction output."""
SHIPPED_MAP = _DATA / "roadgrip.yaml"
"""The signal map of :data:`SHIPPED_DBC`."""

_TOP_KEYS = {"vehicle", "rate", "max_gap", "timeout", "integrity", "output", "signals", "extras", "description"}
_INTEGRITY = (None, "xor8")


def _positive(v: Any) -> bool:
    return not isinstance(v, bool) and isinstance(v, int | float) and v > 0 and math.isfinite(v)


def load_signal_map(spec: str | Path | dict[str, Any]) -> dict[str, Any]:
    """Read and check a signal map (module docstring).

    Raises
    ------
    ValueError
        Unreadable file, unknown keys, a target that is not a canonical signal, a bad
        unit, sign, scale, rate, timeout or integrity rule.
    """
    m, name = read_map(spec, kind="signal map", file_kind="signal map", section="signals", top_keys=_TOP_KEYS)
    for key in ("rate", "max_gap", "timeout"):
        if m.get(key) is not None and not _positive(m[key]):
            raise ValueError(f"{name}: {key} must be a positive number, got {m[key]!r}")
    if m.get("integrity") not in _INTEGRITY:
        raise ValueError(f"{name}: integrity must be one of {', '.join(str(i) for i in _INTEGRITY)}, "
                         f"got {m['integrity']!r}")
    out = dict(m)
    for section in ("signals", "extras"):
        entries = m.get(section) or {}
        if not isinstance(entries, dict):
            raise ValueError(f"{name}: '{section}' must map column names to entries")
        out[section] = {}
        for target, entry in entries.items():
            where = f"{name}: {section[:-1]} {target!r}"
            if section == "signals" and target not in QUANTITY_OF:
                raise ValueError(f"{where} is not a canonical signal ({', '.join(SIGNAL_COLUMNS)})")
            if section == "extras" and target in SIGNAL_COLUMNS:
                raise ValueError(f"{where} clashes with a canonical column")
            entry = check_map_entry(entry, where, key="signal", extra_keys=("message", "timeout"),
                                    target=target if section == "signals" else None)
            if entry.get("timeout") is not None and not _positive(entry["timeout"]):
                raise ValueError(f"{where}: timeout must be a positive number, got {entry['timeout']!r}")
            out[section][str(target)] = entry
    return out


def load_dbc(path: str | Path) -> Any:
    """A DBC file as a ``cantools`` database; ``ValueError`` naming the file when it cannot be read."""
    import cantools

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"DBC file not found: {p}")
    try:
        return cantools.database.load_file(str(p), database_format="dbc")
    except Exception as exc:  # cantools raises parser errors of several kinds
        raise ValueError(f"{p.name}: not a readable DBC file: {exc}") from None


def xor8(frame_id: int, data: bytes | bytearray, skip: int) -> int:
    """The xor8 checksum: the frame id's two low bytes XOR every payload byte but ``data[skip]``."""
    c = (frame_id & 0xFF) ^ ((frame_id >> 8) & 0xFF)
    for i, b in enumerate(data):
        if i != skip:
            c ^= b
    return c


class MappedMessage(NamedTuple):
    """A DBC message that fills canonical columns.

    Attributes
    ----------
    message : cantools Message
    targets : tuple of (column, signal name, factor to SI, timeout [s])
    checksum_byte : int or None
        Payload byte of ``<Message>_Checksum`` (``integrity: xor8``).
    counter : str or None
        Name of ``<Message>_Counter``.
    counter_modulo : int
    """

    message: Any
    targets: tuple[tuple[str, str, float, float], ...]
    checksum_byte: int | None
    counter: str | None
    counter_modulo: int


def _find_signal(db: Any, entry: dict[str, Any], target: str, dbc_name: str) -> tuple[Any, Any]:
    name, msg_name = entry["signal"], entry.get("message")
    hits = [(m, s) for m in db.messages for s in m.signals
            if s.name == name and (msg_name is None or m.name == msg_name)]
    if not hits:
        known = sorted(s.name for m in db.messages for s in m.signals)
        raise ValueError(f"{dbc_name}: signal {name!r} (for {target!r}) not found; signals in the DBC: "
                         + ", ".join(known))
    if len(hits) > 1:
        raise ValueError(f"{dbc_name}: signal {name!r} (for {target!r}) is in several messages "
                         f"({', '.join(m.name for m, _ in hits)}): give 'message:'")
    return hits[0]


def _integrity(message: Any, rule: str | None, dbc_name: str) -> tuple[int | None, str | None, int]:
    if rule is None:
        return None, None, 16
    base = message.name.split("_", 1)[1] if message.name.startswith("RG_") else message.name
    sigs = {s.name: s for s in message.signals}
    cs = next((sigs[n] for n in (f"{message.name}_Checksum", f"{base}_Checksum") if n in sigs), None)
    ct = next((sigs[n] for n in (f"{message.name}_Counter", f"{base}_Counter") if n in sigs), None)
    byte = None
    if cs is not None:
        if cs.length != 8 or cs.start % 8 or cs.byte_order != "little_endian":
            raise ValueError(f"{dbc_name}: {cs.name} must be one whole byte for the xor8 checksum")
        byte = cs.start // 8
    return byte, (ct.name if ct is not None else None), (1 << ct.length) if ct is not None else 16


class FrameDecoder:
    """Decode frames into canonical values, dropping and counting the faulty ones.

    Parameters
    ----------
    db : cantools Database
    signal_map : dict
        A checked map (:func:`load_signal_map`).
    dbc_name : str
        The DBC's name in messages.

    Attributes
    ----------
    messages : dict of int to MappedMessage
        Frame id -> the mapped message.
    dropped : Counter
        Frames dropped per reason of :data:`FAULTS`.
    accepted : int
        Frames of mapped messages decoded.
    ignored : int
        Well-formed frames of DBC messages that fill no column.
    """

    def __init__(self, db: Any, signal_map: dict[str, Any], dbc_name: str = "DBC"):
        self.db = db
        self.map = signal_map
        default_timeout = float(signal_map.get("timeout") or 0.1)
        by_msg: dict[int, list[tuple[str, str, float, float]]] = {}
        msgs: dict[int, Any] = {}
        for section in ("signals", "extras"):
            for target, entry in signal_map[section].items():
                msg, sig = _find_signal(db, entry, target, dbc_name)
                where = f"{dbc_name}: signal {sig.name!r} (for {target!r})"
                dbc_unit, map_unit = (sig.unit or "").strip(), entry.get("unit")
                factor = 1.0
                if section == "signals":
                    if not dbc_unit and map_unit is None:
                        raise ValueError(f"{where} has no unit in the DBC: give one in the map ('unit:')")
                    if dbc_unit and map_unit is not None and si_unit(dbc_unit) != si_unit(str(map_unit)):
                        raise ValueError(f"{where}: the DBC says {dbc_unit!r}, the map {map_unit!r}")
                    factor = unit_factor(dbc_unit or str(map_unit), target, where)
                factor *= float(entry.get("sign", 1)) * float(entry.get("scale", 1.0))
                timeout = float(entry.get("timeout") or default_timeout)
                by_msg.setdefault(msg.frame_id, []).append((target, sig.name, factor, timeout))
                msgs[msg.frame_id] = msg
        rule = signal_map.get("integrity")
        self.messages = {fid: MappedMessage(msgs[fid], tuple(t), *_integrity(msgs[fid], rule, dbc_name))
                         for fid, t in by_msg.items()}
        self._limits = {(fid, s.name): (s.minimum, s.maximum)
                        for fid, mm in self.messages.items() for s in mm.message.signals}
        self._known = {m.frame_id for m in db.messages}
        self._last_counter: dict[int, int | None] = dict.fromkeys(self.messages)
        self.dropped: Counter[str] = Counter()
        self.accepted = 0
        self.ignored = 0

    @property
    def columns(self) -> list[str]:
        """Mapped columns in canonical order, then the extras."""
        cols = {t for mm in self.messages.values() for t, *_ in mm.targets}
        return [c for c in SIGNAL_COLUMNS if c in cols] + [c for c in self.map["extras"] if c in cols]

    def resync(self, frame_id: int) -> None:
        """Take the next counter of ``frame_id`` as it comes (after a silence)."""
        self._last_counter[frame_id] = None

    def decode(self, frame_id: int, data: bytes | bytearray) -> dict[str, float] | None:
        """Canonical values [SI] of one frame, or None when it is dropped (counted) or fills nothing."""
        mm = self.messages.get(frame_id)
        if mm is None:
            if frame_id in self._known:
                self.ignored += 1
            else:
                self.dropped["unknown_id"] += 1
            return None
        if len(data) != mm.message.length:
            self.dropped["bad_length"] += 1
            return None
        if mm.checksum_byte is not None and data[mm.checksum_byte] != xor8(frame_id, data, mm.checksum_byte):
            self.dropped["checksum"] += 1
            return None
        try:
            values = mm.message.decode(bytes(data), decode_choices=False, scaling=True)
        except Exception:  # cantools: a payload its signals cannot be read from
            self.dropped["undecodable"] += 1
            return None
        if mm.counter is not None:
            c, last = int(values[mm.counter]), self._last_counter[frame_id]
            self._last_counter[frame_id] = c
            if last is not None and c != (last + 1) % mm.counter_modulo:
                self.dropped["counter"] += 1
                return None
        out = {}
        for target, sig, factor, _ in mm.targets:
            v = float(values[sig])
            lo, hi = self._limits[(frame_id, sig)]
            if (lo is not None and v < lo) or (hi is not None and v > hi):
                self.dropped["out_of_range"] += 1
                return None
            out[target] = v * factor
        self.accepted += 1
        return out

    def report(self) -> dict[str, int]:
        """``accepted``, ``ignored`` and the dropped frames per reason (all of :data:`FAULTS`)."""
        return {"accepted": self.accepted, "ignored": self.ignored, **{k: int(self.dropped[k]) for k in FAULTS}}


def read_can_log(
    path: str | Path,
    dbc: str | Path,
    signals: str | Path | dict[str, Any] | None = None,
    vehicle: str | Path | VehicleParams | None = None,
) -> Drive:
    """Read a CAN log (``.blf``, ``.asc``, ``.trc``) through a DBC and a signal map.

    Parameters
    ----------
    path : str or Path
        The log.
    dbc : str or Path
        The DBC file.
    signals : str, Path or dict, optional
        Signal map (module docstring); default the shipped map (:data:`SHIPPED_MAP`).
    vehicle : preset name, YAML path or VehicleParams, optional
        Overrides the map's ``vehicle``; one of the two is required.

    Returns
    -------
    Drive
        Canonical signals in SI units on a uniform clock (``t`` from the map's ``t``
        signal, else the frames' times, zero at the first tick). ``meta.extra``:
        ``format`` (``'can'``), ``signal_map`` (column -> signal), ``frames``
        (:meth:`FrameDecoder.report`), ``rate_hz``, ``t_origin_s``.

    Raises
    ------
    ValueError
        Unreadable log, DBC or map, a mapped signal with no accepted frame, or a failed
        :class:`~roadgrip.drive.Drive` validation.
    """
    import can

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"no such file: {p}")
    if p.suffix.lower() not in CAN_LOG_SUFFIXES:
        raise ValueError(f"{p.name}: a CAN log is {', '.join(CAN_LOG_SUFFIXES)}")
    m = load_signal_map(signals if signals is not None else SHIPPED_MAP)
    named = "" if signals is None or isinstance(signals, dict) else f" {Path(signals).name}"
    veh = map_vehicle(m, vehicle, "read_can_log", f"signal map{named}")
    decoder = FrameDecoder(load_dbc(dbc), m, Path(dbc).name)
    cols = decoder.columns
    ts: dict[str, list[float]] = {c: [] for c in cols}
    vs: dict[str, list[float]] = {c: [] for c in cols}
    clock: list[tuple[float, float]] = []  # (frame time, sample time) pairs of the t signal
    try:
        for msg in can.LogReader(str(p)):
            if msg.is_error_frame or msg.is_remote_frame:
                continue
            values = decoder.decode(msg.arbitration_id, msg.data)
            if values is None:
                continue
            if "t" in values:
                clock.append((float(msg.timestamp), values["t"]))
            for c, v in values.items():
                ts[c].append(float(msg.timestamp))
                vs[c].append(v)
    except Exception as exc:  # python-can's readers raise several errors on a foreign file
        raise ValueError(f"{p.name}: not a readable CAN log: {exc}") from None
    empty = [c for c in cols if not ts[c]]
    if empty:
        raise ValueError(f"{p.name}: no accepted frame of {', '.join(empty)} "
                         f"(dropped: {dict(decoder.dropped) or 'none'})")
    # frames out of time order (a logger merging its channels) are put in order; of
    # frames with one time stamp, the last read holds
    if clock:  # the sample clock: frame times mapped onto the t signal's
        ft, st = np.array(clock).T
        order = np.argsort(ft, kind="stable")
        ft, st = ft[order], st[order]
        to_clock = lambda x: np.interp(x, ft, st)  # noqa: E731
    else:
        to_clock = np.asarray
    streams = {}
    for c in cols:
        if c == "t":
            continue
        t = np.asarray(to_clock(np.asarray(ts[c])), float)
        order = np.argsort(t, kind="stable")
        t, v = t[order], np.asarray(vs[c])[order]
        keep = np.concatenate([np.diff(t) > 0, [True]])
        streams[c] = pd.DataFrame({"t": t[keep], c: v[keep]})
    rates = [1.0 / np.median(np.diff(s["t"])) for s in streams.values() if len(s) > 1]
    rate = float(m.get("rate") or float(f"{max(rates):.6g}"))
    lo = max(s["t"].iloc[0] for s in streams.values())
    hi = min(s["t"].iloc[-1] for s in streams.values())
    if hi < lo:
        raise ValueError(f"{p.name}: the mapped signals do not overlap in time")
    for s in streams.values():
        s["t"] = s["t"] - lo
    df = resample(streams, clock=make_clock(0.0, hi - lo, rate), max_gap=m.get("max_gap"))
    order = [c for c in SIGNAL_COLUMNS if c in df.columns] + [c for c in m["extras"] if c in df.columns]
    extra = {"format": "can", "signal_map": {c: e["signal"] for s in ("signals", "extras") for c, e in m[s].items()},
             "frames": decoder.report(), "rate_hz": rate, "t_origin_s": float(lo)}
    try:
        return Drive.from_frame(df[order].reset_index(drop=True), veh, source=str(p), extra=extra)
    except DriveValidationError as exc:
        raise DriveValidationError(f"{p.name}: {exc}") from None


class FrameEncoder:
    """Encode canonical values or named signals into frames of a DBC, with counter and checksum.

    The inverse of :class:`FrameDecoder` for the mapped messages (SI values divided by
    the map's factors, then the DBC's scaling), and a plain encoder of any message of
    the DBC by signal name (:meth:`encode`). With ``integrity: xor8`` every message
    gets its running ``<Message>_Counter`` and its ``<Message>_Checksum``.

    Parameters
    ----------
    db : cantools Database
    signal_map : dict
        A checked map (:func:`load_signal_map`).
    """

    def __init__(self, db: Any, signal_map: dict[str, Any]):
        self.db = db
        self.decoder = FrameDecoder(db, signal_map)
        self.rule = signal_map.get("integrity")
        self._counters: dict[int, int] = {}

    def encode(self, name: str, values: dict[str, float]) -> tuple[int, bytes]:
        """``(frame id, payload)`` of message ``name`` with its signals at ``values``
        (physical, DBC units; missing signals 0, values clipped to the DBC's range)."""
        msg = self.db.get_message_by_name(name)
        byte, counter, modulo = _integrity(msg, self.rule, "DBC")
        full = {}
        for s in msg.signals:
            v = float(values.get(s.name, 0.0))
            lo, hi = s.minimum, s.maximum
            full[s.name] = min(max(v, lo if lo is not None else v), hi if hi is not None else v)
        if counter is not None:
            c = self._counters.get(msg.frame_id, -1)
            c = (c + 1) % modulo
            self._counters[msg.frame_id] = c
            full[counter] = c
        data = bytearray(msg.encode(full, scaling=True, strict=False))
        if byte is not None:
            data[byte] = xor8(msg.frame_id, data, byte)
        return msg.frame_id, bytes(data)

    def encode_sample(self, row: dict[str, float]) -> list[tuple[int, bytes]]:
        """The frames of one sample of canonical values [SI] (every mapped message, the
        one holding ``t`` first)."""
        frames = []
        for _, mm in sorted(self.decoder.messages.items(),
                            key=lambda kv: not any(t == "t" for t, *_ in kv[1].targets)):
            values = {sig: row[target] / factor for target, sig, factor, _ in mm.targets if target in row}
            frames.append(self.encode(mm.message.name, values))
        return frames
