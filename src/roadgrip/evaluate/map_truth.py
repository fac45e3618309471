"""A friction map and a per-sample friction estimate scored against the simulator's friction field.

What a user of a friction map asks of a cell is the friction where the car
drives inside it. The truth of a cell is therefore the true friction under the
tires of every sample whose axle (true pose, ``lf`` ahead of and ``lr`` behind
the CG) lies in the cell, averaged; it does not depend on which samples the
estimator chose to use. The friction under the tires is the drive's
``mu_true`` column where it has one (the multi-body engine applies the surface
at its reference point to all four wheels), else the friction field at the
axle.

The physics floor needs no truth: a car that holds ``|a_y|`` for a second on a
surface proves a friction of at least ``|a_y| / g`` there
(:func:`roadgrip.signals.sustained_grip`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from roadgrip.constants import Z95
from roadgrip.drive import Drive
from roadgrip.signals import level_accelerations, sustained_grip

__all__ = [
    "AXLES",
    "MapScore",
    "axle_positions",
    "axle_truth",
    "cells_needing_observations",
    "path_cell_truth",
    "sample_score",
    "score_map",
    "truth_at_observations",
]

AXLES = ("front", "rear")


def axle_positions(drive: Drive, true_pose: bool = True) -> dict[str, tuple[NDArray, NDArray]]:
    """Positions [m] of the front and rear axle centres of every sample.

    Uses ``x_true, y_true, psi_true`` when present and ``true_pose``, else the
    measured ``x, y, psi``; without a heading both axles sit at ``x, y``.
    """
    sfx = "_true" if true_pose and drive.has("x_true", "y_true") else ""
    x, y = drive.col(f"x{sfx}"), drive.col(f"y{sfx}")
    hcol = f"psi{sfx}" if drive.has(f"psi{sfx}") else ("psi" if drive.has("psi") else None)
    if hcol is None:
        return {"front": (x, y), "rear": (x, y)}
    c, s = np.cos(drive.col(hcol)), np.sin(drive.col(hcol))
    v = drive.vehicle
    return {"front": (x + v.lf * c, y + v.lf * s), "rear": (x - v.lr * c, y - v.lr * s)}


def axle_truth(drive: Drive) -> dict[str, NDArray[np.float64]]:
    """True friction under each axle for every sample [-].

    The drive's ``mu_true`` for both axles, else the simulator's friction field
    (``meta.truth['friction_field']``) at the axle positions.

    Raises
    ------
    ValueError
        When the drive carries neither.
    """
    field = (drive.meta.truth or {}).get("friction_field")
    if drive.has("mu_true"):
        mu = drive.col("mu_true")
        return {"front": mu, "rear": mu}
    if field is None:
        raise ValueError("the drive has no friction truth (no friction field, no mu_true column)")
    from roadgrip.sim.friction import mu_at

    pos = axle_positions(drive)
    return {a: np.asarray(mu_at(field, drive.t, *pos[a]), float) for a in AXLES}


def _keys(x: NDArray, y: NDArray, cell: float) -> pd.MultiIndex:
    return pd.MultiIndex.from_arrays([np.floor(x / cell).astype(np.int64), np.floor(y / cell).astype(np.int64)],
                                     names=["ix", "iy"])


def path_cell_truth(drive: Drive, cell: float) -> pd.Series:
    """Mean true friction at the axle positions of the samples inside each cell, indexed by ``(ix, iy)``."""
    pos = axle_positions(drive)
    mu = axle_truth(drive)
    keys = [_keys(*pos[a], cell) for a in AXLES]
    vals = np.concatenate([mu[a] for a in AXLES])
    idx = keys[0].append(keys[1])
    return pd.Series(vals, index=idx).groupby(level=["ix", "iy"]).mean()


def truth_at_observations(drive: Drive, table: pd.DataFrame) -> pd.DataFrame:
    """The estimates with every friction observation replaced by the true friction under its axle.

    Each ``mu_<axle>_obs`` (the cascade's single-sample observations) becomes
    :func:`axle_truth`; which samples are observations, their positions and their
    bands stay the estimator's. The map of this table is what any estimator would
    map if every observation it made were exact: its score (:func:`score_map`) is
    the ceiling that the places where the drive gave information allow, since a
    cell's truth averages every pass through the cell and the observations only
    the excited ones.

    Raises
    ------
    ValueError
        When the table has no ``mu_front_obs`` / ``mu_rear_obs`` column or its
        length differs from the drive's.
    """
    cols = [f"mu_{a}_obs" for a in AXLES if f"mu_{a}_obs" in table.columns]
    if not cols:
        raise ValueError("the estimates have no single-sample friction observations (mu_front_obs, mu_rear_obs)")
    if len(table) != drive.n:
        raise ValueError(f"the estimates have {len(table)} rows, the drive {drive.n} samples")
    mu = axle_truth(drive)
    return table.assign(**{c: mu[c.split("_")[1]] for c in cols})


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2], strict=True))


def cells_needing_observations(drive: Drive, cell: float, util_min: float = 0.6,
                               min_time: float = 1.0) -> pd.MultiIndex:
    """Cells an axle crossed while its true utilisation stayed above ``util_min`` for ``min_time`` [s].

    Needs the truth columns ``util_f_true``, ``util_r_true`` (multi-body drives).
    """
    pos = axle_positions(drive)
    t = drive.t
    found = []
    for a, col in (("front", "util_f_true"), ("rear", "util_r_true")):
        for i0, i1 in _runs(drive.col(col) > util_min):
            if t[i1 - 1] - t[i0] >= min_time:
                found.append(_keys(pos[a][0][i0:i1], pos[a][1][i0:i1], cell))
    if not found:
        return pd.MultiIndex.from_arrays([np.zeros(0, np.int64)] * 2, names=["ix", "iy"])
    out = found[0]
    for k in found[1:]:
        out = out.append(k)
    return out.unique()


def sample_score(drive: Drive, table: pd.DataFrame, margin: float = 0.05) -> dict[str, float]:
    """Per-sample bands against the truth under each axle.

    Returns the fraction of samples (per axle and both pooled) whose 95 % band
    ``mu_<axle>_lower .. mu_<axle>_upper`` excludes the truth by more than
    ``margin``, and the fraction whose upper bound lies below the sustained
    ``|a_y| / g`` floor (:func:`roadgrip.signals.sustained_grip` of the
    levelled ``ay``, :func:`roadgrip.signals.level_accelerations`).
    """
    truth = axle_truth(drive)
    ay = level_accelerations(drive.col("ax"), drive.col("ay"), drive.vehicle)[1]
    floor = sustained_grip(drive.t, ay)
    out: dict[str, float] = {}
    wrong_all = []
    for a in AXLES:
        lo = table[f"mu_{a}_lower"].to_numpy(float)
        hi = table[f"mu_{a}_upper"].to_numpy(float)
        wrong = (truth[a] < lo - margin) | (truth[a] > hi + margin)
        out[f"confidently_wrong_{a}"] = float(wrong.mean())
        out[f"below_floor_{a}"] = float(np.mean(hi < floor - 1e-9))
        wrong_all.append(wrong)
    out["confidently_wrong"] = float(np.concatenate(wrong_all).mean())
    out["floor_max"] = float(floor[-1]) if len(floor) else 0.0
    return out


@dataclass(frozen=True)
class MapScore:
    """A friction grid against the truth at the positions inside its cells.

    Attributes
    ----------
    cells : DataFrame
        Cells with at least one observation: ``ix, iy, mu_mean, mu_std, n_obs,
        mu_true`` (NaN where no sample lies in the cell), ``error``.
    n_scored : int
        Cells with at least ``min_obs`` observations and a truth.
    mae : float
        Mean ``|error|`` over the scored cells [-].
    within_01 : float
        Fraction of scored cells within 0.1.
    coverage95 : float
        Fraction of scored cells with the truth inside ``mean ± 1.96 std``.
    confidently_wrong : int
        Cells (any number of observations) with ``|error| > 0.15`` and ``1.96 std < |error|``.
    required : int
        Cells crossed at true utilisation above 0.6 for 1 s (:func:`cells_needing_observations`).
    required_met : int
        Of those, cells holding at least ``min_obs`` observations.
    """

    cells: pd.DataFrame
    n_scored: int
    mae: float
    within_01: float
    coverage95: float
    confidently_wrong: int
    required: int
    required_met: int

    def line(self) -> str:
        """One-line summary for benchmark output."""
        return (f"cells>=10 obs {self.n_scored:3d}  MAE {self.mae:.3f}  within 0.1 {100 * self.within_01:5.1f} %  "
                f"95% cover {100 * self.coverage95:5.1f} %  conf. wrong {self.confidently_wrong}  "
                f"required cells {self.required_met}/{self.required}")


def score_map(drive: Drive, grid, min_obs: int = 10) -> MapScore:
    """Score a :class:`roadgrip.mapping.FrictionGrid` of ``drive`` against its friction truth."""
    mean, std = grid.posterior()
    iy, ix = np.nonzero(grid.n_obs > 0)
    cells = pd.DataFrame({"ix": ix + grid.ix0, "iy": iy + grid.iy0, "mu_mean": mean[iy, ix],
                          "mu_std": std[iy, ix], "n_obs": grid.n_obs[iy, ix]})
    truth = path_cell_truth(drive, grid.cell)
    cells["mu_true"] = truth.reindex(pd.MultiIndex.from_frame(cells[["ix", "iy"]])).to_numpy(float)
    cells["error"] = cells["mu_mean"] - cells["mu_true"]
    err = cells["error"].abs()
    scored = (cells["n_obs"] >= min_obs) & cells["mu_true"].notna()
    e = err[scored]
    cover = e <= Z95 * cells.loc[scored, "mu_std"]
    wrong = int(((err > 0.15) & (err > Z95 * cells["mu_std"])).sum())
    required, met = 0, 0
    if drive.has("util_f_true", "util_r_true"):
        need = cells_needing_observations(drive, grid.cell)
        have = pd.Series(cells["n_obs"].to_numpy(), index=pd.MultiIndex.from_frame(cells[["ix", "iy"]]))
        got = have.reindex(need).fillna(0).to_numpy()
        required, met = len(need), int((got >= min_obs).sum())
    nan = float("nan")
    return MapScore(cells, int(scored.sum()), float(e.mean()) if len(e) else nan,
                    float((e <= 0.1).mean()) if len(e) else nan, float(cover.mean()) if len(e) else nan,
                    wrong, required, met)
