"""Classification trace over the driving signals (paper 002, Fig. 12-13 style)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from roadgrip.drive import Drive
from roadgrip.estimators.base import EstimateResult

__all__ = ["plot_result"]


def _shade(ax, t: np.ndarray, mask: np.ndarray, color: str, label: str | None = None) -> None:
    """Shade the time spans where ``mask`` holds."""
    m = np.asarray(mask, bool)
    if not m.any():
        return
    edges = np.flatnonzero(np.diff(np.r_[0, m.astype(int), 0]))
    for k, (a, b) in enumerate(zip(edges[::2], edges[1::2], strict=True)):
        ax.axvspan(t[a], t[min(b, len(t) - 1)], color=color, alpha=0.15, lw=0,
                   label=label if k == 0 else None)


def plot_result(drive: Drive, result: EstimateResult, path: str | Path) -> None:
    """Write a PNG: accelerations, slips, the channel estimates, and the class trace.

    Panels (time on the shared axis): measured ``ax``/``ay`` (and the kinematic
    lateral acceleration where the classifier used it) with the excited
    samples shaded; the slip regressors; for bRLS the two stiffness estimates
    (``theta_long``, ``theta_lat``), for slipmap the reliability weights; the
    grip index with the class (high = 1, low = 0, unknown = 0.5) and, for
    simulated drives, the true class.

    Parameters
    ----------
    drive : Drive
        The classified drive.
    result : EstimateResult
        Output of the ``brls`` or ``slipmap`` estimator
        (:mod:`roadgrip.estimators.classify`) on ``drive``.
    path : str or Path
        Output PNG.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    table = result.table
    t = table["t"].to_numpy(float)
    fig, axs = plt.subplots(4, 1, figsize=(11, 9), sharex=True)
    exc = table["excited"].to_numpy(bool)
    a0 = axs[0]
    if drive.has("ax"):
        a0.plot(t, drive.col("ax"), lw=0.6, label="ax")
    if drive.has("ay"):
        a0.plot(t, drive.col("ay"), lw=0.6, label="ay")
    if "ay_used" in table.columns and drive.has("ay") and not np.allclose(
        table["ay_used"].to_numpy(float), drive.col("ay")
    ):
        a0.plot(t, table["ay_used"].to_numpy(float), lw=0.8, label="ay used (r vx + dvy/dt)")
    _shade(a0, t, exc, "tab:orange", "excited")
    a0.set_ylabel("acceleration [m/s²]")
    a0.legend(loc="upper right", fontsize=8)

    a1 = axs[1]
    for col, lab in (("phi_long", "sum of wheel slips [-]"), ("phi_lat", "lateral regressor [rad]"),
                     ("kappa_used", "κ used [-]"), ("alpha_f_hat", "αf [rad]"),
                     ("alpha_r_hat", "αr [rad]")):
        if col in table.columns:
            a1.plot(t, table[col].to_numpy(float), lw=0.6, label=lab)
    a1.set_ylabel("slip")
    a1.legend(loc="upper right", fontsize=8)

    a2 = axs[2]
    if np.isfinite(table.get("theta_lat", pd.Series([np.nan])).to_numpy(float)).any():
        a2.plot(t, table["theta_long"], lw=0.8, label="θ long [m/s²]")
        a2.plot(t, table["theta_lat"], lw=0.8, label="θ lat [m/s²/rad]")
        a2.set_ylabel("stiffness estimate")
    else:
        for col in ("w_x", "w_y"):
            if col in table.columns:
                a2.plot(t, table[col], lw=0.6, label=f"reliability {col}")
        a2.set_ylabel("weight (eq. 9)")
    a2.legend(loc="upper right", fontsize=8)

    a3 = axs[3]
    cls = table["grip_class"].astype(str).to_numpy()
    level = np.where(cls == "high", 1.0, np.where(cls == "low", 0.0, 0.5))
    a3.plot(t, table["grip_index"], lw=0.8, label="grip index")
    a3.step(t, level, where="post", lw=1.2, label="class (1 high, 0 low, 0.5 unknown)")
    if "mu_true" in drive.data.columns:
        from roadgrip.evaluate.metrics import truth_grip_class

        truth = truth_grip_class(drive.col("mu_true"))
        a3.step(t, np.where(truth == "high", 1.0, 0.0) + 0.02, where="post", ls="--", lw=1.0,
                color="k", label="true class")
    a3.set_ylim(-0.1, 1.15)
    a3.set_ylabel("grip")
    a3.set_xlabel("time [s]")
    a3.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"{result.method} friction classification: {drive.meta.source}", fontsize=10)
    fig.tight_layout()
    fig.savefig(str(path), dpi=110)
    plt.close(fig)
