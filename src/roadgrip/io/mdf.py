"""ASAM MDF4 files (CAN and data loggers), read with `asammdf` through a *channel map*.

A channel map is a YAML file naming the channel that fills each canonical signal::

    vehicle: sedan          # optional; read_mdf(vehicle=...) overrides it
    rate: 100               # optional raster [Hz]; default: the fastest mapped channel's
                            # rate (median step, to 6 significant digits)
    max_gap: 0.25           # optional [s]; longer gaps in a channel are not bridged
    channels:
      ax:       {channel: ESP_AccX}                 # unit from the file (e.g. g)
      ay:       {channel: ESP_AccY, sign: -1, axis: "logger y points right"}
      yaw_rate: {channel: ESP_YawRate}             # e.g. deg/s in the file
      steer:    {channel: SAS_Angle, scale: 0.0625, axis: "steering-wheel angle / 16"}
      vx:       {channel: ESP_VehSpeed}            # e.g. km/h
      omega_fl: {channel: WheelSpdFL, unit: rpm}   # the file gives no unit: say it here
    extras:                                        # optional; kept as extra columns, unconverted
      brake_pressure: {channel: ESP_BrakePress}

Values are the file's physical values (its conversions applied, e.g. a raw integer
times a factor), then converted from the channel's unit to SI: the unit is the file's
(``deg/s`` -> rad/s, ``km/h`` -> m/s, ``g`` -> m/s², ...; see :data:`UNIT_ALIASES`
for the spellings understood). A channel without a unit must be given one in the
map (``unit:``), else reading stops with an error naming it; a map unit that
contradicts the file's is an error too. Then ``sign`` (+-1) and ``scale`` (e.g. one
over a steering ratio) apply, and ``group`` picks one of several channels of the same
name.

**Raster.** All mapped channels are interpolated linearly onto one uniform clock at
``rate`` over the span every channel covers (:func:`roadgrip.io.resample.resample`):
never extrapolated, ticks inside a gap longer than ``max_gap`` dropped. ``t`` is zero
at the first tick; ``meta.extra`` holds the file's ``start_time``, the offset
``t_origin_s`` of the first tick from it, every mapped channel's native rate
(``source_rates_hz``), and the channels found in the file but not used
(``channels_unused``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.drive import SIGNAL_COLUMNS, Drive, DriveValidationError
from roadgrip.io.mapping import (
    QUANTITY_OF,
    UNIT_ALIASES,
    check_map_entry,
    map_vehicle,
    read_map,
    si_unit,
    unit_factor,
)
from roadgrip.io.resample import make_clock, resample
from roadgrip.vehicle.params import VehicleParams

__all__ = ["UNIT_ALIASES", "load_channel_map", "read_mdf", "si_unit"]

_TOP_KEYS = {"vehicle", "rate", "max_gap", "channels", "extras", "description"}


def load_channel_map(spec: str | Path | dict[str, Any]) -> dict[str, Any]:
    """Read and check a channel map (module docstring).

    Raises
    ------
    ValueError
        Unreadable file, unknown keys, a target that is not a canonical signal (or
        is ``t``, which comes from the file's time channels), a unit that is unknown
        or does not fit the signal, a sign other than +-1, a bad scale or rate.
    """
    m, name = read_map(spec, kind="channel map", file_kind="channel map", section="channels", top_keys=_TOP_KEYS)
    for key in ("rate", "max_gap"):
        v = m.get(key)
        if v is not None and (isinstance(v, bool) or not isinstance(v, int | float) or not v > 0
                              or not math.isfinite(v)):
            raise ValueError(f"{name}: {key} must be a positive number, got {v!r}")
    out = dict(m)
    for section in ("channels", "extras"):
        entries = m.get(section) or {}
        if not isinstance(entries, dict):
            raise ValueError(f"{name}: '{section}' must map column names to entries")
        out[section] = {}
        for target, entry in entries.items():
            where = f"{name}: {section[:-1]} {target!r}"
            if section == "channels" and (target not in QUANTITY_OF or target == "t"):
                raise ValueError(
                    f"{where} is not a canonical signal a channel can fill "
                    f"({', '.join(c for c in SIGNAL_COLUMNS if c != 't')}); time comes from the file"
                )
            if section == "extras" and target in SIGNAL_COLUMNS:
                raise ValueError(f"{where} clashes with a canonical column")
            entry = check_map_entry(entry, where, key="channel", extra_keys=("group",),
                                    target=target if section == "channels" else None)
            out[section][str(target)] = entry
    return out


def _get(mdf: Any, entry: dict[str, Any], target: str, fname: str):
    name = entry["channel"]
    if name not in mdf.channels_db:
        raise ValueError(
            f"{fname}: channel {name!r} (for {target!r}) not found; channels in the file: "
            + ", ".join(sorted(mdf.channels_db))
        )
    try:
        return mdf.get(name, group=entry.get("group"))
    except Exception as exc:  # asammdf: several groups hold this name
        raise ValueError(f"{fname}: channel {name!r} (for {target!r}): {exc}; give 'group:'") from None


def read_mdf(
    path: str | Path,
    channels: str | Path | dict[str, Any],
    vehicle: str | Path | VehicleParams | None = None,
) -> Drive:
    """Read an ASAM MDF4 file through a channel map.

    Parameters
    ----------
    path : str or Path
        ``.mf4`` (or MDF 3 ``.mdf``) file.
    channels : str, Path or dict
        Channel map (module docstring) or the parsed map.
    vehicle : preset name, YAML path or VehicleParams, optional
        Overrides the map's ``vehicle``; one of the two is required.

    Returns
    -------
    Drive
        Canonical signals in SI units on a uniform clock, the ``extras`` as extra
        columns. ``meta.extra``: ``format`` (``'mdf'``), ``channel_map`` (column ->
        channel), ``units`` (column -> the file's or the map's unit),
        ``source_rates_hz``, ``source_counts``, ``channels_unused``, ``start_time``,
        ``t_origin_s``, ``rate_hz`` and ``interpolation``.

    Raises
    ------
    ValueError
        Unreadable file or map, a missing channel (the message lists the file's
        channels), a channel without a unit and none in the map, a unit that is
        unknown, contradicts the map or does not fit its signal, or a failed
        :class:`~roadgrip.drive.Drive` validation.
    """
    from asammdf import MDF

    p = Path(path)
    if not p.is_file():
        raise ValueError(f"no such file: {p}")
    m = load_channel_map(channels)
    named = "" if channels is None or isinstance(channels, dict) else f" {Path(channels).name}"
    veh = map_vehicle(m, vehicle, "read_mdf", f"channel map{named}")
    try:
        mdf = MDF(p)
    except Exception as exc:  # asammdf raises several errors on a foreign file
        raise ValueError(f"{p.name}: not a readable MDF file: {exc}") from None
    try:
        masters = {mdf.groups[g].channels[i].name for g, i in mdf.masters_db.items()}
        streams: dict[str, pd.DataFrame] = {}
        units: dict[str, str] = {}
        rates: dict[str, float] = {}
        counts: dict[str, int] = {}
        for section in ("channels", "extras"):
            for target, entry in m[section].items():
                sig = _get(mdf, entry, target, p.name)
                file_unit = (sig.unit or "").strip()
                map_unit = entry.get("unit")
                where = f"{p.name}: channel {entry['channel']!r} (for {target!r})"
                factor = 1.0
                if section == "channels" or map_unit is not None:
                    if not file_unit and map_unit is None:
                        raise ValueError(f"{where} has no unit in the file: give one in the map ('unit:')")
                    if file_unit and map_unit is not None and si_unit(file_unit) != si_unit(str(map_unit)):
                        raise ValueError(f"{where}: the file says {file_unit!r}, the map {map_unit!r}")
                    unit = file_unit or str(map_unit)
                    factor = unit_factor(unit, target if section == "channels" else None, where)
                    units[target] = unit
                ts = np.asarray(sig.timestamps, dtype=float)
                if np.asarray(sig.samples).dtype.kind not in "biuf":
                    raise ValueError(f"{where} holds {np.asarray(sig.samples).dtype} samples "
                                     f"(e.g. {np.asarray(sig.samples).ravel()[:1].tolist()}), not numbers")
                v = np.asarray(sig.samples, dtype=float)
                if v.ndim != 1:
                    raise ValueError(f"{where} is not a scalar channel (samples of shape {v.shape})")
                step = np.diff(ts)
                if not np.isfinite(ts).all() or (step < 0).any():
                    i = int(np.argmax(~np.isfinite(ts))) if not np.isfinite(ts).all() else int(np.argmax(step < 0)) + 1
                    raise ValueError(f"{where}: its time stamps go backwards (or are not finite) at sample "
                                     f"{i} (t = {ts[i]:.6g} s after {ts[i - 1] if i else math.nan:.6g} s): "
                                     "a logger clock reset; split the file there")
                if (step == 0).any():  # a repeated stamp: the latest value holds
                    keep = np.concatenate([step > 0, [True]])
                    ts, v = ts[keep], v[keep]
                factor *= float(entry.get("sign", 1)) * float(entry.get("scale", 1.0))
                streams[target] = pd.DataFrame({"t": ts, target: v * factor})
                rates[entry["channel"]] = float(1.0 / np.median(np.diff(ts))) if len(ts) > 1 else float("nan")
                counts[entry["channel"]] = len(ts)
        used = {e["channel"] for sec in ("channels", "extras") for e in m[sec].values()}
        unused = sorted(set(mdf.channels_db) - used - masters)
        start_time = str(mdf.header.start_time)
    finally:
        mdf.close()
    # a logger's nominal rate (10, 50, 100 Hz ...) from the median step, to 6 digits
    rate = float(m.get("rate") or float(f"{max(r for r in rates.values() if np.isfinite(r)):.6g}"))
    lo = max(s["t"].iloc[0] for s in streams.values())
    hi = min(s["t"].iloc[-1] for s in streams.values())
    if hi < lo:
        raise ValueError(f"{p.name}: the mapped channels do not overlap in time")
    for s in streams.values():
        s["t"] = s["t"] - lo
    df = resample(streams, clock=make_clock(0.0, hi - lo, rate), max_gap=m.get("max_gap"))
    order = [c for c in SIGNAL_COLUMNS if c in df.columns] + [c for c in m["extras"] if c in df.columns]
    extra = {
        "format": "mdf",
        "channel_map": {c: e["channel"] for sec in ("channels", "extras") for c, e in m[sec].items()},
        "units": units,
        "source_rates_hz": rates,
        "source_counts": counts,
        "channels_unused": unused,
        "start_time": start_time,
        "t_origin_s": float(lo),
        "rate_hz": rate,
        "interpolation": (
            f"linear onto a uniform {rate:g} Hz clock over the span all mapped channels cover, "
            "never extrapolated" + (f"; ticks inside a gap over {m['max_gap']} s dropped"
                                    if m.get("max_gap") else "")
        ),
    }
    try:
        return Drive.from_frame(df[order].reset_index(drop=True), veh, source=str(p), extra=extra)
    except DriveValidationError as exc:  # name the file, as the other readers do
        raise DriveValidationError(f"{p.name}: {exc}") from None
