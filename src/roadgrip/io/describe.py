r"""``describe_drive``: the summary printed by ``roadgrip info``.

Besides duration, rate and signal ranges it reports how much of the drive
excites the tire in its nonlinear region (:func:`nonlinear_fraction`):

* With simulation truth: the fraction of samples where ``|alpha_f_true|`` is
  beyond ``alpha_80``, the front slip angle at which the true front friction
  curve (of the surface under the vehicle at that sample) reaches 80 % of its
  peak.
* Without truth, two proxies on the measured signals (smoothed by a centred
  0.2 s moving average against sensor noise):

  - ``ay``: the fraction of samples with ``|ay| > level * mu_peak * g``
    (``level`` 0.5; ``mu_peak`` given, or assumed 1.0 for a dry surface: an
    underestimate on slippery ground);
  - ``yaw``: the linear single-track model (paper 000 eq. 1 with the
    vehicle's axle cornering stiffnesses, :func:`linear_yaw_rate`) is driven by
    the measured ``steer`` and ``vx``; among samples with ``vx > 1 m/s`` and a
    model yaw rate above 0.1 rad/s, the fraction where the measured yaw rate
    departs from the model's by more than 25 %. Unlike a steady-state formula
    it follows transients (slaloms), so a departure means the tires left their
    linear range, or the vehicle's stiffnesses do not fit the surface. It needs
    ``yaw_rate``, ``steer`` and ``vx``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rich.console import Group
from rich.table import Table

from roadgrip.constants import GRAVITY
from roadgrip.drive import SIGNAL_COLUMNS, TRUTH_COLUMNS, Drive
from roadgrip.tire import FrictionModel
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "Excitation",
    "describe_drive",
    "linear_yaw_rate",
    "nonlinear_fraction",
    "slip_at_fraction_of_peak",
]

UNITS = {
    "t": "s",
    "ax": "m/s²",
    "ay": "m/s²",
    "yaw_rate": "rad/s",
    "steer": "rad",
    "vx": "m/s",
    "omega_fl": "rad/s",
    "omega_fr": "rad/s",
    "omega_rl": "rad/s",
    "omega_rr": "rad/s",
    "x": "m",
    "y": "m",
    "psi": "rad",
    "vx_true": "m/s",
    "vy_true": "m/s",
    "yaw_rate_true": "rad/s",
    "alpha_f_true": "rad",
    "alpha_r_true": "rad",
    "mu_true": "-",
    "Fxf_true": "N",
    "Fxr_true": "N",
    "Fyf_true": "N",
    "Fyr_true": "N",
    "Fzf_true": "N",
    "Fzr_true": "N",
}
for _w in ("fl", "fr", "rl", "rr"):
    UNITS[f"kappa_{_w}_true"] = "-"


def linear_yaw_rate(
    t: np.ndarray, steer: np.ndarray, vx: np.ndarray, params: VehicleParams
) -> np.ndarray:
    """Yaw rate of the linear single-track model driven by measured inputs.

    The lateral model of paper 000 (eq. 1) with linear axle forces
    ``F = C alpha`` (linearised slip angles) is integrated with the implicit
    (backward) Euler step, which stays stable at any step and low speed; the
    speed is floored at 0.5 m/s. Its steady state is
    :func:`~roadgrip.vehicle.steady_state_linear`.

    Parameters
    ----------
    t, steer, vx : ndarray, shape (n,)
        Time [s], road-wheel angle [rad], longitudinal speed [m/s].
    params : VehicleParams
        Mass, inertia, ``lf``, ``lr`` and the axle cornering stiffnesses.

    Returns
    -------
    ndarray, shape (n,)
        Model yaw rate [rad/s], starting from rest (``vy = r = 0``).
    """
    m, iz, a, b = params.mass, params.yaw_inertia, params.lf, params.lr
    cf, cr = params.cornering_stiffness_front, params.cornering_stiffness_rear
    n = len(t)
    out = np.zeros(n)
    vy = r = 0.0
    dts = np.diff(t, prepend=t[0])
    for k in range(1, n):
        dt = float(dts[k])
        u = max(float(vx[k]), 0.5)
        d = float(steer[k])
        # dx/dt = A x + B d with x = [vy, r]
        a11 = -(cf + cr) / (m * u)
        a12 = -u - (cf * a - cr * b) / (m * u)
        a21 = -(cf * a - cr * b) / (iz * u)
        a22 = -(cf * a * a + cr * b * b) / (iz * u)
        b1, b2 = cf / m, cf * a / iz
        # (I - dt A) x_new = x + dt B d
        m11, m12, m21, m22 = 1 - dt * a11, -dt * a12, -dt * a21, 1 - dt * a22
        r1, r2 = vy + dt * b1 * d, r + dt * b2 * d
        det = m11 * m22 - m12 * m21
        vy, r = (r1 * m22 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det
        out[k] = r
    return out


def slip_at_fraction_of_peak(model: FrictionModel, fraction: float = 0.8) -> float:
    """Smallest positive slip where ``mu`` reaches ``fraction`` of its peak.

    Parameters
    ----------
    model : FrictionModel
    fraction : float
        In (0, 1).

    Returns
    -------
    float
        Slip [rad or -]; ``inf`` when the curve never gets there.
    """
    from scipy.optimize import brentq

    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be in (0, 1), got {fraction!r}")
    s_peak, mu_peak = model.peak()
    target = fraction * mu_peak
    hi = s_peak if np.isfinite(s_peak) else 1.0
    while float(model.mu(hi)) < target:
        hi *= 2.0
        if hi > 1e3:
            return float("inf")
    return float(brentq(lambda s: float(model.mu(s)) - target, 0.0, hi, xtol=1e-12))


@dataclass(frozen=True)
class Excitation:
    """Nonlinear excitation of a drive.

    Attributes
    ----------
    fraction : float
        Fraction of samples in the nonlinear region [-] (NaN where undefined).
    method : str
        ``'truth'``, ``'ay'`` or ``'yaw'``.
    detail : str
        The threshold used, in words.
    """

    fraction: float
    method: str
    detail: str


def _smooth(v: np.ndarray, t: np.ndarray, window: float = 0.2) -> np.ndarray:
    if len(t) < 3:
        return v
    n = round(window / float(np.median(np.diff(t))))
    if n < 2:
        return v
    k = np.ones(n) / n
    pad = np.pad(v, (n // 2, n - 1 - n // 2), mode="edge")
    return np.convolve(pad, k, mode="valid")


def nonlinear_fraction(
    drive: Drive, *, mu_peak: float | None = None, level: float = 0.5
) -> list[Excitation]:
    """How much of a drive excites the tire nonlinearly (module docstring).

    Parameters
    ----------
    drive : Drive
    mu_peak : float, optional
        Peak friction for the ``ay`` proxy (default 1.0, assumed).
    level : float
        Fraction of ``mu_peak * g`` above which ``|ay|`` counts as nonlinear.

    Returns
    -------
    list of Excitation
        The truth measure when available, then the proxies the signals allow.
    """
    out: list[Excitation] = []
    data = drive.data
    if drive.has_truth and "alpha_f_true" in data.columns and "surfaces" in (drive.meta.truth or {}):
        alpha = np.abs(drive.col("alpha_f_true"))
        if "surface" in data.columns:
            labels = data["surface"].astype(str).to_numpy()
        else:
            labels = np.full(len(alpha), next(iter(drive.meta.truth["surfaces"])))
        thresh = np.empty(len(alpha))
        parts = []
        for lab in np.unique(labels):
            a80 = slip_at_fraction_of_peak(drive.true_tire("front", surface=str(lab)), 0.8)
            thresh[labels == lab] = a80
            parts.append(f"{lab}: {a80:.4f} rad")
        out.append(
            Excitation(
                float(np.mean(alpha > thresh)),
                "truth",
                "|alpha_f_true| beyond the slip of 80 % of the true front peak (" + ", ".join(parts) + ")",
            )
        )
    t = drive.t
    if "ay" in data.columns:
        mu = 1.0 if mu_peak is None else float(mu_peak)
        thr = level * mu * GRAVITY
        ay = _smooth(drive.col("ay"), t)
        assumed = "assumed" if mu_peak is None else "given"
        out.append(
            Excitation(
                float(np.mean(np.abs(ay) > thr)),
                "ay",
                f"|ay| > {level:.0%} of {assumed} peak mu = {mu:g} ({thr:.2f} m/s²)",
            )
        )
    if drive.has("yaw_rate", "steer", "vx"):
        vx = _smooth(drive.col("vx"), t)
        r = _smooth(drive.col("yaw_rate"), t)
        r_lin = linear_yaw_rate(t, _smooth(drive.col("steer"), t), vx, drive.vehicle)
        sel = (vx > 1.0) & (np.abs(r_lin) > 0.1)
        frac = float(np.mean(np.abs(r[sel] - r_lin[sel]) > 0.25 * np.abs(r_lin[sel]))) if sel.any() else float("nan")
        out.append(
            Excitation(
                frac,
                "yaw",
                f"|yaw_rate - linear model| > 25 % (over {sel.mean():.0%} of samples: "
                "vx > 1 m/s, |r_model| > 0.1 rad/s)",
            )
        )
    return out


def _fmt(v: float) -> str:
    return f"{v:.4g}"


def describe_drive(drive: Drive, *, mu_peak: float | None = None) -> Group:
    """A rich renderable summary of a drive (``roadgrip info``).

    Parameters
    ----------
    drive : Drive
    mu_peak : float, optional
        Peak friction for the ``ay`` excitation proxy (see :func:`nonlinear_fraction`).

    Returns
    -------
    rich.console.Group
        An overview table, a per-signal table (unit, min, max, mean) and the
        excitation table.
    """
    t = drive.t
    dt = np.diff(t)
    over = Table(title=f"drive: {drive.meta.source}", show_header=False)
    over.add_column("item", style="bold")
    over.add_column("value")
    over.add_row("vehicle", drive.vehicle.name)
    over.add_row("samples", str(drive.n))
    over.add_row("duration", f"{drive.duration:.2f} s")
    if len(dt):
        med = float(np.median(dt))
        jitter = float(np.std(dt)) / med
        over.add_row(
            "sample rate",
            f"{1.0 / med:.2f} Hz (dt median {med * 1e3:.2f} ms, jitter std/median {jitter:.1%}, "
            f"min {dt.min() * 1e3:.2f} ms, max {dt.max() * 1e3:.2f} ms)",
        )
    over.add_row("truth", "yes" if drive.has_truth else "no")
    over.add_row("pose", "yes" if drive.has_pose else "no")
    over.add_row("wheel speeds", "yes" if drive.has_wheel_speeds else "no")
    extra_cols = drive.extra_columns
    over.add_row("extra columns", ", ".join(extra_cols) if extra_cols else "none")
    fmt = drive.meta.extra.get("format") if isinstance(drive.meta.extra, dict) else None
    if fmt:
        over.add_row("format", str(fmt))

    sig = Table(title="signals")
    for name, just in (("column", "left"), ("unit", "left"), ("min", "right"), ("max", "right"), ("mean", "right")):
        sig.add_column(name, justify=just)
    known = [c for c in (*SIGNAL_COLUMNS, *TRUTH_COLUMNS) if c in drive.data.columns and c != "surface"]
    for c in known:
        v = drive.col(c)
        sig.add_row(c, UNITS.get(c, ""), _fmt(v.min()), _fmt(v.max()), _fmt(v.mean()))
    if "surface" in drive.data.columns:
        counts = drive.data["surface"].astype(str).value_counts(normalize=True)
        sig.add_row("surface", "-", ", ".join(f"{k} {p:.0%}" for k, p in counts.items()), "", "")
    for c in extra_cols:
        col = drive.data[c]
        if col.dtype.kind in "fiub":
            v = col.to_numpy(float)
            sig.add_row(f"{c} (extra)", "", _fmt(np.nanmin(v)), _fmt(np.nanmax(v)), _fmt(np.nanmean(v)))

    exc = Table(title="nonlinear tire excitation")
    exc.add_column("measure")
    exc.add_column("time fraction", justify="right")
    exc.add_column("definition")
    for e in nonlinear_fraction(drive, mu_peak=mu_peak):
        exc.add_row(e.method, "n/a" if not np.isfinite(e.fraction) else f"{e.fraction:.1%}", e.detail)
    return Group(over, sig, exc)
