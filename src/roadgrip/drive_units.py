"""Unit hints that are likely but not certain: heading in degrees, speed in km/h.

:func:`roadgrip.drive.validate_frame` refuses what is certainly wrong; these
checks only return warnings with their evidence (the measured ratio and the
number of samples behind it), issued as :class:`roadgrip.drive.DriveWarning`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["unit_warnings"]

_MIN_SAMPLES = 20


def unit_warnings(df: pd.DataFrame) -> list[str]:
    """Warnings about columns whose unit looks wrong, each with its evidence.

    - ``psi`` in degrees: its time derivative is about 57.3 x ``yaw_rate`` while turning;
    - ``vx`` in km/h: it is about 3.6 x the speed over ground of the pose ``x, y``.

    Parameters
    ----------
    df : DataFrame
        A frame that passed :func:`roadgrip.drive.validate_frame` (finite, time increasing).

    Returns
    -------
    list of str
    """
    out: list[str] = []
    cols = set(df.columns)
    if not {"t"} <= cols or len(df) < _MIN_SAMPLES:
        return out
    t = df["t"].to_numpy(float)
    if not np.all(np.diff(t) > 0):
        return out
    if {"psi", "yaw_rate"} <= cols:
        r = df["yaw_rate"].to_numpy(float)
        dpsi = np.gradient(df["psi"].to_numpy(float), t)
        sel = np.abs(r) > 0.05
        if sel.sum() >= _MIN_SAMPLES:
            ratio = float(np.median(dpsi[sel] / r[sel]))
            if 45.0 < ratio < 70.0:
                out.append(f"column 'psi' changes about {ratio:.1f} x yaw_rate while turning "
                           f"({int(sel.sum())} samples): it looks like degrees, expected rad")
    if {"vx", "x", "y"} <= cols:
        v = np.hypot(np.gradient(df["x"].to_numpy(float), t), np.gradient(df["y"].to_numpy(float), t))
        vx = df["vx"].to_numpy(float)
        sel = v > 1.0
        if sel.sum() >= _MIN_SAMPLES:
            ratio = float(np.median(np.abs(vx[sel]) / v[sel]))
            if 3.3 < ratio < 3.9:
                out.append(f"column 'vx' is about {ratio:.2f} x the pose's speed over ground "
                           f"({int(sel.sum())} samples): it looks like km/h, expected m/s")
    return out
