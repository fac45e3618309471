"""Figures of the Kalman cascade: velocities, axle forces, slip angles and axle friction.

Slip angles are drawn only where the speed is at least the cascade's ``v_min``: below it
the cascade makes no friction update, and a slip angle, a ratio of two small speeds,
reaches tens of degrees at walking pace (:mod:`roadgrip.plots.standstill`).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult
from roadgrip.plots.standstill import min_speed
from roadgrip.plots.titles import fit_suptitle

__all__ = ["cascade_figure", "plot_result"]


def _spans(ax, t: np.ndarray, mask: np.ndarray, label: str) -> None:
    """Shade the time spans where ``mask`` holds (one legend entry)."""
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2], strict=True)):
        ax.axvspan(t[a], t[min(b, len(t) - 1)], color="0.85", lw=0, label=label if k == 0 else None)


def plot_result(drive: Drive, result: EstimateResult, path: str | Path) -> None:
    """Write :func:`cascade_figure` as a PNG to ``path``."""
    fig = cascade_figure(drive, result)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def cascade_figure(drive: Drive, result: EstimateResult) -> Figure:
    """The three stages' estimates over time (truth where simulated).

    Panels: ``vx, vy`` [m/s] (with ``vy_pose`` where the drive has a pose
    velocity); axle lateral forces ``Fyf, Fyr`` [N]; slip angles [deg], where the
    estimated speed is at least the run's ``v_min`` (slower spans shaded); friction
    ``mu_front, mu_rear`` [-] in absolute units with their 95 % bands, the excited
    samples marked, and ``mu_true`` when the drive has it.
    """
    tab = result.table
    df = drive.data
    t = tab["t"].to_numpy()
    v_min = min_speed(result)
    slow = ~(np.abs(tab["vx"].to_numpy(float)) >= v_min)
    fig, axes = plt.subplots(4, 1, figsize=(12, 11), sharex=True, layout="constrained")

    ax = axes[0]
    ax.plot(t, tab["vx"], label="vx (stage 2)", color="C0")
    ax.plot(t, tab["vy"], label="vy (stage 2)", color="C1")
    for col, c in (("vx_true", "C0"), ("vy_true", "C1")):
        if col in df.columns:
            ax.plot(t, df[col], color=c, ls="--", lw=0.8, label=col)
    if "vy_pose" in df.columns:  # from the localisation (real data)
        ax.plot(t, df["vy_pose"], color="C1", ls=":", lw=0.8, label="vy_pose")
    ax.set_ylabel("velocity [m/s]")
    ax.legend(loc="upper right", ncol=4, fontsize=8)

    ax = axes[1]
    for col, c in (("Fyf", "C2"), ("Fyr", "C3")):
        ax.plot(t, tab[col], color=c, label=f"{col} (stage 2)")
        if f"{col}_std" in tab.columns:
            s = tab[f"{col}_std"].to_numpy()
            ax.fill_between(t, tab[col] - 1.96 * s, tab[col] + 1.96 * s, color=c, alpha=0.15, lw=0)
        if f"{col}_true" in df.columns:
            ax.plot(t, df[f"{col}_true"], color=c, ls="--", lw=0.8, label=f"{col}_true")
    f = tab[["Fyf", "Fyr"]].to_numpy()
    lo, hi = np.nanpercentile(f, [0.5, 99.5])
    pad = 0.2 * (hi - lo) + 1.0
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_ylabel("axle lateral force [N]")
    ax.legend(loc="upper right", ncol=4, fontsize=8)

    ax = axes[2]
    if slow.any():
        _spans(ax, t, slow, f"vx < {v_min:g} m/s: not shown")
    for col, c in (("alpha_f", "C2"), ("alpha_r", "C3")):
        ax.plot(t, np.where(slow, np.nan, np.degrees(tab[col].to_numpy(float))), color=c, label=col)
        if f"{col}_true" in df.columns:
            ax.plot(t, np.where(slow, np.nan, np.degrees(df[f"{col}_true"].to_numpy(float))), color=c,
                    ls="--", lw=0.8, label=f"{col}_true")
    ax.set_ylabel("slip angle [deg]")
    ax.legend(loc="upper right", ncol=4, fontsize=8)

    ax = axes[3]
    for axle, c in (("front", "C2"), ("rear", "C3")):
        ax.plot(t, tab[f"mu_{axle}"], color=c, label=f"mu_{axle}")
        ax.fill_between(t, tab[f"mu_{axle}_lower"], tab[f"mu_{axle}_upper"], color=c, alpha=0.15, lw=0)
        exc = tab.get(f"excited_{axle}")
        if exc is not None and exc.any():
            sel = exc.to_numpy(bool)
            ax.plot(t[sel], tab[f"mu_{axle}_obs"].to_numpy()[sel], ".", ms=2, color=c, alpha=0.4,
                    label=f"single-sample observations ({axle})")
    if "mu_true" in df.columns:
        ax.plot(t, df["mu_true"], color="k", ls="--", lw=1.0, label="mu_true")
    ax.set_ylabel("friction coefficient mu [-]")
    ax.set_xlabel("time [s]")
    ax.set_ylim(0.0, max(1.3, float(np.nanmax(tab[["mu_front", "mu_rear"]].to_numpy())) + 0.1))
    ax.legend(loc="upper right", ncol=3, fontsize=8)
    fit_suptitle(fig, f"Kalman cascade (paper 003): {drive.meta.source}", fontsize=11)
    return fig
