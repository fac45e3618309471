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
``*_true``          ...     simulator truth (``vy_true``, ``alpha_f_true``, ...)
``Fyf_true`` ...    N       true axle forces
``surface``         -       label of the true surface under the vehicle
==================  ======  ==============================================

Extra columns are kept, ignored by the estimators and listed by ``roadgrip info``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from roadgrip.tire import FrictionModel, model_from_dict
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "SIGNAL_COLUMNS",
    "TRUTH_COLUMNS",
    "WHEEL_COLUMNS",
    "Drive",
    "DriveMeta",
    "DriveValidationError",
    "validate_frame",
]

WHEEL_COLUMNS = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
SIGNAL_COLUMNS = ("t", "ax", "ay", "yaw_rate", "steer", "vx", *WHEEL_COLUMNS, "x", "y", "psi")
TRUTH_COLUMNS = (
    "vx_true",
    "vy_true",
    "yaw_rate_true",
    "alpha_f_true",
    "alpha_r_true",
    "kappa_fl_true",
    "kappa_fr_true",
    "kappa_rl_true",
    "kappa_rr_true",
    "mu_true",
    "Fxf_true",
    "Fxr_true",
    "Fyf_true",
    "Fyr_true",
    "Fzf_true",
    "Fzr_true",
    "util_f_true",
    "util_r_true",
    "surface",
)

# Plausibility limits used to catch unit mistakes. They are generous on purpose:
# a road vehicle (or a small racing car) does not sustain them.
_MAX_ACCEL = 60.0  # m/s², about 6 g
_MAX_YAW_RATE = 10.0  # rad/s, about 570 deg/s
_MAX_STEER = 1.2  # rad, about 69 deg road-wheel angle


class DriveValidationError(ValueError):
    """A drive fails validation; the message names the column and the problem."""


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
) -> None:
    """Check a frame of canonical signals; raise :class:`DriveValidationError`.

    Checks, in order: empty frame; missing ``required`` columns; non-numeric
    signal columns; NaN or inf in any numeric canonical column; time not
    strictly increasing (duplicates and reversals reported separately); and,
    with ``check_units``, units that look wrong (accelerations in g, rates in
    deg/s, steering in degrees).

    Parameters
    ----------
    df : DataFrame
        Canonical columns; others are ignored.
    required : tuple of str
        Columns that must be present.
    check_units : bool
        Run the unit plausibility checks.
    """
    if len(df) == 0:
        raise DriveValidationError("drive is empty: no samples")
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise DriveValidationError(
            f"missing required column(s) {missing}; present: {list(df.columns)}"
        )
    t = df["t"].to_numpy(dtype=float) if "t" in df.columns else None
    for col in (*SIGNAL_COLUMNS, *TRUTH_COLUMNS):
        if col not in df.columns or col == "surface":
            continue
        if not pd.api.types.is_numeric_dtype(df[col]):
            raise DriveValidationError(f"column {col!r} is not numeric (dtype {df[col].dtype})")
        v = df[col].to_numpy(dtype=float)
        bad = ~np.isfinite(v)
        if bad.any():
            raise DriveValidationError(
                f"column {col!r} has {int(bad.sum())} NaN/inf value(s), first at {_first_bad(t, bad)}"
            )
    if t is not None and len(t) > 1:
        d = np.diff(t)
        if (d == 0).any():
            raise DriveValidationError(
                f"time column 't' has duplicated timestamps, first at {_first_bad(t[1:], d == 0)}"
            )
        if (d < 0).any():
            raise DriveValidationError(
                f"time column 't' is not increasing: it goes backwards at {_first_bad(t[1:], d < 0)}"
            )
    if check_units:
        _check_units(df)


def _pose_speed(df: pd.DataFrame) -> np.ndarray | None:
    """Speed over ground [m/s] from the pose ``x, y`` (central differences), or None.

    None where the frame has no pose, its time is not increasing or the pose
    does not move (a pose that never changes carries no speed).
    """
    if not {"x", "y", "t"} <= set(df.columns) or len(df) < 3:
        return None
    t = df["t"].to_numpy(float)
    if not np.all(np.diff(t) > 0):
        return None
    x, y = df["x"].to_numpy(float), df["y"].to_numpy(float)
    v = np.hypot(np.gradient(x, t), np.gradient(y, t))
    return v if np.max(v) > 0.5 else None


def _check_units(df: pd.DataFrame) -> None:
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
    # Consistency of ay with vx * yaw_rate in steady cornering: catches ay in g and
    # yaw rate in deg/s even when their magnitudes alone look plausible.
    # The speed comes from the pose where the frame has one: wheel or driveshaft
    # speeds include wheel spin (a drifting car's encoder can read several times
    # the true speed), which would make a valid ay look like g.
    speed = _pose_speed(df)
    if speed is None and "vx" in cols:
        speed = df["vx"].to_numpy(float)
    if speed is not None and {"ay", "yaw_rate"} <= set(cols) and len(df) >= 20:
        ay = df["ay"].to_numpy(float)
        kin = speed * df["yaw_rate"].to_numpy(float)
        sel = np.abs(kin) > 1.0
        if sel.sum() >= 20:
            ratio = float(np.dot(ay[sel], kin[sel]) / np.dot(kin[sel], kin[sel]))
            if 0.05 < ratio < 0.2:
                raise DriveValidationError(
                    f"column 'ay' is about {ratio:.3f} x vx*yaw_rate in turns: ay looks like it "
                    "is in g, expected m/s²"
                )
            if 0.005 < ratio < 0.035:
                raise DriveValidationError(
                    f"'ay' is about {ratio:.4f} x vx*yaw_rate in turns: yaw_rate looks like "
                    "deg/s, expected rad/s"
                )
    # Consistency of ax with the derivative of vx while accelerating or braking:
    # catches ax in g. Only where the two correlate clearly (noisy or spinning-wheel
    # speeds give no verdict).
    if speed is not None and {"ax", "t"} <= set(cols) and len(df) >= 200:
        t = df["t"].to_numpy(float)
        if np.all(np.diff(t) > 0):
            # central difference over about 0.5 s, robust to speed-sensor noise
            w = max(1, int(0.25 / float(np.median(np.diff(t)))))
            vx = speed
            ax = df["ax"].to_numpy(float)[w:-w]
            a_kin = (vx[2 * w:] - vx[:-2 * w]) / (t[2 * w:] - t[:-2 * w])
            sel = np.abs(a_kin) > 0.5
            if sel.sum() >= 20 and np.std(ax[sel]) > 0 and np.std(a_kin[sel]) > 0:
                corr = float(np.corrcoef(ax[sel], a_kin[sel])[0, 1])
                ratio = float(np.dot(ax[sel], a_kin[sel]) / np.dot(a_kin[sel], a_kin[sel]))
                if corr > 0.5 and 0.05 < ratio < 0.2:
                    raise DriveValidationError(
                        f"column 'ax' is about {ratio:.3f} x d(vx)/dt while accelerating: ax "
                        "looks like it is in g, expected m/s²"
                    )


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
        """Validate ``df`` (see :func:`validate_frame`) and wrap it."""
        validate_frame(df, required, check_units=check_units)
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
