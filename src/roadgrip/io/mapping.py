"""Foreign logs through a column-mapping file.

A mapping is a YAML file that says, for each canonical column, which source
column holds it, in which unit, with which sign; the conversion happens once,
on the way in. Example::

    # mapping for logger X
    vehicle: sedan            # optional; read_mapped(vehicle=...) overrides it
    time_zero: true           # optional; shift t to start at 0 (default false)
    keep: [brake_pressure]    # optional; source columns kept as extra columns
    columns:
      t:        {column: time_ms, unit: ms}
      ax:       {column: AccX, unit: g}
      ay:       {column: AccY, unit: g, sign: -1, axis: "sensor y points right"}
      yaw_rate: {column: GyroZ, unit: deg/s, sign: -1, axis: "sensor z points down"}
      steer:    {column: SWA, unit: deg, scale: 0.0625, axis: "steering-wheel angle / 16"}
      vx:       {column: speed, unit: km/h}

Each entry takes ``column`` (required), ``unit`` (required; see
:data:`UNITS`), ``sign`` (+1 or -1, default +1), ``scale`` (a dimensionless
factor applied after the unit, e.g. one over a steering ratio; default 1),
and ``axis`` (free-text remark). Units must fit the column's quantity: an
acceleration takes ``m/s^2`` or ``g``, an angle ``rad`` or ``deg``, and so on.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import yaml

from roadgrip.constants import GRAVITY
from roadgrip.drive import SIGNAL_COLUMNS, Drive, DriveValidationError
from roadgrip.io._csv import read_csv_exact
from roadgrip.vehicle.params import VehicleParams, load_vehicle

__all__ = ["ENTRY_KEYS", "QUANTITY_OF", "UNITS", "UNIT_ALIASES", "check_map_entry", "load_mapping", "map_vehicle",
           "read_map", "read_mapped", "si_unit", "unit_factor"]

UNITS: dict[str, tuple[str, float]] = {
    "m/s^2": ("acceleration", 1.0),
    "m/s2": ("acceleration", 1.0),
    "g": ("acceleration", GRAVITY),
    "rad/s": ("rate", 1.0),
    "deg/s": ("rate", math.pi / 180.0),
    "rpm": ("rate", 2.0 * math.pi / 60.0),
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
    "m/s": ("speed", 1.0),
    "km/h": ("speed", 1.0 / 3.6),
    "s": ("time", 1.0),
    "ms": ("time", 1.0e-3),
    "m": ("length", 1.0),
}
"""Unit name -> (quantity, factor to SI)."""

QUANTITY_OF: dict[str, str] = {
    "t": "time",
    "ax": "acceleration",
    "ay": "acceleration",
    "yaw_rate": "rate",
    "steer": "angle",
    "vx": "speed",
    "omega_fl": "rate",
    "omega_fr": "rate",
    "omega_rl": "rate",
    "omega_rr": "rate",
    "x": "length",
    "y": "length",
    "psi": "angle",
}
"""Canonical column -> the quantity its unit must measure."""

_TOP_KEYS = {"columns", "vehicle", "time_zero", "keep", "source", "description"}
_ENTRY_KEYS = {"column", "unit", "sign", "scale", "axis"}

UNIT_ALIASES: dict[str, str] = {
    "m/s²": "m/s^2", "m/s/s": "m/s^2", "m s-2": "m/s^2", "mps2": "m/s^2",
    "°/s": "deg/s", "deg/sec": "deg/s", "grad/s": "deg/s", "dps": "deg/s",
    "rad/sec": "rad/s", "1/min": "rpm", "U/min": "rpm", "rev/min": "rpm",
    "°": "deg", "grad": "deg", "kph": "km/h", "kmh": "km/h", "km/hr": "km/h",
    "mps": "m/s", "sec": "s", "G": "g",
}  # fmt: skip
"""Unit spellings found in MDF files and DBCs -> the names of :data:`UNITS`."""

ENTRY_KEYS = ("unit", "sign", "scale", "axis")
"""Keys every entry of a channel or signal map takes besides its source key."""


def si_unit(unit: str) -> str | None:
    """The :data:`UNITS` name of a unit spelling (:data:`UNIT_ALIASES`), or None if unknown."""
    u = unit.strip()
    u = UNIT_ALIASES.get(u, u)
    return u if u in UNITS else None


def unit_factor(unit: str, target: str | None, where: str) -> float:
    """The factor to SI of ``unit`` (any spelling of :data:`UNIT_ALIASES`).

    Parameters
    ----------
    unit : str
        The unit as the file or the map spells it.
    target : str, optional
        The canonical column it fills: the unit must measure its quantity
        (:data:`QUANTITY_OF`); None for an extra column (any known unit).
    where : str
        The map entry or channel, for the message.

    Raises
    ------
    ValueError
        An unknown unit, or one that measures another quantity than ``target``.
    """
    key = si_unit(unit)
    if key is None:
        raise ValueError(
            f"{where}: unit {unit!r} is not understood; known: {', '.join(UNITS)} "
            f"(and {', '.join(UNIT_ALIASES)})"
        )
    quantity, factor = UNITS[key]
    if target is not None and quantity != QUANTITY_OF[target]:
        raise ValueError(f"{where}: unit {unit!r} measures {quantity}, but {target!r} is a {QUANTITY_OF[target]}")
    return factor


def check_map_entry(entry: Any, where: str, *, key: str, extra_keys: tuple[str, ...] = (),
                    target: str | None = None) -> dict[str, Any]:
    """One entry of a channel map (MDF4) or signal map (CAN), checked.

    Parameters
    ----------
    entry : str or dict
        ``{key: name, unit:, sign:, scale:, axis:, ...}``, or the source name alone
        (shorthand for ``{key: name}``).
    where : str
        The map and the entry, for messages (``"car.yaml: channel 'ax'"``).
    key : str
        The key naming the source (``'channel'``, ``'signal'``); required, a string.
    extra_keys : tuple of str
        Keys the reader takes besides :data:`ENTRY_KEYS` (``'group'``; ``'message'``,
        ``'timeout'``); their values are the caller's to check.
    target : str, optional
        The canonical column the entry fills (its unit must fit); None for an extra.

    Returns
    -------
    dict
        The entry as a mapping.

    Raises
    ------
    ValueError
        Naming ``where``: no source name, unknown keys, a unit that is unknown or does
        not fit ``target``, a sign other than +-1, a scale that is not a finite
        non-zero number.
    """
    if isinstance(entry, str):
        entry = {key: entry}
    if not isinstance(entry, dict) or not isinstance(entry.get(key), str):
        raise ValueError(f"{where}: expected a mapping with {key!r}")
    known = {key, *ENTRY_KEYS, *extra_keys}
    bad = sorted(map(str, set(entry) - known))
    if bad:
        raise ValueError(f"{where}: unknown key(s) {bad}; known: {sorted(known)}")
    if entry.get("unit") is not None:
        unit_factor(str(entry["unit"]), target, where)
    sign = entry.get("sign", 1)
    if isinstance(sign, bool) or sign not in (1, -1):
        raise ValueError(f"{where}: sign must be +1 or -1, got {sign!r}")
    scale = entry.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not math.isfinite(scale) or scale == 0:
        raise ValueError(f"{where}: scale must be a finite non-zero number, got {scale!r}")
    return dict(entry)



def map_vehicle(m: dict[str, Any], vehicle: str | Path | VehicleParams | None, reader: str,
                kind: str) -> VehicleParams:
    """The vehicle of a reader: the argument, else the map's ``vehicle:`` entry.

    ``reader`` and ``kind`` (e.g. ``'read_mdf'``, ``'channel map'``) name them in the
    error raised when neither gives one, and ``kind`` in the error about the map's entry.
    """
    spec = vehicle if vehicle is not None else m.get("vehicle")
    if spec is None:
        raise ValueError(f"{reader} needs a vehicle: in the {kind} ('vehicle:') or as argument")
    if vehicle is not None or isinstance(spec, VehicleParams):
        return load_vehicle(spec)
    if not isinstance(spec, str | Path):
        raise ValueError(f"{kind}: 'vehicle:' must be a preset name or a YAML file, got {spec!r}")
    try:
        return load_vehicle(spec)
    except ValueError as exc:
        raise ValueError(f"{kind}, 'vehicle:' entry: {exc}") from None


def read_map(spec: str | Path | dict[str, Any], *, kind: str, file_kind: str, section: str,
             top_keys: set[str], missing_hint: str = "") -> tuple[dict[str, Any], str]:
    """A YAML map (column, channel or topic map) read and checked for its main section.

    Parameters
    ----------
    spec : str, Path or dict
        A YAML file or an already-parsed map.
    kind : str
        What the map is, in messages (``'channel map'``); also the name of a parsed map.
    file_kind : str
        What the file is, in the messages about reading it (``'mapping file'``).
    section : str
        The section that must be a non-empty mapping (``'channels'``).
    top_keys : set of str
        The keys allowed at the top level.
    missing_hint : str
        Appended to the not-found message (e.g. the shipped maps).

    Returns
    -------
    (dict, str)
        The map and its name for messages (the file's name, or ``kind``).

    Raises
    ------
    ValueError
        A missing or unreadable file, invalid YAML, no such section, unknown top-level keys.
    """
    if isinstance(spec, dict):
        m, name = dict(spec), kind
    else:
        p = Path(spec)
        name = p.name
        try:
            m = yaml.safe_load(p.read_text())
        except FileNotFoundError:
            raise ValueError(f"{file_kind} not found: {p}{missing_hint}") from None
        except IsADirectoryError:
            raise ValueError(f"{file_kind} {p} is a folder, not a file") from None
        except UnicodeDecodeError as exc:
            raise ValueError(f"{file_kind} {name} is not text (byte {exc.start}: {exc.reason})") from None
        except yaml.YAMLError as exc:
            raise ValueError(f"{file_kind} {name} is not valid YAML: {' '.join(str(exc).split())}") from None
    if not isinstance(m, dict) or not isinstance(m.get(section), dict) or not m[section]:
        raise ValueError(f"{name}: a {kind} needs a non-empty '{section}' section")
    unknown = sorted(set(m) - top_keys)
    if unknown:
        raise ValueError(f"{name}: unknown key(s) {unknown}; known: {sorted(top_keys)}")
    return m, name

def load_mapping(spec: str | Path | dict[str, Any]) -> dict[str, Any]:
    """Read and check a mapping (YAML path or an already-parsed mapping).

    Raises
    ------
    ValueError
        Unreadable file, unknown keys, a non-canonical target column, a unit
        that is unknown or does not fit the column, a sign other than +-1.
    """
    m, name = read_map(spec, kind="mapping", file_kind="mapping file", section="columns", top_keys=_TOP_KEYS)
    cols = m["columns"]
    if "t" not in cols:
        raise ValueError(f"{name}: the mapping must give the time column 't'")
    for target, entry in cols.items():
        where = f"{name}: column {target!r}"
        if target not in QUANTITY_OF:
            raise ValueError(f"{where} is not a canonical signal column ({', '.join(SIGNAL_COLUMNS)})")
        if not isinstance(entry, dict):
            raise ValueError(f"{where}: expected a mapping with 'column' and 'unit'")
        bad = sorted(set(entry) - _ENTRY_KEYS)
        if bad:
            raise ValueError(f"{where}: unknown key(s) {bad}; known: {sorted(_ENTRY_KEYS)}")
        for req in ("column", "unit"):
            if req not in entry:
                raise ValueError(f"{where}: missing {req!r}")
        unit = str(entry["unit"])
        if unit not in UNITS:
            raise ValueError(f"{where}: unknown unit {unit!r}; known: {', '.join(UNITS)}")
        if UNITS[unit][0] != QUANTITY_OF[target]:
            raise ValueError(
                f"{where}: unit {unit!r} measures {UNITS[unit][0]}, but {target!r} is a "
                f"{QUANTITY_OF[target]}"
            )
        sign = entry.get("sign", 1)
        if sign not in (1, -1):
            raise ValueError(f"{where}: sign must be +1 or -1, got {sign!r}")
        scale = entry.get("scale", 1.0)
        if isinstance(scale, bool) or not isinstance(scale, int | float) or not math.isfinite(scale) or scale == 0:
            raise ValueError(f"{where}: scale must be a finite non-zero number, got {scale!r}")
    keep = m.get("keep", [])
    if not isinstance(keep, list):
        raise ValueError(f"{name}: 'keep' must be a list of source column names")
    return m


def read_mapped(
    csv_path: str | Path,
    mapping_yaml: str | Path | dict[str, Any],
    vehicle: str | Path | VehicleParams | None = None,
) -> Drive:
    """Read a foreign CSV log through a column mapping.

    Parameters
    ----------
    csv_path : str or Path
        The log.
    mapping_yaml : str, Path or dict
        Mapping file (module docstring) or the parsed mapping.
    vehicle : preset name, YAML path or VehicleParams, optional
        Overrides the mapping's ``vehicle``; one of the two is required.

    Returns
    -------
    Drive
        Canonical columns in SI units, the ``keep`` columns as extras;
        ``meta.extra['mapping']`` records the mapping used.
    """
    m = load_mapping(mapping_yaml)
    p = Path(csv_path)
    if not p.is_file():
        raise ValueError(f"no such file: {p}")
    veh = map_vehicle(m, vehicle, "read_mapped", "mapping")
    try:
        src = read_csv_exact(p)
    except pd.errors.EmptyDataError:
        raise ValueError(f"{p.name} is empty") from None
    out: dict[str, np.ndarray] = {}
    for target, entry in m["columns"].items():
        col = str(entry["column"])
        if col not in src.columns:
            raise ValueError(
                f"{p.name}: source column {col!r} (for {target!r}) not found; "
                f"present: {list(src.columns)}"
            )
        if not pd.api.types.is_numeric_dtype(src[col]):
            raise ValueError(f"{p.name}: source column {col!r} (for {target!r}) is not numeric")
        factor = UNITS[str(entry["unit"])][1] * float(entry.get("sign", 1)) * float(entry.get("scale", 1.0))
        out[target] = src[col].to_numpy(float) * factor
    extra_cols = {}
    for col in m.get("keep", []):
        if col not in src.columns:
            raise ValueError(f"{p.name}: column {col!r} listed in 'keep' not found")
        if col in out:
            raise ValueError(f"{p.name}: kept column {col!r} clashes with a canonical column")
        extra_cols[col] = src[col].to_numpy()
    df = pd.DataFrame({**out, **extra_cols})
    t_offset = 0.0
    if m.get("time_zero", False) and len(df):
        t_offset = float(df["t"].iloc[0])
        df["t"] = df["t"] - t_offset
    order = [c for c in SIGNAL_COLUMNS if c in df.columns] + list(extra_cols)
    extra = {
        "format": "mapped",
        "mapping": {k: dict(v) for k, v in m["columns"].items()},
        "t_offset_s": t_offset,
    }
    try:
        return Drive.from_frame(df[order], veh, source=str(p), extra=extra)
    except DriveValidationError as exc:  # name the file, as the other readers do
        raise DriveValidationError(f"{p.name}: {exc}") from None
