"""Generic report figures: input signals, friction traces with bands, tire curves,
classification traces and friction maps.

Every function returns a :class:`matplotlib.figure.Figure` (Agg backend) and
takes plain containers (a :class:`~roadgrip.drive.Drive`, an estimate table
following the output contract, a curve table, a cell table), so they work for
any estimator that writes the contract. Friction is always drawn in absolute
units (force over normal load), never normalised.
"""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from roadgrip.plots.scales import draw_no_data, friction_scale, no_data_handle, std_scale

__all__ = [
    "figure_png",
    "plot_classification",
    "plot_curves",
    "plot_friction_trace",
    "plot_map",
    "plot_signals",
]

_CLASS_COLOURS = {"high": "#2b8a3e", "low": "#c92a2a", "unknown": "#adb5bd"}


def figure_png(fig: Figure, dpi: int = 90) -> bytes:
    """Render ``fig`` to PNG bytes and close it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def _surface_spans(ax, t: np.ndarray, labels: np.ndarray | None) -> None:
    """Shade the time axis by true surface label."""
    if labels is None or len(labels) == 0:
        return
    names = list(dict.fromkeys(labels.tolist()))
    if len(names) < 2:
        return
    cmap = plt.get_cmap("Pastel1")
    change = np.flatnonzero(labels[1:] != labels[:-1]) + 1
    starts = np.r_[0, change]
    ends = np.r_[change, len(t) - 1]
    done = set()
    for s, e in zip(starts, ends, strict=True):
        name = labels[s]
        ax.axvspan(t[s], t[e], color=cmap(names.index(name) % 9), alpha=0.5, lw=0,
                   label=None if name in done else f"surface: {name}")
        done.add(name)


def _labels(drive) -> np.ndarray | None:
    return drive.data["surface"].astype(str).to_numpy() if drive is not None and drive.has("surface") else None


def plot_signals(drive, title: str | None = None) -> Figure:
    """The measured input signals of a drive, one panel per quantity.

    Panels (where present): accelerations ``ax``, ``ay`` [m/s²]; yaw rate
    [rad/s]; steering [deg at the road wheel]; speed ``vx`` and wheel speeds
    times radius [m/s]. The background shows the true surface, where known.
    """
    t = drive.t
    panels = []
    if drive.has("ax") or drive.has("ay"):
        panels.append(("acceleration [m/s²]", [(c, drive.col(c)) for c in ("ax", "ay") if drive.has(c)]))
    if drive.has("yaw_rate"):
        panels.append(("yaw rate [rad/s]", [("yaw_rate", drive.col("yaw_rate"))]))
    if drive.has("steer"):
        panels.append(("road-wheel steer [deg]", [("steer", np.degrees(drive.col("steer")))]))
    speeds = [(c, drive.col(c)) for c in ("vx",) if drive.has(c)]
    if drive.has_wheel_speeds:
        r = drive.vehicle.wheel_radius
        speeds += [(f"{c} · R", drive.col(c) * r) for c in ("omega_fl", "omega_rr")]
    if speeds:
        panels.append(("speed [m/s]", speeds))
    if not panels:
        panels.append(("(no signals)", []))
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 1.9 * len(panels) + 0.6), sharex=True,
                             squeeze=False)
    labels = _labels(drive)
    for ax, (ylabel, series) in zip(axes[:, 0], panels, strict=True):
        _surface_spans(ax, t, labels)
        for name, v in series:
            ax.plot(t, v, lw=0.8, label=name)
        ax.set_ylabel(ylabel, fontsize=8)
        ax.grid(alpha=0.3)
        if series:
            ax.legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("time [s]")
    fig.suptitle(title or f"input signals: {drive.meta.source}", fontsize=10)
    fig.tight_layout()
    return fig


def plot_friction_trace(table: pd.DataFrame, truth: dict[str, np.ndarray] | None = None,
                        title: str = "peak friction") -> Figure:
    """Peak-friction estimates per axle with their 95 % band over time.

    Parameters
    ----------
    table : DataFrame
        Contract columns ``t``, ``mu_front``, ``mu_rear``, ``mu_*_lower/upper``,
        optionally ``peak_observed_*`` and ``excited``.
    truth : dict, optional
        ``{'front': (n,), 'rear': (n,)}`` true peak friction at the table's times
        (an axle whose truth is NaN throughout draws none).
    """
    t = table["t"].to_numpy(float)
    fig, axes = plt.subplots(2, 1, figsize=(10, 5), sharex=True)
    for ax, axle, colour in zip(axes, ("front", "rear"), ("#1c7ed6", "#e8590c"), strict=True):
        if f"mu_{axle}" not in table or not np.isfinite(table[f"mu_{axle}"].to_numpy(float)).any():
            ax.text(0.5, 0.5, f"no {axle} estimate", ha="center", va="center", transform=ax.transAxes)
            continue
        mu = table[f"mu_{axle}"].to_numpy(float)
        lo = table[f"mu_{axle}_lower"].to_numpy(float)
        hi = table[f"mu_{axle}_upper"].to_numpy(float)
        if "excited" in table:
            exc = table["excited"].to_numpy(bool)
            ax.fill_between(t, 0, 1, where=exc, color="#ffe066", alpha=0.35, lw=0,
                            transform=ax.get_xaxis_transform(), label="excited")
        ax.fill_between(t, lo, hi, color=colour, alpha=0.25, lw=0, label="95 % band")
        ax.plot(t, mu, color=colour, lw=1.2, label=f"μ {axle} estimate")
        obs_col = f"peak_observed_{axle}"
        if obs_col in table:
            unobs = ~table[obs_col].to_numpy(bool)
            if unobs.any():
                ax.fill_between(t, 0, 0.03, where=unobs, color="#868e96", lw=0,
                                transform=ax.get_xaxis_transform(),
                                label="peak not observed: μ is a lower bound")
        if truth is not None and axle in truth and np.isfinite(np.asarray(truth[axle], float)).any():
            ax.plot(t, truth[axle], "k--", lw=1.0, label="true peak")
        ax.set_ylabel(f"μ {axle} [-]")
        top = np.nanmax(np.r_[hi[np.isfinite(hi)], 1.2]) if np.isfinite(hi).any() else 1.2
        ax.set_ylim(0, min(top * 1.05, 2.0))
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1].set_xlabel("time [s]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_curves(curves: pd.DataFrame, visited: dict[str, np.ndarray] | None = None,
                title: str = "learned tire curves") -> Figure:
    """Posterior friction curves μ(α) per axle at each stored time, with bands.

    Parameters
    ----------
    curves : DataFrame
        Columns ``t``, ``axle``, ``alpha`` [rad], ``mu_mean``, ``mu_lower``,
        ``mu_upper`` and optionally ``mu_true`` (drawn where finite).
    visited : dict, optional
        ``{'front': alpha_f, 'rear': alpha_r}`` visited slip angles [rad], drawn
        as a histogram under the curves.
    """
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    times = sorted(curves["t"].unique())
    cmap = plt.get_cmap("viridis")
    for ax, axle in zip(axes, ("front", "rear"), strict=True):
        for k, tc in enumerate(times):
            c = curves[(curves["t"] == tc) & (curves["axle"] == axle)].sort_values("alpha")
            if c.empty:
                continue
            a = np.degrees(c["alpha"].to_numpy(float))
            colour = cmap(k / max(len(times) - 1, 1))
            ax.fill_between(a, c["mu_lower"], c["mu_upper"], color=colour, alpha=0.15, lw=0)
            ax.plot(a, c["mu_mean"], color=colour, lw=1.3, label=f"t = {tc:.0f} s")
            # the truth where it is defined (a binned truth is NaN outside its visited bins)
            if k == len(times) - 1 and "mu_true" in c and np.isfinite(c["mu_true"].to_numpy(float)).any():
                ax.plot(a, c["mu_true"], "k--", lw=1.0, label="truth")
        if visited is not None and axle in visited and len(visited[axle]):
            ax2 = ax.twinx()
            ax2.hist(np.degrees(visited[axle]), bins=60, color="#adb5bd", alpha=0.4,
                     label="visited slip angles")
            ax2.set_yticks([])
            ax.set_zorder(ax2.get_zorder() + 1)
            ax.patch.set_visible(False)
        ax.set_xlabel(f"slip angle α {axle} [deg]")
        ax.grid(alpha=0.3)
        ax.set_title(axle, fontsize=9)
        ax.legend(fontsize=7, loc="lower right")
    axes[0].set_ylabel("μ = Fy / Fz [-]")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_classification(table: pd.DataFrame, truth_class: np.ndarray | None = None,
                        signals: dict[str, np.ndarray] | None = None,
                        title: str = "grip classification", *,
                        truth_label: str = "true class (high/low)") -> Figure:
    """Grip class and grip index over time, with the excitation flag and the truth.

    Parameters
    ----------
    table : DataFrame
        Contract columns ``t``, ``grip_class``, ``grip_index``, ``excited``.
    truth_class : ndarray of str, optional
        True class at the table's times.
    truth_label : str
        Its legend entry (a real drive's reference is a label of the floor, not a truth).
    signals : dict, optional
        Name -> (n,) signal to draw above the trace (e.g. ``ax``, ``ay``).
    """
    t = table["t"].to_numpy(float)
    n_top = 1 if signals else 0
    fig, axes = plt.subplots(n_top + 1, 1, figsize=(10, 2.2 * (n_top + 1) + 0.8), sharex=True,
                             squeeze=False)
    if signals:
        ax = axes[0, 0]
        for name, v in signals.items():
            ax.plot(t, v, lw=0.7, label=name)
        ax.set_ylabel("[m/s²]")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    ax = axes[-1, 0]
    cls = table["grip_class"].astype(str).to_numpy() if "grip_class" in table else np.full(len(t), "unknown")
    for name, colour in _CLASS_COLOURS.items():
        sel = cls == name
        if sel.any():
            ax.fill_between(t, 0, 1, where=sel, color=colour, alpha=0.25, lw=0,
                            transform=ax.get_xaxis_transform(), label=f"class {name}")
    if "grip_index" in table:
        ax.plot(t, table["grip_index"].to_numpy(float), color="k", lw=1.0, label="grip index")
    if "excited" in table:
        exc = table["excited"].to_numpy(bool)
        ax.plot(t, np.where(exc, 1.04, np.nan), color="#f59f00", lw=3, label="excited")
    if truth_class is not None:
        ax.step(t, np.where(np.asarray(truth_class) == "high", 0.95, 0.05), where="post",
                color="#364fc7", ls="--", lw=1.0, label=truth_label)
    ax.set_ylim(-0.02, 1.08)
    ax.set_ylabel("grip index [-]")
    ax.set_xlabel("time [s]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="lower right", ncol=3)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def plot_map(cells: pd.DataFrame, cell_size: float, path: tuple[np.ndarray, np.ndarray] | None = None,
             *, min_obs: int = 1, title: str = "friction map") -> Figure:
    """Heat map of cell friction (absolute μ) and of its standard deviation.

    Colours are the shared scales of :mod:`roadgrip.plots.scales` (the ``roadgrip map``
    figure uses the same). Cells with fewer than ``min_obs`` observations, and the
    area around the observed cells that the axes show, are drawn as no data (hatched
    grey) in both panels.

    Parameters
    ----------
    cells : DataFrame
        Columns ``x``, ``y`` (cell centres, m), ``mu_mean``, ``mu_std``, ``n_obs``.
    cell_size : float
        Cell edge [m].
    path : (x, y), optional
        Driven path [m], drawn as a thin line; the axes cover it.
    min_obs : int
        Fewest observations of a cell with data.
    """
    fig, axes = plt.subplots(1, 2, figsize=(11, 5.2), layout="constrained")
    x = cells["x"].to_numpy(float)
    y = cells["y"].to_numpy(float)
    obs = cells["n_obs"].to_numpy(float) >= max(min_obs, 1)
    # Cells onto a raster (cell centres sit on a lattice of pitch cell_size).
    if len(x):
        ix = np.round((x - x.min()) / cell_size).astype(int)
        iy = np.round((y - y.min()) / cell_size).astype(int)
        shape = (iy.max() + 1, ix.max() + 1)
        extent = (x.min() - cell_size / 2, x.min() + (shape[1] - 0.5) * cell_size,
                  y.min() - cell_size / 2, y.min() + (shape[0] - 0.5) * cell_size)
    bounds = [list(extent)] if len(x) else []
    if path is not None:
        px, py = np.asarray(path[0], float), np.asarray(path[1], float)
        ok = np.isfinite(px) & np.isfinite(py)
        if ok.any():
            bounds.append([px[ok].min(), px[ok].max(), py[ok].min(), py[ok].max()])
    for ax, col, label, (cmap, norm) in ((axes[0], "mu_mean", "μ [-] (absolute)", friction_scale()),
                                         (axes[1], "mu_std", "μ std [-]", std_scale())):
        draw_no_data(ax)
        if len(x):
            img = np.full(shape, np.nan)
            v = cells[col].to_numpy(float)
            img[iy[obs], ix[obs]] = v[obs]
            ax.imshow(img, origin="lower", extent=extent, cmap=cmap, norm=norm, interpolation="nearest")
        if path is not None:
            ax.plot(path[0], path[1], color="k", lw=0.4, alpha=0.5, label="driven path")
        if bounds:
            b = np.asarray(bounds)
            ax.set_xlim(b[:, 0].min() - cell_size, b[:, 1].max() + cell_size)
            ax.set_ylim(b[:, 2].min() - cell_size, b[:, 3].max() + cell_size)
        ax.set_aspect("equal")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label=label, shrink=0.8,
                     extend="max")
    axes[0].set_title("posterior mean", fontsize=9)
    axes[1].set_title("uncertainty", fontsize=9)
    handles = [no_data_handle(), *axes[0].get_lines()[:1]]
    fig.legend(handles=handles, loc="outside lower center", ncol=len(handles), fontsize=8)
    fig.suptitle(title, fontsize=10)
    return fig
