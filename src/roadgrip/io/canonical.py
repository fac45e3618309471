"""Canonical CSV and Parquet drive files.

A canonical CSV is what :meth:`roadgrip.drive.Drive.to_csv` writes: one line
``# roadgrip-meta <json>`` with the :class:`~roadgrip.drive.DriveMeta`, then a
header and the columns in SI units and ISO 8855 axes. A plain CSV without the
meta line is accepted too, in which case the vehicle must be given. Parquet
files carry the metadata in the schema under the key ``roadgrip``.

Reading is lossless: CSV floats are parsed exactly (the writer emits 17
significant digits; ``float_precision='round_trip'`` on pandas < 3, the default
parser from pandas 3), column dtypes are restored from the meta line, and
Parquet stores float64 as is. Extra columns are kept.

What real loggers write is read (:mod:`roadgrip.io._csv`): gzip, bzip2, xz or
zstd compression told by the content whatever the name, a UTF-8 byte-order mark,
UTF-16, ``#`` comment lines anywhere, ``;`` or tab delimiters, a decimal comma
(``decimal=','``) or thousands separator (``thousands=','``) where stated. Rows
without a time are dropped, and consecutive rows sharing a timestamp are merged
into one (numeric columns averaged, text columns keep the last value), each with
a warning naming the line or time. Anything else is refused in one line naming
the file, the line and the column.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace
from pathlib import Path

import pandas as pd

from roadgrip.drive import (
    SIGNAL_COLUMNS,
    TRUTH_COLUMNS,
    Drive,
    DriveMeta,
    DriveValidationError,
    DriveWarning,
    merge_duplicate_times,
    validate_frame,
)
from roadgrip.io._csv import read_table, read_text
from roadgrip.vehicle.params import VehicleParams

__all__ = ["META_PREFIX", "parquet_meta", "read_canonical_csv", "read_canonical_parquet"]

META_PREFIX = "# roadgrip-meta "
"""First line of a canonical CSV, followed by the metadata as JSON."""

_FLOAT_COLUMNS = frozenset(SIGNAL_COLUMNS + TRUTH_COLUMNS) - {"surface"}


def _finish(
    df: pd.DataFrame, meta: DriveMeta | None, vehicle: VehicleParams | None, path: Path
) -> Drive:
    """Validate and wrap; a validation error is prefixed with the file's name."""
    try:
        return _finish_unnamed(df, meta, vehicle, path)
    except DriveValidationError as exc:
        raise DriveValidationError(f"{path.name}: {exc}") from None


def _finish_unnamed(
    df: pd.DataFrame, meta: DriveMeta | None, vehicle: VehicleParams | None, path: Path
) -> Drive:
    if meta is None:
        if vehicle is None:
            raise ValueError(
                f"{path.name} has no roadgrip metadata: pass the vehicle "
                "(--vehicle PRESET or YAML file)"
            )
        return Drive.from_frame(df, vehicle, source=str(path))
    df, n = merge_duplicate_times(df)
    if n:
        warnings.warn(f"{path.name}: {n} row(s) with a duplicated timestamp in 't' merged into the "
                      "row of the same time (numeric columns averaged)", DriveWarning, stacklevel=3)
    validate_frame(df, ("t",))
    if vehicle is not None:
        meta = replace(meta, vehicle=vehicle)
    return Drive(df.reset_index(drop=True), meta)


def read_canonical_csv(
    path: str | Path,
    vehicle: VehicleParams | None = None,
    *,
    decimal: str = ".",
    thousands: str | None = None,
) -> Drive:
    """Read a canonical CSV drive.

    Parameters
    ----------
    path : str or Path
        CSV file, with or without the ``# roadgrip-meta`` line.
    vehicle : VehicleParams, optional
        Overrides the vehicle of the metadata; required without metadata.
    decimal : str
        Decimal mark (``','`` for a decimal comma; the delimiter is then ``;``).
    thousands : str, optional
        Thousands separator, only where the file uses one.

    Compressed (gzip, bzip2, xz, zstd: told by the content), UTF-8 with a
    byte-order mark and UTF-16 files are read; ``#`` comment lines are skipped.
    Any problem is one line naming the file and line (:class:`TableError`).

    Returns
    -------
    Drive
    """
    path = Path(path)
    text = read_text(path)
    first = text.split("\n", 1)[0]
    meta = None
    dtypes: dict[str, str] = {}
    if first.startswith(META_PREFIX):
        body = first[len(META_PREFIX):]
        meta = _meta(body, path, "line 1")
        dtypes = json.loads(body).get("dtypes")
        if not isinstance(dtypes, dict):
            dtypes = {}
        dtypes = {str(k): str(v) for k, v in dtypes.items()}
    numeric = {c for c in _FLOAT_COLUMNS if dtypes.get(c, "float64") != "object"}
    table = read_table(path, text, numeric=numeric, decimal=decimal, thousands=thousands,
                       skip_first=meta is not None)
    return _finish(_restore_dtypes(table.frame, dtypes), meta, vehicle, path)


