r"""Tire-friction models: normalised force ``mu = F / Fz`` as a function of slip.

All models are vectorised over arbitrary array shapes and are odd functions of
slip, so that positive slip gives positive friction (the sign convention of the
GP-SSM paper, where the slip angle is ``alpha = -arctan(v_y / v_x)`` at the
wheel). Slip is the lateral slip angle ``alpha`` [rad] or the longitudinal slip
ratio ``kappa`` [-]; the models do not care which.

==============  ==========================================================
model           formula
==============  ==========================================================
Magic Formula   ``D sin(C atan(B s - E (B s - atan(B s))))``  (Pacejka 2006)
Brush (Fiala)   cubic in ``tan(s)`` up to full sliding, then ``mu``
Burckhardt      ``sign(s) (c1 (1 - exp(-c2 |s|)) - c3 |s|)``
Linear          ``k s`` (no saturation)
==============  ==========================================================

References
----------
H. B. Pacejka, *Tire and Vehicle Dynamics*, 2nd ed., Butterworth-Heinemann, 2006.
E. Fiala, "Seitenkräfte am rollenden Luftreifen", VDI-Z 96, 1954; as written in
J. Svendenius, *Tire Modeling and Friction Estimation*, PhD thesis, Lund 2007.
U. Kiencke and L. Nielsen, *Automotive Control Systems*, 2nd ed., Springer 2005,
Table 7.1 (Burckhardt parameters).
MathWorks, *Tire-Road Interaction (Magic Formula)* block reference, table of
typical B, C, D, E values for dry/wet tarmac, snow and ice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "SURFACES",
    "BrushTire",
    "Burckhardt",
    "FrictionModel",
    "LinearTire",
    "MagicFormula",
    "Surface",
    "bracketed_root",
    "brush_force",
    "get_surface",
    "model_from_dict",
]


@runtime_checkable
class FrictionModel(Protocol):
    """A static friction curve ``mu(slip)``; every model below satisfies it."""

    def mu(self, slip: ArrayLike) -> NDArray[np.float64]:
        """Normalised force [-] at slip ``slip`` [rad or -], same shape."""

    def peak(self) -> tuple[float, float]:
        """``(slip_at_peak, mu_peak)`` for positive slip."""

    def slope0(self) -> float:
        """``d mu / d slip`` at zero slip [1/rad or -]."""

    def with_peak(self, mu_peak: float) -> FrictionModel:
        """The same curve shape scaled to a new peak friction."""

    def to_dict(self) -> dict:
        """A JSON/YAML-serialisable description (``model_from_dict`` inverts it)."""


def bracketed_root(f: Callable[[float], float], lo: float, hi: float, *, xtol: float = 2e-12,
                   max_iter: int = 500) -> float:
    """A root of a continuous ``f`` whose sign changes on ``[lo, hi]``, to ``xtol``.

    False position with the Illinois modification (the function value kept at an end
    that survives two steps in a row is halved), and a bisection step whenever a step
    has not halved the bracket, so that the bracket at least halves every two steps.
    It stops when the bracket is narrower than ``xtol + 4 eps max(|lo|, |hi|)`` and
    returns its middle: within that tolerance of a root, as
    :func:`scipy.optimize.brentq` with the same ``xtol`` (whose import takes 0.4 s and
    40 MB, more than the rest of ``roadgrip info``).

    Parameters
    ----------
    f : callable
        ``f(x) -> float``.
    lo, hi : float
        Ends of the bracket (either order).
    xtol : float
        Absolute tolerance [unit of x].
    max_iter : int
        Most function evaluations after the two ends.

    Returns
    -------
    float

    Raises
    ------
    ValueError
        ``f`` has the same sign (or NaN) at both ends, or no convergence in ``max_iter``.

    Examples
    --------
    >>> abs(bracketed_root(lambda x: x * x - 2.0, 0.0, 2.0, xtol=1e-14) - 2**0.5) < 1e-14
    True
    """
    lo, hi = (float(lo), float(hi)) if lo <= hi else (float(hi), float(lo))
    flo, fhi = float(f(lo)), float(f(hi))
    if flo == 0.0:
        return lo
    if fhi == 0.0:
        return hi
    if not ((flo < 0.0 < fhi) or (fhi < 0.0 < flo)):
        raise ValueError(f"f must change sign on [{lo!r}, {hi!r}]; f = {flo!r}, {fhi!r} at the ends")
    eps = np.finfo(float).eps
    kept = 0  # which end the last step kept: -1 lo, +1 hi
    bisect = False
    for _ in range(max_iter):
        width = hi - lo
        if width <= xtol + 4.0 * eps * max(abs(lo), abs(hi)):
            return 0.5 * (lo + hi)
        x = 0.5 * (lo + hi) if bisect else (lo * fhi - hi * flo) / (fhi - flo)
        if not lo < x < hi:
            x = 0.5 * (lo + hi)
        fx = float(f(x))
        if fx == 0.0:
            return x
        if math.isnan(fx):
            raise ValueError(f"f is NaN at {x!r}")
        if (fx < 0.0) == (flo < 0.0):
            lo, flo = x, fx
            if kept == 1:
                fhi *= 0.5
            kept = 1
        else:
            hi, fhi = x, fx
            if kept == -1:
                flo *= 0.5
            kept = -1
        bisect = hi - lo > 0.5 * width
    raise ValueError(f"no root to {xtol:g} on [{lo!r}, {hi!r}] after {max_iter} steps")


def _positive(name: str, value: float) -> None:
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be positive and finite, got {value!r}")


@dataclass(frozen=True)
class MagicFormula:
    """Pacejka Magic Formula, ``mu(s) = D sin(C atan(B s - E (B s - atan(B s))))``.

    Parameters
    ----------
    B : float
        Stiffness factor [1/rad or -].
    C : float
        Shape factor [-]; ``C > 1`` gives a peak followed by a drop.
    D : float
        Peak friction [-]; the curve's maximum equals ``D`` when ``C >= 1``.
    E : float
        Curvature factor [-], ``E <= 1``.

    Examples
    --------
    >>> mf = MagicFormula(B=10.0, C=1.9, D=1.0, E=0.97)
    >>> round(mf.slope0(), 6)
    19.0
    """

    B: float
    C: float
    D: float
    E: float = 0.0

    def __post_init__(self) -> None:
        _positive("B", self.B)
        _positive("C", self.C)
        _positive("D", self.D)
        if not np.isfinite(self.E) or self.E > 1.0:
            raise ValueError(f"E must be finite and <= 1, got {self.E!r}")

    def mu(self, slip: ArrayLike) -> NDArray[np.float64]:
        bs = self.B * np.asarray(slip, dtype=float)
        return self.D * np.sin(self.C * np.arctan(bs - self.E * (bs - np.arctan(bs))))

    def dmu(self, slip: ArrayLike) -> NDArray[np.float64]:
        """Analytic derivative ``d mu / d slip``."""
        s = np.asarray(slip, dtype=float)
        bs = self.B * s
        inner = bs - self.E * (bs - np.arctan(bs))
        dinner = self.B * (1.0 - self.E + self.E / (1.0 + bs**2))
        return self.D * np.cos(self.C * np.arctan(inner)) * self.C * dinner / (1.0 + inner**2)

    def slope0(self) -> float:
        return float(self.B * self.C * self.D)

    def peak(self) -> tuple[float, float]:
        if self.C <= 1.0:
            # Monotone curve: the supremum is approached at infinite slip.
            return float("inf"), float(self.D * np.sin(self.C * np.pi / 2))
        # C atan(x) = pi/2 at the peak, x = inner argument; solve for slip.
        x_target = np.tan(np.pi / (2 * self.C))

        def f(bs: float) -> float:
            return bs - self.E * (bs - np.arctan(bs)) - x_target

        hi = 1.0
        while f(hi) < 0:
            hi *= 2.0
        bs_peak = bracketed_root(f, 0.0, hi, xtol=1e-14)
        return float(bs_peak / self.B), float(self.D)

    def with_peak(self, mu_peak: float) -> MagicFormula:
        return replace(self, D=float(mu_peak))

    def to_dict(self) -> dict:
        return {"model": "magic_formula", "B": self.B, "C": self.C, "D": self.D, "E": self.E}


@dataclass(frozen=True)
class BrushTire:
    """Fiala brush model with a parabolic pressure distribution, normalised by ``Fz``.

    With ``z = tan(s)``, ``k`` the normalised cornering stiffness and ``mu`` the
    friction coefficient, the force up to full sliding is

    ``mu(s) = k z - k² |z| z / (3 mu) + k³ z³ / (27 mu²)``  for ``|z| < 3 mu / k``

    and ``mu sign(z)`` beyond. The expression is a polynomial in ``z``, so it is
    finite, continuous and smooth at zero slip (no ``1/s`` term); it meets the
    sliding branch with zero slope.

    Parameters
    ----------
    mu_peak : float
        Friction coefficient ``mu`` [-] (the saturation level of ``F / Fz``).
    stiffness : float
        Normalised cornering (or slip) stiffness ``C / Fz`` [1/rad or -].
    """

    mu_peak: float
    stiffness: float

    def __post_init__(self) -> None:
        _positive("mu_peak", self.mu_peak)
        _positive("stiffness", self.stiffness)

    @property
    def slip_sliding(self) -> float:
        """Slip at which the whole contact patch slides [rad or -]."""
        return float(np.arctan(3.0 * self.mu_peak / self.stiffness))

    def mu(self, slip: ArrayLike) -> NDArray[np.float64]:
        return brush_force(np.asarray(slip, dtype=float), 1.0, self.mu_peak, self.stiffness)

    def slope0(self) -> float:
        return float(self.stiffness)

    def peak(self) -> tuple[float, float]:
        return self.slip_sliding, float(self.mu_peak)

    def with_peak(self, mu_peak: float) -> BrushTire:
        return replace(self, mu_peak=float(mu_peak))

    def to_dict(self) -> dict:
        return {"model": "brush", "mu_peak": self.mu_peak, "stiffness": self.stiffness}


def brush_force(
    slip: ArrayLike, fz: ArrayLike, mu: ArrayLike, c_stiff: ArrayLike
) -> NDArray[np.float64]:
    """Fiala brush force ``F`` [N] (or normalised when ``fz = 1``), vectorised.

    Parameters
    ----------
    slip : array_like
        Slip angle [rad] (or slip ratio).
    fz : array_like
        Normal load [N], ``>= 0``.
    mu : array_like
        Friction coefficient [-], ``> 0``.
    c_stiff : array_like
        Cornering stiffness per unit load ``C / Fz`` [1/rad].

    Returns
    -------
    ndarray
        Broadcast shape of the inputs. ``|F| <= mu fz`` everywhere.
    """
    z = np.tan(np.clip(np.asarray(slip, dtype=float), -1.5, 1.5))
    mu = np.asarray(mu, dtype=float)
    k = np.asarray(c_stiff, dtype=float)
    fz = np.asarray(fz, dtype=float)
    az = np.abs(z)
    z_sl = 3.0 * mu / k
    poly = k * z - k**2 * az * z / (3.0 * mu) + k**3 * z**3 / (27.0 * mu**2)
    return fz * np.where(az < z_sl, poly, mu * np.sign(z))


@dataclass(frozen=True)
class Burckhardt:
    """Burckhardt friction curve ``mu(s) = c1 (1 - exp(-c2 s)) - c3 s`` for ``s >= 0``.

    Extended as an odd function to negative slip.

    Parameters
    ----------
    c1 : float
        Maximum of the exponential part [-].
    c2 : float
        Shape [-].
    c3 : float
        Linear decrease after the peak [-], ``>= 0``.
    """

    c1: float
    c2: float
    c3: float

    def __post_init__(self) -> None:
        _positive("c1", self.c1)
        _positive("c2", self.c2)
        if not np.isfinite(self.c3) or self.c3 < 0:
            raise ValueError(f"c3 must be >= 0, got {self.c3!r}")

    def mu(self, slip: ArrayLike) -> NDArray[np.float64]:
        s = np.asarray(slip, dtype=float)
        a = np.abs(s)
        return np.sign(s) * (self.c1 * (1.0 - np.exp(-self.c2 * a)) - self.c3 * a)

    def slope0(self) -> float:
        return float(self.c1 * self.c2 - self.c3)

    def peak(self) -> tuple[float, float]:
        if self.c3 == 0:
            return float("inf"), float(self.c1)
        s = float(np.log(self.c1 * self.c2 / self.c3) / self.c2)
        return s, float(self.mu(s))

    def with_peak(self, mu_peak: float) -> Burckhardt:
        scale = mu_peak / self.peak()[1]
        return Burckhardt(self.c1 * scale, self.c2, self.c3 * scale)

    def to_dict(self) -> dict:
        return {"model": "burckhardt", "c1": self.c1, "c2": self.c2, "c3": self.c3}


@dataclass(frozen=True)
class LinearTire:
    """Linear tire ``mu(s) = stiffness * s``, optionally clipped at ``mu_max``.

    Parameters
    ----------
    stiffness : float
        Normalised stiffness [1/rad or -].
    mu_max : float
        Saturation [-]; ``inf`` (default) gives the purely linear model.
    """

    stiffness: float
    mu_max: float = float("inf")

    def __post_init__(self) -> None:
        _positive("stiffness", self.stiffness)
        if not self.mu_max > 0:  # inf allowed: the unsaturated linear model
            raise ValueError(f"mu_max must be positive (inf for no saturation), got {self.mu_max!r}")

    def mu(self, slip: ArrayLike) -> NDArray[np.float64]:
        s = self.stiffness * np.asarray(slip, dtype=float)
        return np.clip(s, -self.mu_max, self.mu_max)

    def slope0(self) -> float:
        return float(self.stiffness)

    def peak(self) -> tuple[float, float]:
        return float(self.mu_max / self.stiffness), float(self.mu_max)

    def with_peak(self, mu_peak: float) -> LinearTire:
        return replace(self, mu_max=float(mu_peak))

    def to_dict(self) -> dict:
        return {"model": "linear", "stiffness": self.stiffness, "mu_max": self.mu_max}


_MODELS = {
    "magic_formula": MagicFormula,
    "brush": BrushTire,
    "burckhardt": Burckhardt,
    "linear": LinearTire,
}


def model_from_dict(d: dict) -> FrictionModel:
    """Rebuild a friction model from :meth:`to_dict` output.

    Raises
    ------
    ValueError
        If the model name is unknown or the parameters do not fit it.
    """
    d = dict(d)
    name = d.pop("model", None)
    if name not in _MODELS:
        raise ValueError(f"unknown tire model {name!r}; expected one of {sorted(_MODELS)}")
    try:
        return _MODELS[name](**d)
    except TypeError as exc:
        raise ValueError(f"bad parameters for tire model {name!r}: {exc}") from None


@dataclass(frozen=True)
class Surface:
    """A road surface: nominal peak friction and curves for both slip directions.

    Attributes
    ----------
    name : str
        Label used in drives and scenarios (``'dry_asphalt'``, ...).
    mu_peak : float
        Nominal peak friction [-].
    lateral : MagicFormula
        ``mu`` against slip angle [rad], for the lateral (cornering) direction.
    longitudinal : MagicFormula
        ``mu`` against slip ratio [-].
    burckhardt : Burckhardt or None
        Burckhardt longitudinal curve where a published set exists.
    """

    name: str
    mu_peak: float
    lateral: MagicFormula
    longitudinal: MagicFormula
    burckhardt: Burckhardt | None = None


# Longitudinal Magic Formula sets: MathWorks Tire-Road Interaction table
# (dry tarmac 10/1.9/1/0.97, wet 12/2.3/0.82/1, snow 5/2/0.3/1, ice 4/2/0.1/1).
# Burckhardt sets: Kiencke & Nielsen (2005), Table 7.1.
# Lateral sets: shape C = 1.4-1.6 and normalised cornering stiffness B C D of
# 8-16 /rad, typical of passenger-car tires (Pacejka 2006, ch. 4), scaled
# down on loose and frozen surfaces; gravel follows the 0.55-0.65 peak and
# lower stiffness reported for loose gravel (Selmanaj et al. use it as the
# low-grip surface of their dry/gravel/dry test).
SURFACES: dict[str, Surface] = {
    "dry_asphalt": Surface(
        "dry_asphalt",
        1.0,
        lateral=MagicFormula(B=11.0, C=1.45, D=1.0, E=-0.2),
        longitudinal=MagicFormula(B=10.0, C=1.9, D=1.0, E=0.97),
        burckhardt=Burckhardt(1.2801, 23.99, 0.52),
    ),
    "wet_asphalt": Surface(
        "wet_asphalt",
        0.75,
        lateral=MagicFormula(B=13.0, C=1.45, D=0.75, E=-0.2),
        longitudinal=MagicFormula(B=12.0, C=2.3, D=0.82, E=1.0),
        burckhardt=Burckhardt(0.857, 33.822, 0.347),
    ),
    "gravel": Surface(
        "gravel",
        0.6,
        lateral=MagicFormula(B=12.0, C=1.35, D=0.6, E=-0.5),
        longitudinal=MagicFormula(B=7.0, C=1.6, D=0.6, E=0.5),
        burckhardt=Burckhardt(1.3713, 6.4565, 0.6691).with_peak(0.6),
    ),
    "snow": Surface(
        "snow",
        0.3,
        lateral=MagicFormula(B=24.0, C=1.4, D=0.3, E=0.0),
        longitudinal=MagicFormula(B=5.0, C=2.0, D=0.3, E=1.0),
        burckhardt=Burckhardt(0.1946, 94.129, 0.0646),
    ),
    "ice": Surface(
        "ice",
        0.1,
        lateral=MagicFormula(B=40.0, C=1.4, D=0.1, E=0.0),
        longitudinal=MagicFormula(B=4.0, C=2.0, D=0.1, E=1.0),
        burckhardt=Burckhardt(0.05, 306.39, 0.0),
    ),
}
"""Named surface presets; see the comment above for sources."""

BURCKHARDT_PUBLISHED_PEAKS: dict[str, tuple[float, float]] = {
    # (slip at peak, peak friction) as tabulated for the Burckhardt curves.
    "dry_asphalt": (0.17, 1.17),
    "wet_asphalt": (0.13, 0.80),
    "snow": (0.06, 0.19),
}


def get_surface(name: str) -> Surface:
    """Look up a surface preset by name, with a clear error for unknown names."""
    try:
        return SURFACES[name]
    except KeyError:
        raise ValueError(f"unknown surface {name!r}; expected one of {sorted(SURFACES)}") from None
