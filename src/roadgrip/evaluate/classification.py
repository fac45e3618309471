"""Scores of a friction-state classification against the truth of a simulated drive.

The truth class of a sample is 'high' where the true peak friction under the
vehicle ``mu_true`` is at least ``mu_split``, else 'low'; the information the
data carry is measured by the true axle utilisation
``max(util_f_true, util_r_true)`` (axle force over its friction ellipse).
:func:`surface_change_scores` gives, per drive:

* ``delays``: per change of the true class, the time from the first sample on
  the new surface whose utilisation exceeds ``util_min`` to the first sample
  classified as the new class (NaN where no sample of the new surface reaches
  ``util_min``; ``inf`` where the class never follows);
* ``false_switches``: switches between known classes into a class the truth
  does not give at that moment ('unknown' in between is skipped);
* ``accuracy_util``: fraction of the samples with utilisation ``>= util_min``
  classified as their true class;
* ``high_on_low``, ``low_on_high``: samples called 'high' on a low-friction
  surface and 'low' on a high-friction one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from roadgrip.constants import GRIP_CLASS_SPLIT
from roadgrip.drive import Drive

__all__ = ["ChangeScores", "surface_change_scores", "true_classes"]


@dataclass(frozen=True)
class ChangeScores:
    """Scores of one classified drive (see the module docstring)."""

    delays: tuple[float, ...]
    false_switches: int
    accuracy_util: float
    n_util: int
    high_on_low: int
    low_on_high: int
    unknown_fraction: float


def true_classes(drive: Drive, mu_split: float = GRIP_CLASS_SPLIT) -> NDArray[np.str_]:
    """'high' where ``mu_true >= mu_split``, else 'low' (shape (T,))."""
    return np.where(drive.col("mu_true") >= mu_split, "high", "low")


def surface_change_scores(
    drive: Drive, grip_class: NDArray, util_min: float = 0.6, mu_split: float = GRIP_CLASS_SPLIT
) -> ChangeScores:
    """Score the per-sample classes ``grip_class`` (shape (T,)) of a simulated drive."""
    cls = np.asarray(grip_class).astype(str)
    truth = true_classes(drive, mu_split)
    t = drive.t
    util = np.maximum(drive.col("util_f_true"), drive.col("util_r_true"))
    changes = np.flatnonzero(truth[1:] != truth[:-1]) + 1
    bounds = np.r_[changes, len(t)]
    delays = []
    for k, i0 in enumerate(changes):
        seg = slice(i0, bounds[k + 1])
        informed = np.flatnonzero(util[seg] > util_min)
        if informed.size == 0:
            delays.append(float("nan"))
            continue
        t_info = t[seg][informed[0]]
        hit = np.flatnonzero(cls[seg] == truth[i0])
        delays.append(float(t[seg][hit[0]] - t_info) if hit.size else float("inf"))
    known = np.flatnonzero(cls != "unknown")
    kc = cls[known]
    into = known[1:][kc[1:] != kc[:-1]]
    false_sw = int(np.sum(cls[into] != truth[into]))
    sel = util >= util_min
    acc = float((cls[sel] == truth[sel]).mean()) if sel.any() else float("nan")
    return ChangeScores(
        delays=tuple(delays),
        false_switches=false_sw,
        accuracy_util=acc,
        n_util=int(sel.sum()),
        high_on_low=int(np.sum((cls == "high") & (truth == "low"))),
        low_on_high=int(np.sum((cls == "low") & (truth == "high"))),
        unknown_fraction=float((cls == "unknown").mean()),
    )