def _restore_dtypes(df: pd.DataFrame, dtypes: dict[str, str]) -> pd.DataFrame:
    """Cast columns back to their recorded dtypes; canonical numeric columns to float64.

    A float column whose values are all integers is written without a decimal
    point and would otherwise be read back as int64.
    """
    for c in df.columns:
        want = dtypes.get(c)
        if c == "surface":
            df[c] = df[c].astype(str)
        elif want is not None and want != str(df[c].dtype):
            try:
                df[c] = df[c].astype(want)
            except (TypeError, ValueError):
                pass  # leave as parsed; validation reports a non-numeric canonical column
        elif want is None and c in _FLOAT_COLUMNS and df[c].dtype.kind in "iu":
            df[c] = df[c].astype(float)
    return df


def read_canonical_parquet(path: str | Path, vehicle: VehicleParams | None = None) -> Drive:
    """Read a canonical Parquet drive (metadata from the schema key ``roadgrip``).

    Parameters
    ----------
    path : str or Path
    vehicle : VehicleParams, optional
        Overrides the vehicle of the metadata; required without metadata.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    try:
        table = pq.read_table(str(path))
    except (pa.ArrowInvalid, OSError) as exc:
        raise ValueError(f"{path.name} is not a readable Parquet file: {exc}") from None
    meta = parquet_meta(table.schema.metadata, path)
    try:
        df = table.to_pandas()
    except (pa.ArrowException, ValueError, TypeError) as exc:
        raise ValueError(f"{path.name}: columns that cannot be read ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:160]})") from None
    return _finish(df, meta, vehicle, path)


def parquet_meta(schema_metadata: dict[bytes, bytes] | None, path: str | Path) -> DriveMeta | None:
    """The drive metadata of a Parquet file's schema (``None`` where it has none).

    Raises
    ------
    ValueError
        Metadata that does not parse, in one line naming the file.
    """
    md = schema_metadata or {}
    if b"roadgrip" not in md:
        return None
    return _meta(md[b"roadgrip"].decode("utf-8", "replace"), Path(path), "schema key 'roadgrip'")


def _meta(text: str, path: Path, where: str) -> DriveMeta:
    """The metadata, or a one-line error naming the file and where the metadata sits."""
    try:
        meta = DriveMeta.from_json(text)
        _check_truth(meta)
        return meta
    except (ValueError, KeyError, TypeError, AttributeError) as exc:
        msg = " ".join(str(exc).split())[:200]
        raise ValueError(f"{path.name}: unreadable roadgrip metadata ({where}): "
                         f"{type(exc).__name__}: {msg}") from None


def _check_truth(meta: DriveMeta) -> None:
    """The metadata's free-form parts have the types their readers expect."""
    from roadgrip.tire import model_from_dict

    if not isinstance(meta.extra, dict):
        raise TypeError(f"'extra' must be a mapping, got {type(meta.extra).__name__}")
    if not isinstance(meta.source, str):
        raise TypeError(f"'source' must be text, got {type(meta.source).__name__}")
    if meta.truth is None:
        return
    if not isinstance(meta.truth, dict):
        raise TypeError(f"'truth' must be a mapping, got {type(meta.truth).__name__}")
    surfaces = meta.truth.get("surfaces")
    if surfaces is None:
        return
    if not isinstance(surfaces, dict):
        raise TypeError(f"'truth.surfaces' must be a mapping, got {type(surfaces).__name__}")
    for label, entry in surfaces.items():
        if not isinstance(entry, dict):
            raise TypeError(f"'truth.surfaces.{label}' must be a mapping, got {type(entry).__name__}")
        for key in ("front", "rear", "front_long", "rear_long"):
            if key in entry:
                try:
                    model_from_dict(entry[key])
                except Exception as exc:  # any malformed tire description
                    raise ValueError(f"'truth.surfaces.{label}.{key}' is not a tire model "
                                     f"({type(exc).__name__}: {exc})") from None
