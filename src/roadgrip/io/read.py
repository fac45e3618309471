"""``read_drive``: one entry point for every drive file and data set."""

from __future__ import annotations

from pathlib import Path

from roadgrip.drive import Drive
from roadgrip.io.can import CAN_LOG_SUFFIXES
from roadgrip.io.canonical import read_canonical_csv, read_canonical_parquet
from roadgrip.io.dart import is_dart_csv, read_dart
from roadgrip.io.frictionmaps import is_frictionmaps_dir, read_frictionmaps
from roadgrip.io.rosbag import BAG_SUFFIXES, is_rosbag
from roadgrip.vehicle.params import VehicleParams, load_vehicle

__all__ = ["FORMATS", "detect_format", "read_drive"]

MDF_SUFFIXES = (".mf4", ".mdf")
"""File suffixes read as ASAM MDF (:mod:`roadgrip.io.mdf`)."""

FORMATS = ("canonical", "dart", "frictionmaps", "rosbag", "mdf", "can")
"""Accepted values of ``format``."""


def detect_format(path: str | Path) -> str:
    """Tell the format of ``path``.

    A folder containing ``imuData.csv`` (or a file inside one) is
    ``'frictionmaps'``; a ``.bag`` / ``.mcap`` / ``.db3`` file or a folder holding
    ``metadata.yaml`` is ``'rosbag'``; an ``.mf4`` / ``.mdf`` file is ``'mdf'``; a CSV whose header names ``elapsed time sensors`` is
    ``'dart'``; any other ``.csv`` / ``.parquet`` / ``.pq`` file is ``'canonical'``.

    Raises
    ------
    ValueError
        Missing path, empty file, or a format that cannot be told.
    """
    p = Path(path)
    if not p.exists():
        raise ValueError(f"no such file or folder: {p}")
    if p.is_dir():
        if is_frictionmaps_dir(p):
            return "frictionmaps"
        if is_rosbag(p):
            return "rosbag"
        raise ValueError(
            f"cannot tell the format of folder {p}: a frictionmaps run folder contains "
            "imuData.csv, a ROS 2 bag folder metadata.yaml; otherwise give a file"
        )
    if p.stat().st_size == 0:
        raise ValueError(f"{p} is empty")
    if p.name in ("imuData.csv", "odomData.csv", "commandData.csv", "pfPoseData.csv") and (
        is_frictionmaps_dir(p.parent)
    ):
        return "frictionmaps"
    suffix = p.suffix.lower()
    if suffix in BAG_SUFFIXES:
        return "rosbag"
    if suffix in MDF_SUFFIXES:
        return "mdf"
    if suffix in CAN_LOG_SUFFIXES:
        return "can"
    if suffix in (".parquet", ".pq"):
        return "canonical"
    if suffix == ".csv":
        return "dart" if is_dart_csv(p) else "canonical"
    if suffix in (".gz", ".bz2", ".xz", ".zst") and Path(p.stem).suffix.lower() == ".csv":
        return "canonical"  # a compressed canonical CSV (the reader detects the compression by content)
    raise ValueError(
        f"cannot tell the format of {p.name!r}: expected .csv, .parquet, "
        f"{', '.join(BAG_SUFFIXES + MDF_SUFFIXES)}, or pass "
        f"--format ({'|'.join(FORMATS)})"
    )


