r"""Units and sign conventions of a drive's channels from kinematic consistency.

Six identities hold on any car whatever its tires do (to the accuracy in brackets, which
sets the ratio a channel pair may have and still count as consistent):

======  ==========================  =================================================  =============
pair    identity                    channels                                           accepted
======  ==========================  =================================================  =============
``A``   ``a_y = v_x r`` (+ dv_y/dt)  ``ay`` against the speed, ``yaw_rate``            0.7 .. 1.5
``X``   ``a_x = dv_x/dt``           ``ax`` against ``vx`` (else the pose's speed)      0.7 .. 1.5
``R``   ``dpsi/dt = r``             ``psi`` against ``yaw_rate``                       0.9 .. 1.1
``S``   ``r = v_x delta / l_eff``   ``yaw_rate`` against the speed, ``steer``          0.15 .. 3
``V``   ``|v_x| = pose speed``      ``vx`` against the pose ``x, y``                   0.8 .. 1.25
``W``   ``omega R = v_x``           ``omega_*`` against the speed                      0.6 .. 1.6
======  ==========================  =================================================  =============

The speed is the pose's where the frame has one (signed as the ``vx`` column or, without
one, by the heading; wheel and encoder speeds include wheel spin), else the ``vx``
column. (``a_y`` carries the roll gain and ``dv_y/dt``; ``S`` the understeer and a steering ratio
near one; ``W`` a wheel radius off by up to 40 % and slip.)

**Evidence.** Each pair is cut into windows (0.5 s, at least 10 samples); a window counts
when its reference is excited (above a threshold), and its ratio ``sum(x y)/sum(y²)`` when
the two agree in shape (uncentred correlation >= 0.95). Samples where a channel is stuck
(the same value for more than 0.3 s: dropouts, constant or held segments), saturated (at
its extreme value, reached three times or more) or the car slower than 2 m/s (standstill)
are left out; reversing needs no exclusion, since every reference is signed. A pair's
ratio is **conclusive** with at least three counted windows, most (80 %) within 25 % of
their median, and counted windows at least half of the excited ones.

**Verdict.** Each suspected mistake (a channel in g, deg/s, degrees, km/h or rpm, or
with a flipped sign) corrects the ratios of the pairs it enters. The drive is
*consistent* when every conclusive ratio is accepted. A mistake *fits* when it enters a
rejected ratio and its correction brings every conclusive ratio it enters into range; a
channel is *wrong* when one mistake fits, or one of the fitting ones explains every
rejected ratio by itself (else the fitting mistakes are named together).
A rejected ratio that no mistake fits is left *unverified* (wheel spin, a poor pose: a
valid but unusual drive is never refused for it). :func:`roadgrip.drive.validate_frame`
refuses the wrong ones; :func:`unit_findings` reports all.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from roadgrip.constants import GRAVITY

__all__ = ["PAIRS", "PairRatio", "UnitFinding", "pair_ratios", "unit_findings"]

WINDOW = 0.5
"""Window [s] of one ratio."""
MIN_WINDOW_SAMPLES = 10
MIN_WINDOWS = 3
AGREE = 0.25
"""Relative spread of the windows' ratios around their median still counted as agreeing."""
AGREE_SHARE = 0.8
MIN_COS = 0.95
"""Uncentred correlation of a window whose ratio counts."""
STUCK = 0.3
"""A channel holding one value longer than this [s] is stuck there (dropout, hold)."""
MIN_SPEED = 1.0
"""Slowest speed [m/s] of a sample in the pairs that use the speed."""
_DEG = math.pi / 180.0
_RPM = 2.0 * math.pi / 60.0

PAIRS: dict[str, tuple[str, float, float]] = {
    "A": ("ay ~ vx*yaw_rate", 0.7, 1.5),
    "X": ("ax ~ d(vx)/dt", 0.7, 1.5),
    "R": ("d(psi)/dt ~ yaw_rate", 0.9, 1.1),
    "S": ("yaw_rate ~ vx*steer/wheelbase", 0.15, 3.0),
    "V": ("|vx| ~ pose speed", 0.8, 1.25),
    "W": ("omega*R ~ vx", 0.6, 1.6),
}
"""Pairs: ``(description, lowest and highest accepted ratio)``."""

