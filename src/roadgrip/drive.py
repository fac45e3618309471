"""The canonical :class:`Drive` container: signals, optional truth, metadata.

Units are SI and axes ISO 8855 (x forward, y left, z up, yaw positive
counter-clockwise). Column names:

==================  ======  ==============================================
column              unit    meaning
==================  ======  ==============================================
``t``               s       time, strictly increasing
``ax``, ``ay``      m/s²    accelerometer specific force at the CG, body axes
``yaw_rate``        rad/s   gyro
``steer``           rad     front road-wheel angle
``vx``              m/s     longitudinal speed (measured or upstream estimate)
``omega_fl`` ...    rad/s   wheel angular speeds (``fl, fr, rl, rr``)
``x``, ``y``        m       position in a local map frame
``psi``             rad     heading in the map frame
``lat``, ``lon``    deg     optional GNSS WGS84 latitude, longitude (NaN: no fix)
``*_true``          ...     simulator truth (``vy_true``, ``alpha_f_true``, ...)
``Fyf_true`` ...    N       true axle forces
``surface``         -       label of the true surface under the vehicle
==================  ======  ==============================================

Extra columns are kept, ignored by the estimators and listed by ``roadgrip info``.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.drive_units import unit_findings
from roadgrip.tire import FrictionModel, model_from_dict
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "SIGNAL_COLUMNS",
    "SIGNAL_RANGES",
    "TRUTH_COLUMNS",
    "WHEEL_COLUMNS",
    "Drive",
    "DriveMeta",
    "DriveValidationError",
    "DriveWarning",
    "merge_duplicate_times",
    "validate_frame",
]

WHEEL_COLUMNS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
SIGNAL_COLUMNS = ("t", "ax", "ay", "yaw_rate", "steer", "vx", *WHEEL_COLUMNS, "x", "y", "psi")
TRUTH_COLUMNS = (
    "vx_true", "vy_true", "yaw_rate_true", "alpha_f_true", "alpha_r_true", "kappa_fl_true",
    "kappa_fr_true", "kappa_rl_true", "kappa_rr_true", "mu_true", "Fxf_true", "Fxr_true",
    "Fyf_true", "Fyr_true", "Fzf_true", "Fzr_true", "util_f_true", "util_r_true", "surface",
)  # fmt: skip

# Unit-mistake limits, generous: a road vehicle (or a small racing car) does not sustain them.
_MAX_ACCEL = 60.0  # m/s², about 6 g
_MAX_YAW_RATE = 10.0  # rad/s, about 570 deg/s
_MAX_STEER = 1.2  # rad, about 69 deg road-wheel angle

AUX_COLUMNS = ("vx_pose", "vy_pose", "motor_rpm", "lat", "lon")
"""Optional numeric columns some estimators read (pose velocity, motor speed) and the GNSS
position the maps place cells with (WGS84 degrees); NaN marks a sample without a value."""

SIGNAL_RANGES: dict[str, tuple[float, float, str]] = {
    "t": (-1e10, 1e10, "s"), "ax": (-500.0, 500.0, "m/s²"), "ay": (-500.0, 500.0, "m/s²"),
    "yaw_rate": (-100.0, 100.0, "rad/s"), "steer": (-1.5707963, 1.5707963, "rad"),
    "vx": (-200.0, 200.0, "m/s"), **{c: (-1e4, 1e4, "rad/s") for c in WHEEL_COLUMNS},
    "x": (-1e8, 1e8, "m"), "y": (-1e8, 1e8, "m"), "psi": (-1e7, 1e7, "rad"),
    "vx_pose": (-200.0, 200.0, "m/s"), "vy_pose": (-200.0, 200.0, "m/s"),
    "motor_rpm": (-1e6, 1e6, "rpm"), "lat": (-90.0, 90.0, "deg"), "lon": (-180.0, 180.0, "deg"),
}  # fmt: skip
"""Physical range of each numeric signal: ``(low, high, unit)``; values outside are refused.

