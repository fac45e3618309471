"""Canonical CSV and Parquet drive files.

A canonical CSV is what :meth:`roadgrip.drive.Drive.to_csv` writes: one line
``# roadgrip-meta <json>`` with the :class:`~roadgrip.drive.DriveMeta`, then a
header and the columns in SI units and ISO 8855 axes. A plain CSV without the
meta line is accepted too, in which case the vehicle must be given. Parquet
files carry the metadata in the schema under the key ``roadgrip``.

Reading is lossless: CSV floats are parsed with ``float_precision='round_trip'``
(the writer emits 17 significant digits) and Parquet stores float64 as is.
Extra columns are kept.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pandas as pd

from roadgrip.drive import Drive, DriveMeta, validate_frame
from roadgrip.vehicle.params import VehicleParams

__all__ = ["META_PREFIX", "read_canonical_csv", "read_canonical_parquet"]

META_PREFIX = "# roadgrip-meta "
"""First line of a canonical CSV, followed by the metadata as JSON."""


def _finish(
    df: pd.DataFrame, meta: DriveMeta | None, vehicle: VehicleParams | None, path: Path
) -> Drive:
    if meta is None:
        if vehicle is None:
            raise ValueError(
                f"{path.name} has no roadgrip metadata: pass the vehicle "
                "(--vehicle PRESET or YAML file)"
            )
        return Drive.from_frame(df, vehicle, source=str(path))
    validate_frame(df, ("t",))
    if vehicle is not None:
        meta = replace(meta, vehicle=vehicle)
    return Drive(df.reset_index(drop=True), meta)


def read_canonical_csv(path: str | Path, vehicle: VehicleParams | None = None) -> Drive:
    """Read a canonical CSV drive.

    Parameters
    ----------
    path : str or Path
        CSV file, with or without the ``# roadgrip-meta`` line.
    vehicle : VehicleParams, optional
        Overrides the vehicle of the metadata; required without metadata.

    Returns
    -------
    Drive
    """
    path = Path(path)
    with open(path, newline="") as fh:
        first = fh.readline()
        meta = None
        if first.startswith(META_PREFIX):
            try:
                meta = DriveMeta.from_json(first[len(META_PREFIX):])
            except (ValueError, KeyError, TypeError) as exc:
                raise ValueError(f"{path.name}: unreadable roadgrip metadata line: {exc}") from None
        else:
            fh.seek(0)
        try:
            df = pd.read_csv(fh, float_precision="round_trip")
        except pd.errors.EmptyDataError:
            raise ValueError(f"{path.name} is empty: no header and no samples") from None
    if "surface" in df.columns:
        df["surface"] = df["surface"].astype(str)
    return _finish(df, meta, vehicle, path)


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
    md = table.schema.metadata or {}
    meta = DriveMeta.from_json(md[b"roadgrip"].decode()) if b"roadgrip" in md else None
    df = table.to_pandas()
    return _finish(df, meta, vehicle, path)