# Suspected mistakes: (column, name of the suspected unit, factor to SI, expected SI unit)
MISTAKES: tuple[tuple[str, str, float, str], ...] = (
    ("ay", "g", GRAVITY, "m/s²"), ("ay", "a flipped sign", -1.0, "+left"),
    ("ax", "g", GRAVITY, "m/s²"), ("ax", "a flipped sign", -1.0, "+forward"),
    ("yaw_rate", "deg/s", _DEG, "rad/s"), ("yaw_rate", "a flipped sign", -1.0, "+counter-clockwise"),
    ("steer", "degrees", _DEG, "rad"), ("steer", "a flipped sign", -1.0, "+left"),
    ("vx", "km/h", 1.0 / 3.6, "m/s"), ("vx", "a flipped sign", -1.0, "+forward"),
    ("psi", "degrees", _DEG, "rad"), ("psi", "a flipped sign", -1.0, "+counter-clockwise"),
    ("omega", "rpm", _RPM, "rad/s"),
)  # fmt: skip


@dataclass(frozen=True)
class PairRatio:
    """The measured ratio of one pair.

    Attributes
    ----------
    pair : str
        Key of :data:`PAIRS`.
    ratio : float
        Median of the counted windows' ratios (NaN without any).
    windows, excited : int
        Counted windows and windows with an excited reference.
    conclusive : bool
    numerator, denominator : tuple of str
        Channels in the measured side and in the reference (a channel's correction
        factor multiplies or divides the ratio).
    signs : tuple of str
        Channels that only sign the reference (a flip of one flips the ratio).
    unsigned : bool
        The pair compares magnitudes: no flip changes it.
    """

    pair: str
    ratio: float
    windows: int
    excited: int
    conclusive: bool
    numerator: tuple[str, ...]
    denominator: tuple[str, ...]
    signs: tuple[str, ...] = ()
    unsigned: bool = False

    @property
    def accepted(self) -> bool:
        lo, hi = PAIRS[self.pair][1:]
        return lo <= self.ratio <= hi

    def corrected(self, column: str, factor: float) -> float:
        """The ratio once ``column`` is multiplied by ``factor``."""
        r = self.ratio
        if self.unsigned:
            factor = abs(factor)
        r *= factor ** self.numerator.count(column)
        r /= factor ** self.denominator.count(column)
        if factor < 0 and column in self.signs:
            r = -r
        return r

    def describe(self) -> str:
        return (f"{PAIRS[self.pair][0]} is {self.ratio:.3g} over {self.windows} windows "
                f"of {WINDOW:g} s")


@dataclass(frozen=True)
class UnitFinding:
    """A verdict on a drive's units and signs.

    Attributes
    ----------
    status : {'wrong', 'unverified'}
        ``'wrong'``: conclusive evidence for the mistakes named; ``'unverified'``:
        the pairs disagree and no single mistake explains it.
    columns : tuple of str
        The suspected columns (one for a clear verdict).
    message : str
        One line naming the column, the suspected unit and the evidence.
    """

    status: str
    columns: tuple[str, ...]
    message: str