Wide enough for a 1:10 model car up to a heavy truck and for every recording
convention (unwrapped heading, Unix time in seconds); narrow enough that what
passes keeps every estimator's arithmetic finite. Truth columns must lie
within +-1e9.
"""

_TRUTH_RANGE = 1e9
# Median sample steps [s] that vehicle data can have: 10 kHz to 1 Hz (time in ms at
# 100 Hz has a step of 10).
_MIN_STEP, _MAX_STEP = 1e-4, 1.0


class DriveValidationError(ValueError):
    """A drive fails validation; the message names the column and the problem."""


class DriveWarning(UserWarning):
    """Something in a drive was repaired (duplicated timestamps merged, ...)."""


def merge_duplicate_times(df: pd.DataFrame) -> tuple[pd.DataFrame, int]:
    """Merge consecutive rows that share a timestamp, as loggers write them.

    Such rows with the same ``t`` become one: numeric columns are averaged,
    other columns keep the last value. Time that goes backwards is left for
    :func:`validate_frame` to refuse. Returns the merged frame (``df`` itself when
    nothing was merged) and the number of rows removed.
    """
    if "t" not in df.columns or len(df) < 2 or df.columns.duplicated().any() or (
            df["t"].dtype.kind not in "fiu"):
        return df, 0
    t = df["t"].to_numpy(float)
    dup = np.diff(t) == 0
    if not dup.any():
        return df, 0
    key = np.concatenate([[0], np.cumsum(~dup)])
    last = np.flatnonzero(np.append(~dup, True))  # the last row of each group
    out = df.iloc[last].reset_index(drop=True)
    for c in df.columns:
        if df[c].dtype.kind in "fiub":
            v = df[c].to_numpy(float)
            with np.errstate(over="ignore", invalid="ignore"):
                out[c] = np.bincount(key, v) / np.bincount(key)
    return out, int(dup.sum())


@dataclass(frozen=True)
class DriveMeta:
    """Drive metadata.

    Attributes
    ----------
    vehicle : VehicleParams
        The vehicle that drove it.
    source : str
        Where the data came from (``'sim:snow-slalom'``, a file path, ...).
    sample_rate : float
        Nominal sample rate [Hz] (median of the time steps).
    truth : dict or None
        Simulation truth beyond the columns. Key ``'surfaces'`` maps each
        surface label to ``{'front': tire dict, 'rear': tire dict,
        'front_long': tire dict, 'rear_long': tire dict, 'mu': float}`` (see
        :meth:`roadgrip.tire.MagicFormula.to_dict`); other keys (scenario, seed,
        friction field) are free-form and JSON-serialisable.
    extra : dict
        Anything else, JSON-serialisable (reader notes, column mapping, ...).
    """

    vehicle: VehicleParams
    source: str = "unknown"
    sample_rate: float = float("nan")
    truth: dict[str, Any] | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> str:
        """JSON text; numpy scalars and arrays in ``truth`` / ``extra`` become numbers and lists."""
        return json.dumps(
            {
                "vehicle": self.vehicle.to_dict(),
                "source": self.source,
                "sample_rate": self.sample_rate,
                "truth": self.truth,
                "extra": self.extra,
            },
            default=_json_default,
        )

    @classmethod
    def from_json(cls, text: str) -> DriveMeta:
        d = json.loads(text)
        return cls(
            vehicle=VehicleParams.from_dict(d["vehicle"]),
            source=d.get("source", "unknown"),
            sample_rate=float(d.get("sample_rate", float("nan"))),
            truth=d.get("truth"),
            extra=d.get("extra") or {},
        )


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    raise TypeError(f"metadata value of type {type(obj).__name__} is not JSON-serialisable")


def _first_bad(t: np.ndarray, mask: np.ndarray) -> str:
    i = int(np.flatnonzero(mask)[0])
    return f"row {i} (t = {t[i]:.6g} s)" if t is not None and i < len(t) else f"row {i}"


def validate_frame(
    df: pd.DataFrame,
    required: tuple[str, ...] = ("t",),
    *,
    check_units: bool = True,
    vehicle: VehicleParams | None = None,
) -> None:
    """Check a frame of canonical signals; raise :class:`DriveValidationError`.

    Checks, in order: empty frame; duplicated column names; missing ``required``
    columns; non-numeric (text, complex) signal columns; NaN or inf in any
    numeric canonical column; values outside :data:`SIGNAL_RANGES` (column,
    value, row and range named); a time base whose step is implausible for
    vehicle data (milliseconds, microseconds or nanoseconds, with the evidence);
    time not strictly increasing (duplicates and reversals reported separately;
    :meth:`Drive.from_frame` merges duplicates first); with ``check_units``, magnitudes no
    vehicle reaches and units or signs that the kinematics show conclusively wrong
    (:func:`roadgrip.drive_units.unit_findings`: accelerations in g, rates in deg/s,
    angles in degrees, speeds in km/h, wheel speeds in rpm, flipped signs), with a
    :class:`DriveWarning` where the channels disagree and no single mistake explains it.

    Parameters
    ----------
    df : DataFrame
        Canonical columns; others are ignored.
    required : tuple of str
        Columns that must be present.
    check_units : bool
        Run the unit plausibility checks.
    vehicle : VehicleParams, optional
        Wheelbase, wheel radius and driven wheels for the steering and wheel-speed
        checks (left out without it).
    """
    if len(df) == 0:
        raise DriveValidationError("drive is empty: no samples")
    dup_cols = df.columns[df.columns.duplicated()]
    if len(dup_cols):
        raise DriveValidationError(f"duplicated column name {dup_cols[0]!r}: each column must "
                                   "appear once")
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DriveValidationError(
            f"missing required column(s) {missing}; present: {list(df.columns)}"
        )
    t = None
    for col in (*SIGNAL_COLUMNS, *AUX_COLUMNS, *TRUTH_COLUMNS):
        if col not in df.columns or col == "surface":
            continue
        kind = df[col].dtype.kind
        if not pd.api.types.is_numeric_dtype(df[col]) or kind == "c":
            what = "complex" if kind == "c" else "not numeric"
            raise DriveValidationError(f"column {col!r} is {what} (dtype {df[col].dtype}): "
                                       f"expected real numbers{_first_text(df[col])}")
        v = df[col].to_numpy(dtype=float)
        if col == "t":
            t = v
        # the auxiliary columns mark samples without a value by NaN
        bad = np.isinf(v) if col in AUX_COLUMNS else ~np.isfinite(v)
        if bad.any():
            raise DriveValidationError(
                f"column {col!r} has {int(bad.sum())} NaN/inf value(s), first at {_first_bad(t, bad)}"
            )
    if check_units:
        _check_magnitudes(df)
    _check_ranges(df, t)
    if t is not None and len(t) > 2:
        _check_time_step(t)
    if t is not None and len(t) > 1:
        d = np.diff(t)
        if (d == 0).any():
            raise DriveValidationError(f"time column 't' has duplicated timestamps, first at "
                                       f"{_first_bad(t[1:], d == 0)}")
        if (d < 0).any():
            raise DriveValidationError(f"time column 't' is not increasing: it goes backwards at "
                                       f"{_first_bad(t[1:], d < 0)}")
    if check_units:
        _check_units(df, vehicle)


def _check_ranges(df: pd.DataFrame, t: np.ndarray | None) -> None:
    """Refuse values outside :data:`SIGNAL_RANGES`, naming column, value, row and range."""
    for col in (*SIGNAL_COLUMNS, *AUX_COLUMNS, *TRUTH_COLUMNS):
        if col not in df.columns or col == "surface":
            continue
        v = df[col].to_numpy(dtype=float)
        lo, hi, unit = SIGNAL_RANGES.get(col, (-_TRUTH_RANGE, _TRUTH_RANGE, "SI"))
        out = (v < lo) | (v > hi)
        if out.any():
            i = int(np.flatnonzero(out)[0])
            hint = _time_unit_hint(v) if col == "t" else ""
            raise DriveValidationError(f"column {col!r} has {int(out.sum())} value(s) outside its "
                                       f"physical range [{lo:g}, {hi:g}] {unit}, first {v[i]:.6g} at "
                                       f"{_first_bad(t, out)}{hint}")


def _first_text(col: pd.Series) -> str:
    """``', e.g. 'abc' at row 3'``: the first value that is not a real number, or ''."""
    bad = (pd.to_numeric(col, errors="coerce").isna() & col.notna()).to_numpy()
    if col.dtype.kind == "c" or not bad.any():
        return ""
    i = int(np.flatnonzero(bad)[0])
    return f", e.g. {str(col.iloc[i])[:40]!r} at row {i}"


def _time_unit_hint(t: np.ndarray) -> str:
    with np.errstate(over="ignore", invalid="ignore"):
        d = np.diff(t)
    d = d[d > 0]
    if d.size == 0:
        return ""
    step = float(np.median(d))
    for unit, f in (("ms", 1e3), ("µs", 1e6), ("ns", 1e9)):
        if _MIN_STEP <= step / f <= 1.0:
            return (f"; the median step {step:.6g} would be {step / f:.6g} s in {unit}: divide "
                    f"'t' by {f:g} (time must be in seconds)")
    return f"; the median step is {step:.6g} (time must be in seconds)"


def _check_time_step(t: np.ndarray) -> None:
    """Refuse a time base whose median step no vehicle logger has (ms, µs, ns, ...)."""
    d = np.diff(t)
    d = d[d > 0]
    if d.size < 2:
        return
    step = float(np.median(d))
    if step > _MAX_STEP:
        raise DriveValidationError(
            f"column 't' has a median step of {step:.6g} s over {len(t)} samples: implausible "
            f"for vehicle data (expected {_MIN_STEP:g} to {_MAX_STEP:g} s){_time_unit_hint(t)}"
        )
    if step < _MIN_STEP:
        raise DriveValidationError(
            f"column 't' has a median step of {step:.3g} s ({1 / step:.3g} Hz) over {len(t)} "
            f"samples: implausible for vehicle data (expected {_MIN_STEP:g} to {_MAX_STEP:g} s); "
            "is the time in seconds?"
        )


def _check_magnitudes(df: pd.DataFrame) -> None:
    """Accelerations in g, rates in deg/s, steering in degrees, from their magnitude."""
    cols = df.columns
    for c in ("ax", "ay"):
        if c in cols and np.max(np.abs(df[c].to_numpy(float))) > _MAX_ACCEL:
            raise DriveValidationError(
                f"column {c!r} reaches {np.max(np.abs(df[c])):.3g} m/s²: implausible "
                "acceleration, check the unit (expected m/s²)"
            )
    if "yaw_rate" in cols and np.max(np.abs(df["yaw_rate"].to_numpy(float))) > _MAX_YAW_RATE:
        raise DriveValidationError(
            f"column 'yaw_rate' reaches {np.max(np.abs(df['yaw_rate'])):.3g}: this looks like "
            "deg/s, expected rad/s"
        )
    if "steer" in cols and np.max(np.abs(df["steer"].to_numpy(float))) > _MAX_STEER:
        raise DriveValidationError(
            f"column 'steer' reaches {np.max(np.abs(df['steer'])):.3g}: this looks like degrees "
            "or a steering-wheel angle, expected the road-wheel angle in rad"
        )


def _check_units(df: pd.DataFrame, vehicle: VehicleParams | None) -> None:
    """Refuse what the kinematics show conclusively in a wrong unit or sign; warn where
    they disagree unexplained (:func:`roadgrip.drive_units.unit_findings`)."""
    kw = {}
    if vehicle is not None:
        from roadgrip.vehicle.params import driven_wheels

        kw = {"wheelbase": vehicle.wheelbase, "wheel_radius": vehicle.wheel_radius,
              "driven": tuple(bool(b) for b in driven_wheels(vehicle.drive))}
    for finding in unit_findings(df, **kw):
        if finding.status == "wrong":
            raise DriveValidationError(finding.message)
        warnings.warn(finding.message, DriveWarning, stacklevel=4)


def _merged(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """:func:`merge_duplicate_times` with a :class:`DriveWarning` naming what was merged."""
    out, n = merge_duplicate_times(df)
    if n:
        t = df["t"].to_numpy(float)
        first = float(t[1:][np.diff(t) == 0][0])
        warnings.warn(f"{source}: {n} row(s) with a duplicated timestamp in 't' merged into the "
                      f"row of the same time (numeric columns averaged), first at t = {first:.6g} s",
                      DriveWarning, stacklevel=3)
    return out


@dataclass(frozen=True)
class Drive:
    """A drive: a time-indexed frame of canonical columns plus :class:`DriveMeta`.

    Construct through :meth:`from_frame` (validates) or the readers in
    :mod:`roadgrip.io`. The frame is not copied on access; treat it as read-only.

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from roadgrip.vehicle import PRESETS
    >>> df = pd.DataFrame({"t": np.arange(3) * 0.01, "ay": [0.0, 0.1, 0.2]})
    >>> d = Drive.from_frame(df, PRESETS["sedan"], source="example")
    >>> d.n, round(d.meta.sample_rate)
    (3, 100)
    """

    data: pd.DataFrame
    meta: DriveMeta

    # -- construction ----------------------------------------------------------------
    @classmethod
    def from_frame(
        cls,
        df: pd.DataFrame,
        vehicle: VehicleParams,
        *,
        source: str = "unknown",
        truth: dict[str, Any] | None = None,
        extra: dict[str, Any] | None = None,
        required: tuple[str, ...] = ("t",),
        check_units: bool = True,
    ) -> Drive:
        """Validate ``df`` (see :func:`validate_frame`) and wrap it.

        Consecutive rows sharing a timestamp, which loggers write, are merged
        first (:func:`merge_duplicate_times`: numeric columns averaged, text
        columns keep the last value) with a :class:`DriveWarning`.
        """
        df = _merged(df, source)
        validate_frame(df, required, check_units=check_units, vehicle=vehicle)
        df = df.reset_index(drop=True)
        t = df["t"].to_numpy(float)
        rate = float(1.0 / np.median(np.diff(t))) if len(t) > 1 else float("nan")
        meta = DriveMeta(vehicle, source, rate, truth, dict(extra or {}))
        return cls(df, meta)

    def with_data(self, df: pd.DataFrame) -> Drive:
        """Same metadata, new frame (validated)."""
        validate_frame(df, ("t",), check_units=False)
        return Drive(df.reset_index(drop=True), self.meta)

    # -- access ------------------------------------------------------------------------
    @property
    def n(self) -> int:
        return len(self.data)

    @property
    def t(self) -> np.ndarray:
        """Time [s], shape (n,)."""
        return self.data["t"].to_numpy(float)

    @property
    def duration(self) -> float:
        t = self.t
        return float(t[-1] - t[0]) if len(t) else 0.0

    @property
    def vehicle(self) -> VehicleParams:
        return self.meta.vehicle

    @property
    def has_truth(self) -> bool:
        return self.meta.truth is not None

    @property
    def has_wheel_speeds(self) -> bool:
        return all(c in self.data.columns for c in WHEEL_COLUMNS)

    @property
    def has_pose(self) -> bool:
        return all(c in self.data.columns for c in ("x", "y", "psi"))

    def has(self, *cols: str) -> bool:
        return all(c in self.data.columns for c in cols)

    def col(self, name: str) -> np.ndarray:
        """A column as a float array; a clear error when absent."""
        if name not in self.data.columns:
            raise DriveValidationError(f"drive from {self.meta.source} has no column {name!r}")
        return self.data[name].to_numpy(float)

    def require(self, *cols: str, why: str = "") -> None:
        missing = [c for c in cols if c not in self.data.columns]
        if missing:
            suffix = f" ({why})" if why else ""
            raise DriveValidationError(
                f"drive from {self.meta.source} lacks required column(s) {missing}{suffix}"
            )

    @property
    def extra_columns(self) -> list[str]:
        known = set(SIGNAL_COLUMNS) | set(TRUTH_COLUMNS)
        return [c for c in self.data.columns if c not in known]

    def slice_time(self, t0: float, t1: float) -> Drive:
        """Samples with ``t0 <= t < t1``."""
        t = self.t
        return Drive(self.data[(t >= t0) & (t < t1)].reset_index(drop=True), self.meta)

    # -- truth -------------------------------------------------------------------------
    def true_tire(
        self, axle: str = "front", direction: str = "lateral", surface: str | None = None
    ) -> FrictionModel:
        """The true friction curve of a simulated drive.

        Parameters
        ----------
        axle : {'front', 'rear'}
        direction : {'lateral', 'longitudinal'}
        surface : str, optional
            Surface label; default the surface under the vehicle for most of the drive.
        """
        if not self.meta.truth or "surfaces" not in self.meta.truth:
            raise DriveValidationError(f"drive from {self.meta.source} carries no true tire model")
        surfaces = self.meta.truth["surfaces"]
        if surface is None:
            if "surface" in self.data.columns:
                surface = str(self.data["surface"].mode().iloc[0])
            else:
                surface = next(iter(surfaces))
        if surface not in surfaces:
            raise DriveValidationError(f"unknown surface {surface!r}; drive has {sorted(surfaces)}")
        if axle not in ("front", "rear"):
            raise ValueError(f"axle must be 'front' or 'rear', got {axle!r}")
        key = axle if direction == "lateral" else f"{axle}_long"
        if key not in surfaces[surface]:
            raise DriveValidationError(
                f"drive from {self.meta.source} carries no parametric tire curve for surface "
                f"{surface!r} (its truth curve is binned from the truth columns: "
                "roadgrip.truth)"
            )
        return model_from_dict(surfaces[surface][key])

    # -- files -------------------------------------------------------------------------
    def to_parquet(self, path: str | Path) -> None:
        """Write Parquet with the metadata in the schema (lossless)."""
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pa.Table.from_pandas(self.data, preserve_index=False)
        md = dict(table.schema.metadata or {})
        md[b"roadgrip"] = self.meta.to_json().encode()
        pq.write_table(table.replace_schema_metadata(md), str(path))

    def to_csv(self, path: str | Path) -> None:
        """Write CSV: one ``# roadgrip-meta <json>`` line, then the columns.

        Floats are written with 17 significant digits, so reading back is lossless.
        The meta line also records each column's dtype (key ``dtypes``), so that
        integer-valued float columns come back as floats.
        """
        meta = json.loads(self.meta.to_json())
        meta["dtypes"] = {str(c): str(dt) for c, dt in self.data.dtypes.items()}
        with open(path, "w", newline="") as fh:
            fh.write("# roadgrip-meta " + json.dumps(meta) + "\n")
            self.data.to_csv(fh, index=False, float_format="%.17g")

    def save(self, path: str | Path) -> None:
        """Write by extension: ``.parquet`` / ``.pq`` or ``.csv``."""
        p = Path(path)
        if p.suffix.lower() in (".parquet", ".pq"):
            self.to_parquet(p)
        elif p.suffix.lower() == ".csv":
            self.to_csv(p)
        else:
            raise ValueError(f"cannot tell the format of {p.name!r}: use .parquet or .csv")
