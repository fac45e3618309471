"""Pieces shared by the two friction-state classifiers of paper 002 (bRLS and slip map).

* the peak-friction references of the two classes, the band a class claims and the
  VSS-style summary (:func:`class_band`, :func:`summary_meta`, :func:`prior_band`);
* the class labels of a run (:func:`classes`);
* the settling rule of the calibration scores (:func:`settled`);
* the first-order low-pass used as prefilter (:func:`lowpass`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import FRICTION_MAX, GRIP_CLASS_SPLIT
from roadgrip.tire import SURFACES

__all__ = [
    "CALIBRATION_SETTLING_S",
    "CLASS_SWITCH_PENALTY",
    "DEFAULT_FRICTION",
    "check_field_types",
    "class_band",
    "classes",
    "classifier_diagnostics",
    "extra_switches",
    "friction_refs",
    "lowpass",
    "mirrored_friction",
    "prior_band",
    "settled",
    "summary_meta",
]

DEFAULT_FRICTION: dict[str, float] = {
    "high": SURFACES["dry_asphalt"].mu_peak,
    "low": SURFACES["gravel"].mu_peak,
}
"""Peak-friction references of the classes without calibration: dry asphalt and gravel."""

CALIBRATION_SETTLING_S = 10.0
"""Calibration scores judge each drive from this time after it first moves [s]."""

CLASS_SWITCH_PENALTY = 0.01
"""Calibration score penalty per class switch beyond the first (fraction of time)."""


def check_field_types(cls: type, d: Mapping[str, Any], where: str) -> None:
    """Refuse a settings dictionary whose scalar fields have the wrong type, naming the key.

    The dataclass ``cls``'s fields annotated ``bool``, ``int``, ``float`` or ``str`` must
    hold a value of that type (an ``int`` is a ``float``; a ``bool`` is neither number),
    so that a calibration file with text where a number belongs is refused when read,
    not deep inside a compiled kernel. Other fields are left to their own checks.

    Raises
    ------
    ValueError
        Naming ``where``, the key, the value and the type it needs.
    """
    import typing

    hints = typing.get_type_hints(cls)
    accepts = {bool: (bool,), int: (int,), float: (int, float), str: (str,)}
    for key, value in d.items():
        need = hints.get(key)
        if need not in accepts:
            continue
        ok = isinstance(value, accepts[need]) and not (need is not bool and isinstance(value, bool))
        if not ok:
            raise ValueError(f"{where}: setting {key!r} = {value!r} must be a {need.__name__}")


def friction_refs(d: Mapping[str, Any], where: str) -> dict[str, float]:
    """``{'high': float, 'low': float}`` from ``d``, checked (``0 < low < high``).

    Raises
    ------
    ValueError
        Naming ``where`` when a reference is missing, not a number or out of order.
    """
    try:
        hi, lo = float(d["high"]), float(d["low"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{where}: 'friction' must give numbers for 'high' and 'low'") from None
    if not (0.0 < lo < hi):
        raise ValueError(f"{where}: friction references need 0 < low < high, got {lo}, {hi}")
    return {"high": hi, "low": lo}


def mirrored_friction(label: str, mu: float) -> dict[str, float]:
    """Both classes' peak-friction references from one class's: the other mirrored across the split.

    A calibration from drives of one class (the usual dry baseline lap) knows that
    class's friction ``mu`` and not the other's. The saturation model tells the classes
    apart by the friction alone (the stiffness, the gains and the road load are the
    car's, fitted on the labelled drives), so the other reference is placed where the
    class split :data:`~roadgrip.constants.GRIP_CLASS_SPLIT` is their geometric mean:
    ``mu_other = split^2 / mu``. On the slips where the low class saturates and the high
    one does not, the predicted accelerations scale with the friction, so the class
    position's threshold (halfway between the predictions) then lies near the split
    (dry asphalt 1.0 gives 0.49, the gravel of the simulator's scenarios).

    Parameters
    ----------
    label : {'high', 'low'}
        The class whose friction is known.
    mu : float
        Its peak friction [-]: above the split for 'high', below it for 'low'.

    Raises
    ------
    ValueError
        When ``mu`` lies on the wrong side of the split for ``label``.

    >>> mirrored_friction("high", 1.0)
    {'high': 1.0, 'low': 0.49}
    """
    split = GRIP_CLASS_SPLIT
    mu = float(mu)
    if label not in ("high", "low"):
        raise ValueError(f"calibration label must be 'high' or 'low', got {label!r}")
    if not math.isfinite(mu) or (label == "high" and not mu > split) or (label == "low" and not 0.0 < mu < split):
        side = "above" if label == "high" else "below"
        raise ValueError(f"a {label!r} friction reference must lie {side} the class split {split}, got {mu}")
    other = round(split**2 / mu, 6)
    return {"high": mu, "low": other} if label == "high" else {"high": other, "low": mu}


def prior_band(friction: Mapping[str, float] | None = None) -> tuple[float, float]:
    """The band reported while the class is 'unknown': ``(low, high)`` references [-]."""
    fr = friction or DEFAULT_FRICTION
    return float(fr["low"]), float(fr["high"])


def class_band(grip_class: str, friction: Mapping[str, float] | None = None,
               floor: float = 0.0) -> tuple[float, float, float]:
    """``(most probable, lower, upper)`` peak friction [-] that a class claims.

    The bounds follow from the class definition, not from the class references
    (which are typical values, not bounds): 'high' is at least
    :data:`~roadgrip.constants.GRIP_CLASS_SPLIT` with no upper claim
    (:data:`~roadgrip.constants.FRICTION_MAX`); 'low' is below the split and at
    least ``floor``, the friction the car demonstrably used (0 without). The most
    probable value is the class's reference, held inside that band. 'unknown'
    claims nothing: ``[0, FRICTION_MAX]`` around the references' midpoint.

    >>> class_band("low", {"high": 0.84, "low": 0.35}, floor=0.31)
    (0.35, 0.31, 0.7)
    >>> class_band("high", {"high": 0.6, "low": 0.3})
    (0.7, 0.7, 2.0)
    """
    fr = friction or DEFAULT_FRICTION
    split = GRIP_CLASS_SPLIT
    if grip_class == "high":
        return max(float(fr["high"]), split), split, FRICTION_MAX
    if grip_class == "low":
        lo = min(max(float(floor), 0.0), split)
        return min(max(float(fr["low"]), lo), split), lo, split
    return 0.5 * (float(fr["high"]) + float(fr["low"])), 0.0, FRICTION_MAX


def summary_meta(table: pd.DataFrame, friction: Mapping[str, float] | None = None) -> dict[str, Any]:
    """``meta['summary']`` of a classification run.

    VSS-style friction (the output contract): the band the final class claims
    (:func:`class_band`, with the table's ``grip_now``, the friction the car uses on
    the present surface, where it has one), and the
    final class and grip index and the share of time in each class.
    """
    last = table.iloc[-1]
    cls = table["grip_class"].astype(str).to_numpy()
    floor = float(last["grip_now"]) if "grip_now" in table.columns else 0.0
    band = class_band(str(last["grip_class"]), friction, floor)
    return {
        "MostProbable": float(band[0]),
        "LowerBound": float(band[1]),
        "UpperBound": float(band[2]),
        "GripClass": str(last["grip_class"]),
        "GripIndex": float(last["grip_index"]),
        "FractionHigh": float((cls == "high").mean()),
        "FractionLow": float((cls == "low").mean()),
        "FractionUnknown": float((cls == "unknown").mean()),
    }


def classes(high: NDArray, known: NDArray) -> NDArray[np.str_]:
    """'high' / 'low' where ``known``, else 'unknown' (elementwise)."""
    return np.where(known, np.where(high, "high", "low"), "unknown")


def extra_switches(cls: NDArray) -> int:
    """Class switches beyond the first among the known classes (a labelled drive has one class)."""
    known = cls[cls != "unknown"]
    return max(int(np.sum(known[1:] != known[:-1])) - 1, 0)


def settled(t: NDArray, moving: NDArray, informed: NDArray | None = None) -> NDArray[np.bool_]:
    """Moving samples from :data:`CALIBRATION_SETTLING_S` after the vehicle first moves.

    The settling period counts from the first moving sample: before it no
    classifier has information, so a drive that starts at a standstill is not
    judged on its first seconds of motion. All samples when it never moves.
    With ``informed``, it counts from the first moving sample at or after the first
    informed one instead (a drive that cruises before its first manoeuvre gives a
    classifier no more information than a standstill), and no sample is judged when
    none is informed.

    Parameters
    ----------
    t : ndarray, shape (T,)
        Sample times [s].
    moving : ndarray of bool, shape (T,)
    informed : ndarray of bool, shape (T,), optional
        Samples that carry class information (a channel's weight, for example).
    """
    moving = np.asarray(moving, bool)
    if informed is not None:
        seen = np.maximum.accumulate(np.asarray(informed, bool)) if moving.size else moving
        if not (moving & seen).any():
            return np.zeros(moving.shape, bool)
        moving = moving & seen
    if not moving.any():
        return np.ones(moving.shape, bool)
    t0 = t[int(np.argmax(moving))]
    m = moving & (t >= t0 + CALIBRATION_SETTLING_S)
    return m if m.any() else moving


def lowpass(x: NDArray, dt: float, tau: float) -> NDArray:
    """First-order low-pass at a constant step ``dt`` [s] with time constant ``tau`` [s] (0 = none)."""
    if tau <= 0:
        return x
    from scipy.signal import lfilter

    k = 1.0 - math.exp(-dt / tau)
    return lfilter([k], [1.0, k - 1.0], x)


def classifier_diagnostics(table: pd.DataFrame, calibrated: bool, defaults: str) -> dict[str, Any]:
    """``meta['diagnostics']`` shared by both classifiers: calibration, excitation, switches.

    ``defaults`` describes the uncalibrated settings.
    """
    cls = table["grip_class"].to_numpy()
    return {
        "calibration": "calibrated" if calibrated else f"uncalibrated defaults ({defaults})",
        "excited_fraction": float(table["excited"].mean()),
        "class_changes": int(np.sum(cls[1:] != cls[:-1])),
    }