def read_drive(
    path: str | Path,
    format: str | None = None,
    vehicle: str | Path | VehicleParams | None = None,
    *,
    topics: str | Path | dict | None = None,
    channels: str | Path | dict | None = None,
    dbc: str | Path | None = None,
) -> Drive:
    """Read a drive: canonical CSV/Parquet, a ROS bag, an MDF4 file, or a shared data set.

    Parameters
    ----------
    path : str or Path
        Canonical ``.csv`` / ``.parquet`` file, a ROS bag (``.bag``, ``.mcap``,
        ``.db3`` or a ROS 2 bag folder), an ASAM MDF4 file (``.mf4``), a DART run
        CSV, or a frictionmaps ``DSn`` folder.
    format : {None, 'canonical', 'dart', 'frictionmaps', 'rosbag', 'mdf'}
        ``None`` detects it (:func:`detect_format`).
    vehicle : preset name, YAML path or VehicleParams, optional
        Overrides the file's vehicle. Required for a plain CSV without roadgrip
        metadata; the data-set readers default to ``'jetracer'`` (dart) and
        ``'f1tenth'`` (frictionmaps); the bag and MDF readers to their map's
        ``vehicle``. A YAML file's ``calibration:`` (``roadgrip vehicle fit``
        writes it) is applied to the sensor columns
        (:func:`roadgrip.io.calibration.apply_calibration`; recorded in
        ``meta.extra['calibration']``).
    topics : YAML path, shipped map name or dict, optional
        ROS bags: the topic map (:mod:`roadgrip.io.rosbag`); default the shipped
        ``'f1tenth'`` map.
    channels : YAML path or dict
        MDF4 files: the channel map (:mod:`roadgrip.io.mdf`); required. CAN logs: the
        signal map (:mod:`roadgrip.io.can`; default the shipped one).
    dbc : str or Path, optional
        CAN logs (``.blf``, ``.asc``, ``.trc``, format ``'can'``): the DBC; required.

    Returns
    -------
    Drive

    Raises
    ------
    ValueError
        With a one-line message: missing or empty file, unknown format, missing
        vehicle, or failed validation (:class:`~roadgrip.drive.DriveValidationError`).
    """
    drive = _read(Path(path), format, vehicle, topics, channels, dbc)
    if isinstance(vehicle, str | Path):
        from roadgrip.io.calibration import apply_calibration, read_calibration

        drive = apply_calibration(drive, read_calibration(vehicle))
    return drive


def _read(p: Path, format: str | None, vehicle: str | Path | VehicleParams | None,
          topics: str | Path | dict | None, channels: str | Path | dict | None, dbc: str | Path | None) -> Drive:
    """:func:`read_drive` without the calibration."""
    if format is not None and format not in FORMATS:
        raise ValueError(f"unknown format {format!r}; expected one of {', '.join(FORMATS)}")
    if not p.exists():
        raise ValueError(f"no such file or folder: {p}")
    fmt = format or detect_format(p)
    if topics is not None and fmt != "rosbag":
        raise ValueError(f"a topic map applies to ROS bags only, not to format {fmt!r}")
    if channels is not None and fmt not in ("mdf", "can"):
        raise ValueError(f"a channel map applies to MDF4 files and CAN logs only, not to format {fmt!r}")
    if dbc is not None and fmt != "can":
        raise ValueError(f"a DBC applies to CAN logs only, not to format {fmt!r}")
    veh = load_vehicle(vehicle) if vehicle is not None else None
    if fmt == "rosbag":
        from roadgrip.io.rosbag import read_rosbag

        return read_rosbag(p, topics if topics is not None else "f1tenth", veh)
    if fmt == "mdf":
        from roadgrip.io.mdf import read_mdf

        if channels is None:
            raise ValueError("an MDF4 file needs a channel map (--channels channels.yaml)")
        return read_mdf(p, channels, veh)
    if fmt == "can":
        from roadgrip.io.can import read_can_log

        if dbc is None:
            raise ValueError("a CAN log needs a DBC (--dbc FILE)")
        return read_can_log(p, dbc, channels, veh)
    if fmt == "dart":
        return read_dart(p, veh)
    if fmt == "frictionmaps":
        return read_frictionmaps(p, veh)
    if p.is_dir():
        raise ValueError(f"{p} is a folder; a canonical drive is a .csv or .parquet file")
    if p.stat().st_size == 0:
        raise ValueError(f"{p} is empty")
    if p.suffix.lower() in (".parquet", ".pq"):
        return read_canonical_parquet(p, veh)
    return read_canonical_csv(p, veh)
