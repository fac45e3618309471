"""Paper 000, Fig. 1: posterior friction curves of the GP-SSM filter at a few times.

Columns are the snapshot times; rows the front curve, the rear curve and a histogram of
the estimated front and rear slip angles visited up to that time. The posterior mean is
black, the 95 % band grey, the truth (where the drive carries it) dashed red, the prior
dash-dotted black; green dashed lines mark the range of the visited slip angles.
Friction is in absolute units (force over load), slip angles in degrees; the friction
axis spans the drawn curves, bands and truth, whatever the surface.

Visited slip angles count only samples at or above the filter's ``min_speed``: slower
ones carry no friction information, and the filter does not learn from them
(:mod:`roadgrip.plots.standstill`); at rest the front slip angle is the steering angle.
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
from matplotlib.figure import Figure

from roadgrip.plots.titles import fit_suptitle

__all__ = ["curves_figure", "friction_limits", "plot_curves", "plot_result"]

_CURVE_COLUMNS = ("mu_mean", "mu_lower", "mu_upper", "mu_true", "mu_prior")
"""Columns of a curve table that the figure draws (the friction axis spans them)."""
_MARGIN = 0.05
"""Margin of the friction axis [fraction of the drawn span]."""


def friction_limits(curves: pd.DataFrame) -> tuple[float, float]:
    """Friction-axis limits [-] spanning every drawn value of ``curves``, with a margin.

    The finite values of the mean, band, truth and prior columns present, widened by
    5 % of their span on each side (0.05 when they are one value).

    Examples
    --------
    >>> c = pd.DataFrame({"mu_mean": [-0.9, 0.9], "mu_lower": [-1.0, 0.8], "mu_upper": [-0.8, 1.0]})
    >>> tuple(round(v, 3) for v in friction_limits(c))
    (-1.1, 1.1)
    """
    cols = [c for c in _CURVE_COLUMNS if c in curves]
    v = curves[cols].to_numpy(float).ravel() if cols else np.zeros(0)
    v = v[np.isfinite(v)]
    if not len(v):
        return -1.0, 1.0
    lo, hi = float(v.min()), float(v.max())
    pad = _MARGIN * (hi - lo) if hi > lo else 0.05
    return lo - pad, hi + pad


def plot_result(drive: Any, result: Any, path: str | Path) -> None:
    """Write the Fig. 1 reproduction of a GP-SSM run as a PNG.

    Parameters
    ----------
    drive : Drive
        The drive the result was computed on (its source names the figure; its speed, as
        the run's ``vx_source`` reads it, masks standstill out of the slip histograms).
    result : EstimateResult
        Its ``curves`` (run with ``curve_times``) and ``table`` (``t``, ``alpha_f``,
        ``alpha_r``).
    path : str or Path

    Raises
    ------
    ValueError
        The result carries no curves.
    """
    from roadgrip.estimators.gpssm.inputs import drive_vx
    from roadgrip.plots.standstill import min_speed

    source = (result.meta or {}).get("config", {}).get("vx_source", "auto")
    vx = np.interp(result.table["t"].to_numpy(float), drive.t, drive_vx(drive, source))
    plot_curves(result.curves, result.table, path, title=str(drive.meta.source), vx=vx,
                min_speed=min_speed(result))


def curves_figure(curves: pd.DataFrame, table: pd.DataFrame, title: str = "", *,
                  vx: np.ndarray | None = None, min_speed: float | None = None) -> Figure:
    """The Fig. 1 reproduction as a :class:`~matplotlib.figure.Figure`.

    Parameters
    ----------
    curves : DataFrame
        ``curves.parquet`` layout: ``t`` [s from the drive start], ``axle``, ``alpha``
        [rad], ``mu_mean``, ``mu_lower``, ``mu_upper``, optional ``mu_prior`` and
        ``mu_true`` (drawn where finite: a binned truth is NaN outside its visited bins).
    table : DataFrame
        Per-step estimates with ``t``, ``alpha_f``, ``alpha_r`` [rad] (slip histogram)
        and optionally ``vx`` [m/s].
    title : str
    vx : ndarray, shape (len(table),), optional
        Speed [m/s] at the table's rows (default the table's ``vx`` column, if any).
    min_speed : float, optional
        Samples slower than this [m/s] are left out of the visited slip angles (default
        the GP-SSM default ``min_speed``). Without a speed every sample counts.

    Raises
    ------
    ValueError
        ``curves`` is empty.
    """
    if curves is None or len(curves) == 0:
        raise ValueError("no posterior curves to plot: run the GP-SSM filter with curve_times")
    if vx is None and "vx" in table:
        vx = table["vx"].to_numpy(float)
    moving = np.ones(len(table), bool)
    if vx is not None:
        if min_speed is None:
            from roadgrip.estimators import get

            min_speed = get("gpssm").Config.min_speed
        moving = np.asarray(vx, float) >= min_speed  # as the filter: reversing teaches nothing
    times = sorted(curves["t"].unique())
    n = len(times)
    fig, axes = plt.subplots(3, n, figsize=(3.2 * n, 8.2), squeeze=False, sharex=True, layout="constrained")
    t_rel = table["t"].to_numpy() - float(table["t"].iloc[0])
    grid = np.degrees(np.sort(curves["alpha"].unique()))
    ylim = friction_limits(curves)
    for j, t in enumerate(times):
        seen = (t_rel <= t + 1e-9) & moving
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
                for k, v in enumerate((slips[axle].min(), slips[axle].max())):
                    ax.axvline(v, color="g", ls="--", lw=0.8,
                               label="range of visited slip angles" if k == 0 else "_range end")
            ax.set_ylim(*ylim)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel(f"{axle} friction mu [-]")
            if i == 0:
                ax.set_title(f"t = {t:.4g} s", fontsize=10)
        hx = axes[2, j]
        visited = np.r_[slips["front"], slips["rear"]]
        lo = min(grid.min(), visited.min()) if len(visited) else grid.min()
        hi = max(grid.max(), visited.max()) if len(visited) else grid.max()
        bins = np.linspace(lo, hi, 61)
        hx.hist(slips["front"], bins=bins, color="tab:blue", alpha=0.7, label="front slip angles")
        hx.hist(slips["rear"], bins=bins, color="tab:orange", alpha=0.5, label="rear slip angles")
        if not len(visited):
            hx.text(0.5, 0.5, "no visited slip angles yet", ha="center", va="center",
                    transform=hx.transAxes, fontsize=8, color="0.4")
        hx.set_xlabel("slip angle alpha [deg]")
        if j == 0:
            hx.set_ylabel("samples" if vx is None else f"samples at vx >= {min_speed:g} m/s")
    handles: dict[str, Any] = {}
    for ax in axes.ravel():
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    fig.legend(handles.values(), handles.keys(), loc="outside lower center", ncol=min(len(handles), 4),
               fontsize=8)
    if title:
        fit_suptitle(fig, title)
    return fig


def plot_curves(curves: pd.DataFrame, table: pd.DataFrame, path: str | Path, title: str = "", *,
                vx: np.ndarray | None = None, min_speed: float | None = None) -> Path:
    """Write :func:`curves_figure` as a PNG to ``path``; return ``path``."""
    fig = curves_figure(curves, table, title, vx=vx, min_speed=min_speed)
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