def _usable(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Samples of a channel that are neither stuck nor at a saturation plateau."""
    n = len(v)
    ok = np.isfinite(v)
    if n < 3:
        return ok
    same = np.concatenate(([False], np.diff(v) == 0))
    # runs of repeated values: a run's start time vs its end time
    start = np.flatnonzero(~same)
    ends = np.append(start[1:], n)
    t_end = t[np.minimum(ends, n - 1)]
    long = (t_end - t[start]) > STUCK
    run_id = np.cumsum(~same) - 1
    ok &= ~long[run_id]
    for extreme in (np.max(v), np.min(v)):
        at = v == extreme
        if at.sum() >= 3 and extreme != 0.0:
            ok &= ~at
    return ok


def _ratio(t: np.ndarray, x: np.ndarray, y: np.ndarray, use: np.ndarray, excited: np.ndarray,
           pair: str, num: tuple[str, ...], den: tuple[str, ...],
           signs: tuple[str, ...] = (), unsigned: bool = False) -> PairRatio:
    """Windowed ratio of ``x`` to ``y`` over the samples ``use & excited``."""
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    w = max(math.ceil(WINDOW / dt), MIN_WINDOW_SAMPLES)
    sel = use & excited & np.isfinite(x) & np.isfinite(y)
    ratios, n_exc = [], 0
    for a in range(0, len(t) - w // 2, w):
        s = sel[a:a + w]
        if s.sum() < max(w // 2, 5):
            continue
        n_exc += 1
        xs, ys = x[a:a + w][s], y[a:a + w][s]
        yy, xx, xy = float(ys @ ys), float(xs @ xs), float(xs @ ys)
        if yy <= 0 or xx <= 0 or abs(xy) / math.sqrt(xx * yy) < MIN_COS:
            continue
        ratios.append(xy / yy)
    if not ratios:
        return PairRatio(pair, math.nan, 0, n_exc, False, num, den, signs, unsigned)
    r = np.array(ratios)
    med = float(np.median(r))
    agree = float(np.mean(np.abs(r - med) <= AGREE * abs(med))) if med != 0 else 0.0
    conclusive = (len(r) >= MIN_WINDOWS and agree >= AGREE_SHARE and len(r) >= 0.5 * n_exc)
    return PairRatio(pair, med, len(r), n_exc, conclusive, num, den, signs, unsigned)


def _pose_speed(df: pd.DataFrame, t: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Speed over ground of the pose [m/s] and the map-frame velocity's projection on the
    heading where ``psi`` exists (its sign: forward or reversing); None without a moving pose."""
    if not {"x", "y"} <= set(df.columns) or len(t) < 3:
        return None
    dx = _smooth_derivative(df["x"].to_numpy(float), t, 0.2)
    dy = _smooth_derivative(df["y"].to_numpy(float), t, 0.2)
    v = np.hypot(dx, dy)
    if not np.nanmax(v, initial=0.0) > 0.5:
        return None
    if "psi" in df.columns:
        psi = df["psi"].to_numpy(float)
        return v, np.cos(psi) * dx + np.sin(psi) * dy
    return v, np.ones(len(v))


def _smooth_derivative(v: np.ndarray, t: np.ndarray, span: float = 0.5) -> np.ndarray:
    """Central difference over about ``span`` [s] (robust to sensor noise); NaN at the ends."""
    dt = float(np.median(np.diff(t)))
    w = max(1, int(0.5 * span / dt))
    out = np.full(len(v), np.nan)
    if len(v) > 2 * w:
        out[w:-w] = (v[2 * w:] - v[:-2 * w]) / (t[2 * w:] - t[:-2 * w])
    return out


def pair_ratios(df: pd.DataFrame, wheelbase: float | None = None, wheel_radius: float | None = None,
                driven: tuple[bool, bool, bool, bool] | None = None) -> list[PairRatio]:
    """The ratio of every pair the frame's columns allow (:data:`PAIRS`).

    Parameters
    ----------
    df : DataFrame
        Finite canonical columns, ``t`` strictly increasing.
    wheelbase : float, optional
        [m], for pair ``S`` (left out without it).
    wheel_radius : float, optional
        [m], for pair ``W`` (left out without it).
    driven : tuple of 4 bool, optional
        Driven wheels ``fl, fr, rl, rr`` (left out of pair ``W`` unless all are); default none.

    Returns
    -------
    list of PairRatio
    """
    cols = set(df.columns)
    if "t" not in cols or len(df) < 2 * MIN_WINDOW_SAMPLES:
        return []
    t = df["t"].to_numpy(float)
    if not np.all(np.diff(t) > 0):
        return []
    col = {c: df[c].to_numpy(float) for c in cols if c != "t" and df[c].dtype.kind in "fiub"}
    use = {c: _usable(v, t) for c, v in col.items()}
    out: list[PairRatio] = []
    pose = _pose_speed(df, t)
    # the speed: the pose's where the frame has one (wheel and encoder speeds include wheel
    # spin), signed as the vx column (else by the heading); else the vx column. A held
    # speed is harmless (a reference, not the channel judged).
    v, v_cols, v_signs = None, (), ()
    if pose is not None:
        if "vx" in col:
            v, v_signs = np.where(col["vx"] < 0, -pose[0], pose[0]), ("vx",)
        else:
            v = np.where(pose[1] < 0, -pose[0], pose[0])
            v_signs = ("psi",) if "psi" in col else ()
    elif "vx" in col:
        v, v_cols = col["vx"], ("vx",)
    v_ok = np.ones(len(t), bool)
    if v is not None:
        moving = np.abs(v) >= MIN_SPEED
        if {"ay", "yaw_rate"} <= cols:
            kin = v * col["yaw_rate"]
            out.append(_ratio(t, col["ay"], kin, use["ay"] & use["yaw_rate"] & v_ok & moving,
                              np.abs(kin) > 1.0, "A", ("ay",), (*v_cols, "yaw_rate"), v_signs))
        if "ax" in cols and len(t) >= 4 * MIN_WINDOW_SAMPLES:
            # the speed sensor where present: a differentiated pose is too noisy twice over
            vs, x_cols, x_signs = (col["vx"], ("vx",), ()) if "vx" in col else (v, v_cols, v_signs)
            dv = _smooth_derivative(vs, t)
            out.append(_ratio(t, col["ax"], dv, use["ax"] & v_ok & moving, np.abs(dv) > 0.5,
                              "X", ("ax",), x_cols, x_signs))
        if {"yaw_rate", "steer"} <= cols and wheelbase:
            kin = v * col["steer"] / wheelbase
            calm = np.abs(col["ay"]) < 3.0 if "ay" in col else np.ones(len(t), bool)
            out.append(_ratio(t, col["yaw_rate"], kin, use["yaw_rate"] & use["steer"] & v_ok
                              & moving & calm, np.abs(kin) > 0.03, "S", ("yaw_rate",),
                              (*v_cols, "steer"), v_signs))
        names = ("omega_fl", "omega_fr", "omega_rl", "omega_rr")
        free = [not (driven and driven[i]) for i in range(4)]
        if not any(free):  # all-wheel drive: all four, as the speed estimate uses them
            free = [True] * 4
        wheels = [c for c, f in zip(names, free, strict=True) if f and c in col]
        if wheels and wheel_radius:
            om = np.mean([col[c] for c in wheels], axis=0) * wheel_radius
            ok = np.logical_and.reduce([use[c] for c in wheels]) & v_ok & moving
            out.append(_ratio(t, np.abs(om), np.abs(v), ok, np.abs(v) > MIN_SPEED, "W",
                              ("omega",), v_cols, unsigned=True))
    if {"psi", "yaw_rate"} <= cols:
        rate = _smooth_derivative(np.unwrap(col["psi"]), t, 0.2)
        out.append(_ratio(t, rate, col["yaw_rate"], use["psi"] & use["yaw_rate"],
                          np.abs(col["yaw_rate"]) > 0.05, "R", ("psi",), ("yaw_rate",)))
    if "vx" in col and pose is not None:  # magnitudes: the sign of vx is judged in A, X, S
        out.append(_ratio(t, np.abs(col["vx"]), pose[0], use["vx"], pose[0] > MIN_SPEED, "V",
                          ("vx",), (), unsigned=True))
    return out


def unit_findings(df: pd.DataFrame, wheelbase: float | None = None, wheel_radius: float | None = None,
                  driven: tuple[bool, bool, bool, bool] | None = None) -> list[UnitFinding]:
    """Channels in a wrong unit or with a flipped sign, from :func:`pair_ratios`.

    Parameters
    ----------
    df : DataFrame
        Finite canonical columns (a frame that passed the other checks of
        :func:`roadgrip.drive.validate_frame`).
    wheelbase, wheel_radius, driven
        See :func:`pair_ratios`.

    Returns
    -------
    list of UnitFinding
        Empty when every conclusive pair is consistent (or none is conclusive).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> t = np.arange(0, 20, 0.01)
    >>> r = 0.2 * np.sin(0.5 * t)
    >>> df = pd.DataFrame({"t": t, "vx": 15.0 + 0 * t, "yaw_rate": r, "ay": 15.0 * r / 9.80665})
    >>> unit_findings(df)[0].message.split(",")[0]
    "ay looks like it is in g (column 'ay')"
    """
    ratios = [p for p in pair_ratios(df, wheelbase, wheel_radius, driven) if p.conclusive]
    bad = [p for p in ratios if not p.accepted]
    if not bad:
        return []
    fits = []
    for column, unit, factor, expected in MISTAKES:
        involved = [p for p in ratios if column in p.numerator + p.denominator + p.signs]
        if not any(not p.accepted for p in involved):
            continue
        if all(PAIRS[p.pair][1] <= p.corrected(column, factor) <= PAIRS[p.pair][2] for p in involved):
            fits.append((column, unit, factor, expected))
    def enters(c: str, p: PairRatio) -> bool:
        return c in p.numerator + p.denominator + p.signs

    # the simplest explanation: a mistake that explains every rejected ratio by itself
    whole = [f for f in fits if all(enters(f[0], p) for p in bad)]
    fits = whole or fits
    explained = {p.pair for p in bad for c, *_ in fits if enters(c, p)}
    rest = [p for p in bad if p.pair not in explained]
    out = []
    if rest:
        out.append(UnitFinding(
            "unverified", tuple(sorted({c for p in rest for c in p.numerator + p.denominator})),
            f"units not verified: {'; '.join(p.describe() for p in rest)}, which no single unit "
            "or sign mistake explains"))
    if not fits:
        return out
    bad = [p for p in bad if p.pair in explained]
    evidence = "; ".join(p.describe() for p in bad)
    if len(fits) == 1:
        column, unit, factor, expected = fits[0]
        name = "omega_*" if column == "omega" else column
        if factor == -1.0:
            what = f"{name} looks like it has a flipped sign (column {name!r}, expected {expected})"
        else:
            what = (f"{name} looks like {'it is in ' if unit == 'g' else ''}{unit} (column "
                    f"{name!r}), expected {expected}: multiply by {factor:.6g}")
        return [UnitFinding("wrong", (column,), f"{what}: {evidence}"), *out]
    names = " or ".join(
        f"{'omega_*' if c == 'omega' else c!r} {'has a flipped sign' if f == -1.0 else 'is in ' + u}"
        for c, u, f, _ in fits)
    return [UnitFinding("wrong", tuple(c for c, *_ in fits),
                        f"a unit or sign is wrong, {names}: {evidence}"), *out]
