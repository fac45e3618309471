"""Paper 000, Fig. 1: posterior friction curves of the GP-SSM filter at a few times.

Columns are the snapshot times; rows the front curve, the rear curve and a histogram of
the estimated front and rear slip angles visited up to that time. The posterior mean is
black, the 95 % band grey, the truth (where the drive carries it) dashed red, the prior
dash-dotted black; green dashed lines mark the range of the visited slip angles.
Friction is in absolute units (force over load), slip angles in degrees.
:func:`plot_result` draws it from an estimator run (the result's table and curves).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

__all__ = ["plot_curves", "plot_result"]


def plot_result(drive: Any, result: Any, path: str | Path) -> None:
    """Write the Fig. 1 reproduction of a GP-SSM run as a PNG.

    Parameters
    ----------
    drive : Drive
        The drive the result was computed on (its source names the figure).
    result : EstimateResult
        Its ``curves`` (run with ``curve_times``) and ``table`` (``t``, ``alpha_f``,
        ``alpha_r``).
    path : str or Path

    Raises
    ------
    ValueError
        The result carries no curves.
    """
    plot_curves(result.curves, result.table, path, title=str(drive.meta.source))


def plot_curves(curves: pd.DataFrame, table: pd.DataFrame, path: str | Path, title: str = "") -> Path:
    """Write the Fig. 1 reproduction as a PNG.

    Parameters
    ----------
    curves : DataFrame
        ``curves.parquet`` layout: ``t`` [s from the drive start], ``axle``, ``alpha``
        [rad], ``mu_mean``, ``mu_lower``, ``mu_upper``, optional ``mu_prior`` and
        ``mu_true`` (drawn where finite: a binned truth is NaN outside its visited bins).
    table : DataFrame
        Per-step estimates with ``t``, ``alpha_f``, ``alpha_r`` [rad] (slip histogram).
    path : str or Path
    title : str
    """
    if curves is None or len(curves) == 0:
        raise ValueError("no posterior curves to plot: run the GP-SSM filter with curve_times")
    times = sorted(curves["t"].unique())
    n = len(times)
    fig, axes = plt.subplots(3, n, figsize=(3.2 * n, 7.5), squeeze=False, sharex=True)
    t_rel = table["t"].to_numpy() - float(table["t"].iloc[0])
    for j, t in enumerate(times):
        seen = t_rel <= t + 1e-9
        slips = {"front": np.degrees(table["alpha_f"].to_numpy()[seen]),
                 "rear": np.degrees(table["alpha_r"].to_numpy()[seen])}
        for i, axle in enumerate(("front", "rear")):
            ax = axes[i, j]
            c = curves[(curves["t"] == t) & (curves["axle"] == axle)].sort_values("alpha")
            a = np.degrees(c["alpha"].to_numpy())
            ax.fill_between(a, c["mu_lower"], c["mu_upper"], color="0.8", label="95 % band")
            ax.plot(a, c["mu_mean"], "k-", lw=1.5, label="posterior mean")
            if "mu_true" in c and c["mu_true"].notna().any():  # a binned truth: gaps
                ax.plot(a, c["mu_true"], "r--", lw=1.2, label="truth")
            if "mu_prior" in c:
                ax.plot(a, c["mu_prior"], "k-.", lw=1.0, label="prior")
            if len(slips[axle]):
                for v in (slips[axle].min(), slips[axle].max()):
                    ax.axvline(v, color="g", ls="--", lw=0.8)
            ax.set_ylim(-0.6, 0.6)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel(f"{axle} friction mu [-]")
            if i == 0:
                ax.set_title(f"t = {t:g} s")
        hx = axes[2, j]
        bins = np.linspace(a.min(), a.max(), 61) if len(a) else 30
        hx.hist(slips["front"], bins=bins, color="tab:blue", alpha=0.7, label="front")
        hx.hist(slips["rear"], bins=bins, color="tab:orange", alpha=0.5, label="rear")
        hx.set_xlabel("slip angle alpha [deg]")
        if j == 0:
            hx.set_ylabel("samples")
    axes[0, 0].legend(fontsize=7, loc="upper left")
    axes[2, 0].legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
