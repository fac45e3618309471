"""The sensor calibration a vehicle file carries, and its application to a drive.

``roadgrip vehicle fit`` writes a ``calibration:`` mapping into the vehicle file it
produces (:data:`CALIBRATION`: each sensor's delay against the gyro, the steering's scale
and offset, the accelerometer's biases). :func:`roadgrip.io.read_drive` applies it when it
is given such a file as ``vehicle``, so that the library and the command line read the same
data from the same file; :func:`apply_calibration` applies a mapping to a drive in hand.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from roadgrip.drive import WHEEL_COLUMNS, Drive
from roadgrip.vehicle.params import CALIBRATION_KEY

__all__ = ["CALIBRATION", "apply_calibration", "corrected_yaw_rate", "read_calibration", "shift_columns"]

CALIBRATION: dict[str, tuple[str, float]] = {
    "delay_accelerometer": ("s", 1.0), "delay_accelerometer_x": ("s", 1.0), "delay_speed": ("s", 1.0),
    "delay_pose": ("s", 1.0), "pose_heading_bias": ("rad", 0.5),
    "steer_delay": ("s", 1.0), "steer_scale": ("-", 10.0), "steer_offset": ("rad", 0.5), "ay_bias": ("m/s²", 20.0),
    "ax_bias": ("m/s²", 20.0), "yaw_rate_scale": ("-", 2.0), "yaw_rate_bias": ("rad/s", 0.5),
}  # fmt: skip
"""The sensor calibration a vehicle file carries (``calibration:``): name -> (unit, largest
magnitude). Delays are against the gyro: ``delay_accelerometer`` moves ``ay``, and ``ax``
too unless ``delay_accelerometer_x`` (``a_x``'s own, a separate message on some buses) is
given (a file written before it existed keeps one accelerometer clock); the road-wheel angle
is ``steer_scale steer + steer_offset``; the biases are subtracted; the yaw rate is
``(yaw_rate - yaw_rate_bias) / yaw_rate_scale``; ``delay_pose`` moves the pose (``x, y, psi``
and ``vx_pose, vy_pose``) and ``pose_heading_bias`` is subtracted from ``psi``."""

_DELAYED = {"delay_accelerometer": ("ax", "ay"), "delay_accelerometer_x": ("ax",),
            "steer_delay": ("steer",), "delay_speed": ("vx", *WHEEL_COLUMNS),
            "delay_pose": ("x", "y", "psi", "vx_pose", "vy_pose")}
"""The columns each delay moves; a later entry overrides an earlier one for a column
(``delay_accelerometer_x`` over ``delay_accelerometer`` for ``ax``)."""


def read_calibration(path: str | Path) -> dict[str, float]:
    """The ``calibration`` mapping of a vehicle file (empty when it has none, or when
    ``path`` is not a YAML file: a preset name).

    Raises
    ------
    ValueError
        An unknown key or a value that is not a finite number within its range (named).
    """
    import yaml

    p = Path(path)
    if p.suffix.lower() not in (".yaml", ".yml") or not p.is_file():
        return {}
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8-sig"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError):
        return {}  # load_vehicle names what is wrong with the file
    cal = data.get(CALIBRATION_KEY) if isinstance(data, dict) else None
    if cal is None:
        return {}
    if not isinstance(cal, dict):
        raise ValueError(f"vehicle file {p.name}: '{CALIBRATION_KEY}' must be a mapping, got {cal!r}")
    out = {}
    for k, v in cal.items():
        if k not in CALIBRATION:
            raise ValueError(f"vehicle file {p.name}: unknown calibration {k!r}; known: {sorted(CALIBRATION)}")
        unit, big = CALIBRATION[k]
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or abs(v) > big:
            raise ValueError(f"vehicle file {p.name}: calibration {k!r} = {v!r} must be a number "
                             f"within ±{big:g} {unit}")
        if k in ("steer_scale", "yaw_rate_scale") and v <= 0:
            raise ValueError(f"vehicle file {p.name}: calibration {k!r} = {v!r} must be > 0")
        out[str(k)] = float(v)
    return out


_ANGLES = ("psi",)
"""Columns that are headings [rad], recorded wrapped to ±pi or continuous."""


def _unwrapped(v: np.ndarray) -> np.ndarray:
    """A heading made continuous over its finite samples (NaN kept)."""
    out = v.copy()
    ok = np.isfinite(v)
    out[ok] = np.unwrap(v[ok])
    return out


def _wrapped_like(orig: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``v`` wrapped to [-pi, pi) where the recorded heading ``orig`` was wrapped, else as is."""
    if np.nanmax(np.abs(orig), initial=0.0) <= np.pi + 1e-9:
        return (v + np.pi) % (2.0 * np.pi) - np.pi
    return v


def corrected_yaw_rate(yaw_rate: np.ndarray, calibration: dict[str, float]) -> np.ndarray:
    """The gyro's reading [rad/s] corrected: ``(yaw_rate - yaw_rate_bias) / yaw_rate_scale``
    (a missing entry: bias 0, scale 1)."""
    return (yaw_rate - calibration.get("yaw_rate_bias", 0.0)) / calibration.get("yaw_rate_scale", 1.0)


def shift_columns(drive: Drive, shifts: dict[str, float]) -> Drive:
    """Columns moved back in time by their shift [s]: ``col_new(t) = col(t + shift)``;
    samples whose shifted time falls outside the drive or inside a gap are dropped.
    ``meta.extra['alignment_s']`` records the shift of each column."""
    t = drive.t
    df = drive.data.copy()
    keep = np.ones(len(t), bool)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    for col, d in shifts.items():
        if col not in df.columns or d == 0.0:
            continue
        ts = t + d
        inside = (ts >= t[0]) & (ts <= t[-1])
        k = np.clip(np.searchsorted(t, ts, side="right"), 1, len(t) - 1)
        inside &= (t[k] - t[k - 1]) <= 3.0 * dt
        keep &= inside
        v = df[col].to_numpy(float)
        if col in _ANGLES:  # a heading wraps at ±pi: interpolate it unwrapped
            df[col] = _wrapped_like(v, np.interp(ts, t, _unwrapped(v)))
        else:
            df[col] = np.interp(ts, t, v)
    extra = dict(drive.meta.extra or {})
    extra["alignment_s"] = {c: float(d) for c, d in shifts.items() if c in df.columns}
    return Drive(df[keep].reset_index(drop=True), replace(drive.meta, extra=extra))


def apply_calibration(drive: Drive, calibration: dict[str, float]) -> Drive:
    """The drive with its sensors calibrated (:data:`CALIBRATION`).

    Each sensor's columns move back by its delay (the accelerometer's ``ay``, and ``ax`` by
    ``delay_accelerometer_x`` where given, else by ``delay_accelerometer``; the speed's ``vx``
    and wheel speeds; ``steer``; the ends without a partner dropped), then
    ``steer <- steer_scale steer + steer_offset``, ``ay <- ay - ay_bias``, ``ax <- ax - ax_bias``,
    ``yaw_rate <- (yaw_rate - yaw_rate_bias) / yaw_rate_scale``.
    ``meta.extra['calibration']`` records what was applied.

    Parameters
    ----------
    drive : Drive
    calibration : dict of str to float
        As :func:`read_calibration` returns; missing entries are not applied.

    Returns
    -------
    Drive

    Raises
    ------
    ValueError
        The drive already carries a calibration (``meta.extra['calibration']``): applying
        one twice would shift and scale its columns twice.
    """
    if not calibration:
        return drive
    if (drive.meta.extra or {}).get("calibration"):
        raise ValueError("the drive's sensors are already calibrated (read with a vehicle file that "
                         "carries a calibration); a second calibration is not applied")
    shifts: dict[str, float] = {}
    for key, cols in _DELAYED.items():
        for c in cols:
            if key in calibration and drive.has(c):
                shifts[c] = calibration[key]
    out = shift_columns(drive, shifts) if shifts else drive
    df = out.data.copy()
    if drive.has("steer"):
        df["steer"] = calibration.get("steer_scale", 1.0) * df["steer"] + calibration.get("steer_offset", 0.0)
    for c in ("ay", "ax"):
        if drive.has(c) and f"{c}_bias" in calibration:
            df[c] = df[c] - calibration[f"{c}_bias"]
    if drive.has("psi") and "pose_heading_bias" in calibration:
        df["psi"] = _wrapped_like(drive.col("psi"), df["psi"].to_numpy(float) - calibration["pose_heading_bias"])
    if drive.has("yaw_rate") and {"yaw_rate_bias", "yaw_rate_scale"} & calibration.keys():
        df["yaw_rate"] = corrected_yaw_rate(df["yaw_rate"].to_numpy(float), calibration)
    extra = dict(out.meta.extra or {})
    extra["calibration"] = dict(calibration)
    return Drive(df, replace(out.meta, extra=extra))
