"""One quantity identified by ``roadgrip vehicle fit``: value, standard error, unit, status.

:func:`fitted` and :func:`undetermined` build one; :func:`describe` is its line in the
vehicle file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["FittedValue", "describe", "fitted", "undetermined"]


@dataclass(frozen=True)
class FittedValue:
    """One identified quantity.

    Attributes
    ----------
    name : str
        E.g. ``'cornering_stiffness_front'``, ``'steer_offset'``.
    value : float
        In ``unit``; the base vehicle's value (or NaN for a sensor quantity) when
        undetermined.
    std : float
        Standard error in ``unit`` (NaN when undetermined).
    unit : str
    status : {'fitted', 'undetermined'}
    note : str
        Why undetermined, or what the value means.
    """

    name: str
    value: float
    std: float
    unit: str
    status: str
    note: str = ""

    @property
    def fitted(self) -> bool:
        return self.status == "fitted"


def describe(v: FittedValue, value: bool = False) -> str:
    val = f"{v.value:.6g} " if value and math.isfinite(v.value) else ""
    if v.fitted:
        return f"{val}± {v.std:.3g} {v.unit} (fitted){'; ' + v.note if v.note else ''}"
    return f"{val}{v.unit} undetermined: {v.note}"


def fitted(name, value, std, unit, note=""):
    return FittedValue(name, float(value), float(std), unit, "fitted", note)


def undetermined(name, unit, note, value=math.nan):
    return FittedValue(name, float(value), math.nan, unit, "undetermined", note)
