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

import math
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from roadgrip.constants import GRAVITY
from roadgrip.drive import SIGNAL_COLUMNS, TRUTH_COLUMNS, Drive
from roadgrip.drive_units import PAIRS, pair_ratios
from roadgrip.io.sections import Section, format_text
from roadgrip.tire import FrictionModel, bracketed_root
from roadgrip.truth import friction_utilisation, has_parametric_truth, utilisation_source
from roadgrip.vehicle.params import VehicleParams, driven_wheels

__all__ = [
    "UTILISATION_LEVELS",
    "Excitation",
    "Section",
    "UtilisationShare",
    "describe_chunks",
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
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be in (0, 1), got {fraction!r}")
    s_peak, mu_peak = model.peak()
    target = fraction * mu_peak
    hi = s_peak if np.isfinite(s_peak) else 1.0
    while float(model.mu(hi)) < target:
        hi *= 2.0
        if hi > 1e3:
            return float("inf")
    return bracketed_root(lambda s: float(model.mu(s)) - target, 0.0, hi, xtol=1e-12)


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
    samples : int
        Samples the fraction is taken over (its denominator).
    """

    fraction: float
    method: str
    detail: str
    samples: int = 0


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
                len(alpha),
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
                f"{why}, so no slip of 80 % of its peak)", int(ok.sum())))
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
                len(ay),
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
                YAW_DETAIL.format(share=sel.mean()),
                int(sel.sum()),
            )
        )
    return out


YAW_DETAIL = ("|yaw_rate - linear model| > 25 % (over {share:.0%} of samples: "
              "vx > 1 m/s, |r_model| > 0.1 rad/s)")

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
    return describe_chunks([drive], mu_peak=mu_peak)


def describe_chunks(chunks: Iterable[Drive], *, mu_peak: float | None = None) -> list[Section]:
    """:func:`describe_drive` of a drive given as consecutive chunks (a long file read piece
    by piece), in memory of one chunk.

    Counts, extremes, means and fractions are those of the whole drive; the median step is
    the median of the chunks' medians (exact for one chunk), and the ``yaw`` proxy's linear
    model starts afresh in each chunk (a transient of about a second per chunk).
    """
    acc = _Summary(mu_peak)
    for chunk in chunks:
        acc.add(chunk)
    if acc.first is None:
        raise ValueError("no samples to describe")
    return acc.sections()


def _merge_details(details: list[str]) -> str:
    """``'text (a: 1, b: 2)'`` details of chunks joined into one, their listed items united
    (sorted, as one drive lists its surfaces); unlike texts are joined by ``'; '``."""
    heads = {d.partition(" (")[0] for d in details}
    if len(heads) != 1 or not all(d.endswith(")") for d in details):
        return "; ".join(details)
    items = sorted({item for d in details for item in d.partition(" (")[2][:-1].split(", ")})
    return f"{heads.pop()} ({', '.join(items)})"


class _Summary:
    """Running aggregates of :func:`describe_chunks`."""

    def __init__(self, mu_peak: float | None) -> None:
        self.mu_peak = mu_peak
        self.first: Drive | None = None
        self.n = 0
        self.t0 = self.t1 = math.nan
        self.dt_med: list[float] = []
        self.dt_w: list[int] = []
        self.dt_sum = self.dt_sq = 0.0
        self.dt_min, self.dt_max = math.inf, -math.inf
        self.cols: dict[str, list[float]] = {}  # min, max, sum, count
        self.surface: Counter[str] = Counter()
        self.exc: dict[str, list] = {}  # method -> [hits, samples, details]
        self.util: dict[str, list] = {}  # axle -> [source, hits per level, defined, total]

    def add(self, drive: Drive) -> None:
        if drive.n == 0:
            return
        t = drive.t
        if self.first is None:
            self.first, self.t0 = drive, float(t[0])
            dt = np.diff(t)
        else:
            dt = np.diff(np.concatenate([[self.t1], t]))
        self.t1 = float(t[-1])
        self.n += drive.n
        if len(dt):
            self.dt_med.append(float(np.median(dt)))
            self.dt_w.append(len(dt))
            self.dt_sum += float(dt.sum())
            self.dt_sq += float(np.sum(dt * dt))
            self.dt_min, self.dt_max = min(self.dt_min, dt.min()), max(self.dt_max, dt.max())
        known = [c for c in (*SIGNAL_COLUMNS, *TRUTH_COLUMNS) if c in drive.data.columns and c != "surface"]
        extra = [c for c in drive.extra_columns if drive.data[c].dtype.kind in "fiub"]
        for c in (*known, *extra):
            v = drive.col(c)
            v = v[np.isfinite(v)] if c in extra else v
            if not len(v):
                continue
            agg = self.cols.setdefault(c, [math.inf, -math.inf, 0.0, 0])
            agg[0], agg[1] = min(agg[0], float(v.min())), max(agg[1], float(v.max()))
            agg[2] += float(v.sum())
            agg[3] += len(v)
        if "surface" in drive.data.columns:
            self.surface.update(drive.data["surface"].astype(str).to_numpy().tolist())
        for e in nonlinear_fraction(drive, mu_peak=self.mu_peak):
            rec = self.exc.setdefault(e.method, [0.0, 0, []])
            if np.isfinite(e.fraction):
                rec[0] += e.fraction * e.samples
                rec[1] += e.samples
            if e.detail not in rec[2]:
                rec[2].append(e.detail)
        for sh in utilisation_shares(drive):
            rec = self.util.setdefault(sh.axle, [sh.source, dict.fromkeys(sh.above, 0.0), 0.0, 0])
            defined = sh.defined * drive.n
            for lv, f in sh.above.items():
                if np.isfinite(f):
                    rec[1][lv] += f * defined
            rec[2] += defined
            rec[3] += drive.n

    def _excitation_rows(self) -> list[tuple[str, ...]]:
        rows = []
        for method, (hits, samples, details) in self.exc.items():
            frac = hits / samples if samples else math.nan
            if method == "yaw":
                detail = YAW_DETAIL.format(share=samples / self.n)
            elif len(details) == 1:
                detail = details[0]
            else:  # the chunks name different surfaces: one list of them all
                detail = _merge_details(details)
            rows.append((method, "n/a" if not np.isfinite(frac) else f"{frac:.1%}", detail))
        return rows

    def sections(self) -> list[Section]:
        drive = self.first
        assert drive is not None
        over: list[tuple[str, ...]] = [
            ("vehicle", str(drive.vehicle.name)),
            ("samples", str(self.n)),
            ("duration", f"{self.t1 - self.t0:.2f} s"),
        ]
        if self.dt_w:
            order = np.argsort(self.dt_med)
            cum = np.cumsum(np.asarray(self.dt_w)[order])
            med = float(np.asarray(self.dt_med)[order][np.searchsorted(cum, cum[-1] / 2.0)])
            m = int(cum[-1])
            jitter = math.sqrt(max(self.dt_sq / m - (self.dt_sum / m) ** 2, 0.0)) / med
            over.append((
                "sample rate",
                f"{1.0 / med:.2f} Hz (dt median {med * 1e3:.2f} ms, jitter std/median {jitter:.1%}, "
                f"min {self.dt_min * 1e3:.2f} ms, max {self.dt_max * 1e3:.2f} ms)",
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
        for c in (*SIGNAL_COLUMNS, *TRUTH_COLUMNS):
            if c in self.cols and c not in extra_cols:
                lo, hi, total, count = self.cols[c]
                sig.append((c, UNITS.get(c, ""), _fmt(lo), _fmt(hi), _fmt(total / count)))
        if self.surface:
            total = sum(self.surface.values())
            sig.append(("surface", "-", ", ".join(f"{k} {v / total:.0%}" for k, v in self.surface.most_common()),
                        "", ""))
        for c in extra_cols:
            if c in self.cols:
                lo, hi, total, count = self.cols[c]
                sig.append((f"{c} (extra)", "", _fmt(lo), _fmt(hi), _fmt(total / count)))
        sections = [
            Section(f"drive: {drive.meta.source}", ("item", "value"), tuple(over), header=False),
            Section("signals", ("column", "unit", "min", "max", "mean"), tuple(sig),
                    right=frozenset({"min", "max", "mean"})),
            Section("nonlinear tire excitation", ("measure", "time fraction", "definition"),
                    tuple(self._excitation_rows()), right=frozenset({"time fraction"})),
        ]
        units = _units_section(drive, self.n > drive.n)
        if units is not None:
            sections.append(units)
        if self.util:
            levels = tuple(f"time > {lv:.0%}" for lv in UTILISATION_LEVELS)
            rows = []
            for axle, (source, hits, defined, total) in self.util.items():
                src = _UTIL_FROM[source](axle[0])
                if defined < total:
                    src += f" (defined at {defined / total:.1%} of the samples)"
                rows.append((axle, *("n/a" if not defined else f"{hits[lv] / defined:.1%}"
                                     for lv in UTILISATION_LEVELS), src))
            sections.append(Section("friction utilisation |F| / (mu Fz) (truth)",
                                    ("axle", *levels, "from"), tuple(rows), right=frozenset(levels)))
        return sections


def _units_section(drive: Drive, chunked: bool) -> Section | None:
    """Each kinematic pair's ratio and verdict (:func:`roadgrip.drive_units.pair_ratios`):
    consistent, rejected, or unverified where the drive cannot tell."""
    veh = drive.vehicle
    ratios = pair_ratios(drive.data, veh.wheelbase, veh.wheel_radius,
                         tuple(bool(b) for b in driven_wheels(veh.drive)))
    if not ratios:
        return None
    rows = []
    for p in ratios:
        lo, hi = PAIRS[p.pair][1:]
        verdict = ("consistent" if p.accepted else "rejected") if p.conclusive else "unverified"
        rows.append((PAIRS[p.pair][0], _fmt(p.ratio) if math.isfinite(p.ratio) else "-",
                     f"{lo:g} .. {hi:g}", f"{p.windows} of {p.excited}", verdict))
    title = "units and signs from kinematic consistency" + (" (first chunk)" if chunked else "")
    return Section(title, ("pair", "ratio", "accepted", "windows agreeing", "verdict"), tuple(rows),
                   right=frozenset({"ratio", "windows agreeing"}))
