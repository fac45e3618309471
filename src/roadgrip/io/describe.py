r"""``describe_drive``: the summary printed by ``roadgrip info``.

Besides duration, rate and signal ranges it reports how much of the drive
excites the tire in its nonlinear region (:func:`nonlinear_fraction`):

* With simulation truth: the fraction of samples where ``|alpha_f_true|`` is
  beyond ``alpha_80``, the front slip angle at which the true front friction
  curve (of the surface under the vehicle at that sample) reaches 80 % of its
  peak. A drive whose truth carries no parametric tire curve (binned truth, see
  :mod:`roadgrip.truth`) has no ``alpha_80``; there the measure is the
  fraction of samples whose front friction utilisation ``|F| / (mu Fz)``
  exceeds 80 % (:func:`~roadgrip.truth.friction_utilisation`), among
  the samples where it is defined, and it is reported as skipped when the drive
  carries no utilisation either.
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

It also reports the friction utilisation per axle (:func:`utilisation_shares`):
the fraction of samples above 50 % and above 80 % of the available friction,
from the ``util_f_true`` / ``util_r_true`` columns when present, otherwise
``hypot(Fx, Fy) / (mu_true Fz)`` from the axle forces (samples with ``Fz <= 0``
have no utilisation and are left out of the fractions). At a uniform sample rate
a fraction of samples is a fraction of time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from roadgrip.constants import GRAVITY
from roadgrip.drive import SIGNAL_COLUMNS, TRUTH_COLUMNS, Drive
from roadgrip.tire import FrictionModel
from roadgrip.truth import friction_utilisation, has_parametric_truth, utilisation_source
from roadgrip.vehicle.params import VehicleParams

__all__ = [
    "UTILISATION_LEVELS",
    "Excitation",
    "Section",
    "UtilisationShare",
    "describe_drive",
    "format_text",
    "linear_yaw_rate",
    "nonlinear_fraction",
    "slip_at_fraction_of_peak",
    "utilisation_shares",
]

UTILISATION_LEVELS = (0.5, 0.8)
"""Friction utilisation levels [-] whose exceedance ``roadgrip info`` reports per axle."""

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
    truth = drive.meta.truth or {}
    parametric = has_parametric_truth(drive, "front")
    if parametric and "alpha_f_true" in data.columns:
        alpha = np.abs(drive.col("alpha_f_true"))
        if "surface" in data.columns:
            labels = data["surface"].astype(str).to_numpy()
        else:
            labels = np.full(len(alpha), next(iter(drive.meta.truth["surfaces"])))
        thresh = np.empty(len(alpha))
        parts = []
        known_surfaces = set(truth.get("surfaces") or {})
        for lab in np.unique(labels):
            if str(lab) not in known_surfaces:  # a label the truth does not describe (cut file)
                thresh[labels == lab] = np.inf
                parts.append(f"{lab}: no true curve")
                continue
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
    elif drive.has_truth and not parametric and ("surfaces" in truth or "truth_curve" in truth):
        why = "the drive's truth has no parametric tire curve"
        src = utilisation_source(drive, "front")
        if src is None:
            out.append(Excitation(
                float("nan"), "truth",
                f"skipped: {why} (no slip of 80 % of its peak) and no front utilisation "
                "(util_f_true, or Fxf/Fyf/Fzf_true and mu_true)"))
        else:
            u = friction_utilisation(drive, "front")
            ok = np.isfinite(u)
            frac = float(np.mean(u[ok] > 0.8)) if ok.any() else float("nan")
            out.append(Excitation(
                frac, "truth",
                f"front friction utilisation |F| / (mu Fz) > 80 % ({_UTIL_FROM[src]('f')}; "
                f"{why}, so no slip of 80 % of its peak)"))
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


_UTIL_FROM = {
    "column": lambda a: f"util_{a}_true",
    "computed": lambda a: f"hypot(Fx{a}, Fy{a}) / (mu_true Fz{a})",
}


@dataclass(frozen=True)
class UtilisationShare:
    """How much of a drive an axle spends near its friction limit.

    Attributes
    ----------
    axle : str
        ``'front'`` or ``'rear'``.
    source : str
        ``'column'`` (``util_<a>_true``) or ``'computed'`` (axle forces and ``mu_true``).
    above : dict of float to float
        Utilisation level [-] -> fraction of samples strictly above it [-], among the
        samples where the utilisation is defined (NaN when it is defined nowhere).
    defined : float
        Fraction of all samples where the utilisation is defined [-].
    """

    axle: str
    source: str
    above: dict[float, float]
    defined: float


def utilisation_shares(
    drive: Drive, levels: tuple[float, ...] = UTILISATION_LEVELS
) -> list[UtilisationShare]:
    """Per axle, the fraction of samples above each friction-utilisation level.

    Parameters
    ----------
    drive : Drive
        Utilisation from ``util_f_true`` / ``util_r_true``, otherwise computed from
        ``Fx*_true``, ``Fy*_true``, ``Fz*_true`` and ``mu_true``
        (:func:`roadgrip.truth.friction_utilisation`).
    levels : tuple of float
        Utilisation levels [-].

    Returns
    -------
    list of UtilisationShare
        One per axle that has a utilisation (empty for a drive without).
    """
    out = []
    for axle in ("front", "rear"):
        src = utilisation_source(drive, axle)
        if src is None:
            continue
        u = friction_utilisation(drive, axle)
        ok = np.isfinite(u)
        above = {float(lv): float(np.mean(u[ok] > lv)) if ok.any() else float("nan")
                 for lv in levels}
        out.append(UtilisationShare(axle, src, above, float(np.mean(ok)) if len(u) else float("nan")))
    return out


def _fmt(v: float) -> str:
    return f"{v:.4g}"


@dataclass(frozen=True)
class Section:
    """One table of a drive description.

    Attributes
    ----------
    title : str
    columns : tuple of str
        Column names.
    rows : tuple of tuple of str
        Formatted cells, one tuple per row.
    right : frozenset of str
        Columns aligned right (numbers).
    header : bool
        Whether the column names are shown (the overview is a key-value list).
    """

    title: str
    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    right: frozenset[str] = frozenset()
    header: bool = True


def describe_drive(drive: Drive, *, mu_peak: float | None = None) -> list[Section]:
    """The summary of a drive that ``roadgrip info`` prints, as formatted tables.

    Parameters
    ----------
    drive : Drive
    mu_peak : float, optional
        Peak friction for the ``ay`` excitation proxy (see :func:`nonlinear_fraction`).

    Returns
    -------
    list of Section
        An overview, a per-signal table (unit, min, max, mean), the excitation
        table and, when the drive carries it, the friction utilisation table
        (:func:`utilisation_shares`). :func:`format_text` renders them as text.
    """
    t = drive.t
    dt = np.diff(t)
    over: list[tuple[str, ...]] = [
        ("vehicle", str(drive.vehicle.name)),
        ("samples", str(drive.n)),
        ("duration", f"{drive.duration:.2f} s"),
    ]
    if len(dt):
        med = float(np.median(dt))
        jitter = float(np.std(dt)) / med
        over.append((
            "sample rate",
            f"{1.0 / med:.2f} Hz (dt median {med * 1e3:.2f} ms, jitter std/median {jitter:.1%}, "
            f"min {dt.min() * 1e3:.2f} ms, max {dt.max() * 1e3:.2f} ms)",
        ))
    over.append(("truth", "yes" if drive.has_truth else "no"))
    over.append(("pose", "yes" if drive.has_pose else "no"))
    over.append(("wheel speeds", "yes" if drive.has_wheel_speeds else "no"))
    extra_cols = drive.extra_columns
    over.append(("extra columns", ", ".join(extra_cols) if extra_cols else "none"))
    fmt = drive.meta.extra.get("format") if isinstance(drive.meta.extra, dict) else None
    if fmt:
        over.append(("format", str(fmt)))

    sig: list[tuple[str, ...]] = []
    known = [c for c in (*SIGNAL_COLUMNS, *TRUTH_COLUMNS) if c in drive.data.columns and c != "surface"]
    for c in known:
        v = drive.col(c)
        sig.append((c, UNITS.get(c, ""), _fmt(v.min()), _fmt(v.max()), _fmt(v.mean())))
    if "surface" in drive.data.columns:
        counts = drive.data["surface"].astype(str).value_counts(normalize=True)
        sig.append(("surface", "-", ", ".join(f"{k} {p:.0%}" for k, p in counts.items()), "", ""))
    for c in extra_cols:
        col = drive.data[c]
        if col.dtype.kind in "fiub":
            v = col.to_numpy(float)
            sig.append((f"{c} (extra)", "", _fmt(np.nanmin(v)), _fmt(np.nanmax(v)), _fmt(np.nanmean(v))))

    exc = [(e.method, "n/a" if not np.isfinite(e.fraction) else f"{e.fraction:.1%}", e.detail)
           for e in nonlinear_fraction(drive, mu_peak=mu_peak)]
    sections = [
        Section(f"drive: {drive.meta.source}", ("item", "value"), tuple(over), header=False),
        Section("signals", ("column", "unit", "min", "max", "mean"), tuple(sig),
                right=frozenset({"min", "max", "mean"})),
        Section("nonlinear tire excitation", ("measure", "time fraction", "definition"), tuple(exc),
                right=frozenset({"time fraction"})),
    ]
    shares = utilisation_shares(drive)
    if shares:
        levels = tuple(f"time > {lv:.0%}" for lv in UTILISATION_LEVELS)
        rows = []
        for sh in shares:
            src = _UTIL_FROM[sh.source](sh.axle[0])
            if sh.defined < 1.0:
                src += f" (defined at {sh.defined:.1%} of the samples)"
            rows.append((sh.axle, *("n/a" if not np.isfinite(f) else f"{f:.1%}"
                                    for f in sh.above.values()), src))
        sections.append(Section("friction utilisation |F| / (mu Fz) (truth)",
                                ("axle", *levels, "from"), tuple(rows), right=frozenset(levels)))
    return sections


def format_text(sections: list[Section]) -> str:
    """Plain-text rendering of :func:`describe_drive`: each table titled, columns padded."""
    out = []
    for sec in sections:
        rows = [sec.columns, *sec.rows] if sec.header else list(sec.rows)
        widths = [max((len(r[i]) for r in rows), default=0) for i in range(len(sec.columns))]
        out.append(sec.title)
        for r in rows:
            cells = [c.rjust(w) if name in sec.right else c.ljust(w)
                     for c, w, name in zip(r, widths, sec.columns, strict=True)]
            out.append("  " + "  ".join(cells).rstrip())
        out.append("")
    return "\n".join(out)
