"""Argument checks shared by the metric modules."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def as_1d(name: str, x: ArrayLike) -> NDArray[np.float64]:
    """``x`` as a one-dimensional float array; ``ValueError`` naming it otherwise."""
    a = np.asarray(x, dtype=float)
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    return a


def same_length(**arrays: np.ndarray) -> int:
    """The common length of ``arrays``; ``ValueError`` listing the lengths otherwise."""
    lens = {k: len(v) for k, v in arrays.items()}
    if len(set(lens.values())) > 1:
        raise ValueError(f"arrays must have equal length, got {lens}")
    return next(iter(lens.values()))
